//! What chance does to a solve rate measured on a finite number of samples. A post-evaluation
//! counts solves out of `n_samples` independent samples, so the count is binomial; the paper's
//! "best" is the highest of several such counts, which lies above the runs' true rates even when
//! every run is equally good. This module computes, exactly rather than by simulation, what the
//! paper's protocol would report for a set of runs, and the interval a single measured rate
//! leaves for the true one, so REPRODUCTION.md can compare like with like.

/// The probabilities of 0..=`n_samples` solves when each sample is solved with probability
/// `rate`, computed in log space so that 400 samples at 98 % do not underflow.
fn binomial_pmf(n_samples: u32, rate: f64) -> Vec<f64> {
    let n = n_samples as usize;
    let rate = rate.clamp(0.0, 1.0);
    if rate == 0.0 || rate == 1.0 {
        let mut pmf = vec![0.0; n + 1];
        pmf[if rate == 0.0 { 0 } else { n }] = 1.0;
        return pmf;
    }
    let mut ln_factorial = vec![0.0_f64; n + 1];
    for i in 1..=n {
        ln_factorial[i] = ln_factorial[i - 1] + (i as f64).ln();
    }
    (0..=n)
        .map(|k| {
            let ln_choose = ln_factorial[n] - ln_factorial[k] - ln_factorial[n - k];
            (ln_choose + k as f64 * rate.ln() + (n - k) as f64 * (1.0 - rate).ln()).exp()
        })
        .collect()
}

/// The distribution of the highest solve count among `n_runs` runs, each measured on
/// `n_samples` samples, when each run's true rate is one of `run_rates` drawn at random (with
/// replacement): the exact counterpart of bootstrapping the runs and resampling their
/// post-evaluations. Holds `P(best <= k)` for k = 0..=`n_samples`.
#[derive(Debug, Clone)]
pub struct BestOfRuns {
    n_samples: u32,
    cumulative: Vec<f64>,
}

impl BestOfRuns {
    /// `None` when there is no run to draw from, or no run or sample to count.
    pub fn new(run_rates: &[f64], n_runs: u32, n_samples: u32) -> Option<BestOfRuns> {
        if run_rates.is_empty() || n_runs == 0 || n_samples == 0 {
            return None;
        }
        let mut mixture = vec![0.0; n_samples as usize + 1];
        for &rate in run_rates {
            for (k, p) in binomial_pmf(n_samples, rate).into_iter().enumerate() {
                mixture[k] += p / run_rates.len() as f64;
            }
        }
        // The best of independent runs is at most k exactly when every run is.
        let mut below = 0.0;
        let cumulative = mixture
            .iter()
            .map(|p| {
                below += p;
                below.min(1.0).powi(n_runs as i32)
            })
            .collect();
        Some(BestOfRuns {
            n_samples,
            cumulative,
        })
    }

    /// The smallest solve rate that the best run reaches or stays below with probability at
    /// least `probability` (0.5 for the median).
    pub fn quantile(&self, probability: f64) -> f64 {
        // Rounding in the running sum can leave the last entry a hair below 1.
        let k = self
            .cumulative
            .iter()
            .position(|&c| c >= probability - 1e-12)
            .unwrap_or(self.n_samples as usize);
        k as f64 / self.n_samples as f64
    }

    /// The probability that the best run's measured rate is at least `rate`.
    pub fn chance_of_at_least(&self, rate: f64) -> f64 {
        let k = (rate * self.n_samples as f64 - 1e-9).ceil().max(0.0) as usize;
        if k == 0 {
            return 1.0;
        }
        (1.0 - self.cumulative[(k - 1).min(self.n_samples as usize)]).max(0.0)
    }
}

/// The 95 % Wilson score interval for a true rate, given `rate` measured on `n_samples`
/// samples: unlike the normal approximation, it stays inside [0, 1] at rates near 100 %.
pub fn wilson_interval(rate: f64, n_samples: u32) -> (f64, f64) {
    let n = n_samples as f64;
    let z = 1.959_963_984_540_054_f64;
    let z2 = z * z;
    let centre = (rate + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half_width = z * (rate * (1.0 - rate) / n + z2 / (4.0 * n * n)).sqrt() / (1.0 + z2 / n);
    (
        (centre - half_width).max(0.0),
        (centre + half_width).min(1.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binomial_probabilities_sum_to_one_and_peak_at_the_mean() {
        for (n, rate) in [(100, 0.85), (400, 0.98), (400, 0.5), (10, 0.0), (10, 1.0)] {
            let pmf = binomial_pmf(n, rate);
            assert!((pmf.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{n} {rate}");
            let mode = pmf
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.total_cmp(b.1))
                .unwrap()
                .0;
            assert!((mode as f64 - rate * n as f64).abs() <= 1.0, "{n} {rate}");
        }
        // A value small enough to check by hand: 2 samples at 50 %.
        assert_eq!(binomial_pmf(2, 0.5), vec![0.25, 0.5, 0.25]);
    }

    #[test]
    fn the_best_of_one_run_is_that_runs_binomial() {
        let best = BestOfRuns::new(&[0.5], 1, 2).unwrap();
        assert!((best.chance_of_at_least(1.0) - 0.25).abs() < 1e-12);
        assert!((best.chance_of_at_least(0.5) - 0.75).abs() < 1e-12);
        assert_eq!(best.chance_of_at_least(0.0), 1.0);
        assert_eq!(best.quantile(0.5), 0.5);
    }

    #[test]
    fn the_best_of_several_equal_runs_lies_above_their_true_rate() {
        // Ten runs that are all truly 85 %, measured on 100 samples each, as in the paper.
        let best = BestOfRuns::new(&[0.85], 10, 100).unwrap();
        let median = best.quantile(0.5);
        assert!((0.88..=0.92).contains(&median), "median {median}");
        assert!(best.quantile(0.05) < median && median < best.quantile(0.95));
        // Two of ten independent chances of 1 - P(X <= 90) each.
        let one_run = BestOfRuns::new(&[0.85], 1, 100).unwrap();
        let expected = 1.0 - (1.0 - one_run.chance_of_at_least(0.91)).powi(10);
        assert!((best.chance_of_at_least(0.91) - expected).abs() < 1e-9);
        // More samples per run leave less room for chance above the true rate.
        let careful = BestOfRuns::new(&[0.85], 10, 1600).unwrap();
        assert!(careful.quantile(0.5) < median);
        // Certain runs stay certain.
        let perfect = BestOfRuns::new(&[1.0], 10, 100).unwrap();
        assert_eq!(perfect.quantile(0.05), 1.0);
        assert!(BestOfRuns::new(&[], 10, 100).is_none());
    }

    #[test]
    fn the_wilson_interval_brackets_the_rate_and_narrows_with_samples() {
        let (low, high) = wilson_interval(0.93, 100);
        assert!(
            (0.86..0.87).contains(&low) && (0.96..0.97).contains(&high),
            "{low} {high}"
        );
        let (low_400, high_400) = wilson_interval(0.93, 400);
        assert!(low < low_400 && high_400 < high);
        // At 0 and 100 % the interval touches the bound (up to rounding) and opens on one side.
        let (low_zero, high_zero) = wilson_interval(0.0, 100);
        assert!(
            low_zero < 1e-12 && (0.03..0.04).contains(&high_zero),
            "{high_zero}"
        );
        let (low_one, high_one) = wilson_interval(1.0, 100);
        assert!(
            high_one > 1.0 - 1e-12 && (0.96..0.97).contains(&low_one),
            "{low_one}"
        );
    }
}
