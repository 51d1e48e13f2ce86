//! Novelty search (Lehman & Stanley, "Abandoning Objectives", 2011) over behaviour
//! descriptors: a genome's novelty is the mean distance from its descriptor to its `k` nearest
//! neighbours among the generation's other genomes and an archive of past behaviours, and the
//! next generation is bred from the most novel by the paper's GA scheme ([`crate::ga`]: elites
//! and their mutated copies), so the only change from the GA is what is ranked.
//!
//! Blending: with `fitness_weight` w the ranked score is (1 - w) x the genome's novelty rank
//! share plus w x its fitness rank share (each in [0, 1], 1 for the first): ranks, not raw
//! values, so the two mix whatever their scales; w = 0 is pure novelty, w = 1 the GA.
//!
//! The archive: after each generation the descriptors of its `archive_per_generation` most
//! novel genomes join it; past `archive_size` the oldest leave. It is part of the saved state.
//! Nothing here draws at random but the GA's reproduction, from the run's seed, so a run is
//! deterministic and a resumed one continues bit for bit. The run's result (`best`) is the
//! fittest genome of the last generation, as for the GA: novelty finds behaviours, the task's
//! fitness still judges them.

use crate::ga::{Ga, GaSettings, GaState, ranking};
use crate::{Evaluation, Strategy, StrategyError, StrategyState, check_results};
use serde::{Deserialize, Serialize};

/// Novelty search's name in experiment files and saved states.
pub const ALGORITHM: &str = "novelty";

/// The most archived behaviours: every generation measures each genome against all of them.
pub const MAX_ARCHIVE: u32 = 100_000;

/// Novelty search's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct NoveltySettings {
    /// The GA's reproduction (population, elites, mutation, initial genes, gene range).
    pub ga: GaSettings,
    /// k: the nearest neighbours a genome's novelty averages over.
    pub neighbours: u32,
    /// Descriptors added to the archive after each generation: its most novel genomes'.
    pub archive_per_generation: u32,
    /// The most descriptors the archive keeps; the oldest leave first.
    pub archive_size: u32,
    /// The weight of fitness against novelty in the ranked score, in [0, 1].
    pub fitness_weight: f64,
}

impl Default for NoveltySettings {
    /// The paper's GA, k = 15 and 5 archived per generation as in Lehman & Stanley's maze
    /// experiments, an archive of 2,000, pure novelty.
    fn default() -> NoveltySettings {
        NoveltySettings {
            ga: GaSettings::default(),
            neighbours: 15,
            archive_per_generation: 5,
            archive_size: 2_000,
            fitness_weight: 0.0,
        }
    }
}

impl NoveltySettings {
    /// Checks the settings' domain, naming the key at fault.
    pub fn check(&self) -> Result<(), StrategyError> {
        self.ga.check()?;
        let fail =
            |key: &'static str, message: String| Err(StrategyError::Settings { key, message });
        if self.neighbours == 0 {
            return fail("novelty_neighbours", "must be at least 1".into());
        }
        if self.archive_size > MAX_ARCHIVE {
            return fail(
                "novelty_archive_size",
                format!("must be at most {MAX_ARCHIVE}, got {}", self.archive_size),
            );
        }
        if self.archive_per_generation > self.ga.population {
            return fail(
                "novelty_archive_per_generation",
                format!(
                    "must be at most the population ({}), got {}",
                    self.ga.population, self.archive_per_generation
                ),
            );
        }
        if !(0.0..=1.0).contains(&self.fitness_weight) {
            return fail(
                "novelty_fitness_weight",
                format!("must be in [0, 1], got {}", self.fitness_weight),
            );
        }
        Ok(())
    }
}

/// Novelty search's whole state: the GA's and the archive.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoveltyState {
    /// The run's seed: every draw of the run derives from it.
    pub run_seed: u64,
    /// Generations told so far.
    pub generation: u32,
    /// The population to evaluate next.
    pub population: Vec<Vec<f32>>,
    /// The fittest genome of the last generation told; `None` before anything was told.
    pub best: Option<Vec<f32>>,
    /// The archived behaviour descriptors, oldest first.
    pub archive: Vec<Vec<f64>>,
}

/// Novelty search as a [`Strategy`].
#[derive(Debug, Clone)]
pub struct Novelty {
    settings: NoveltySettings,
    ga: Ga,
    archive: Vec<Vec<f64>>,
}

impl Novelty {
    /// A new run: the GA's initial population and an empty archive.
    pub fn start(
        settings: NoveltySettings,
        n_genes: usize,
        run_seed: u64,
    ) -> Result<Novelty, StrategyError> {
        settings.check()?;
        let ga = Ga::start(settings.ga.clone(), n_genes, run_seed)?;
        Ok(Novelty {
            settings,
            ga,
            archive: Vec::new(),
        })
    }

    /// A run continued from its saved state, which must fit the settings and `n_genes`.
    pub fn resume(
        settings: NoveltySettings,
        n_genes: usize,
        state: NoveltyState,
    ) -> Result<Novelty, StrategyError> {
        settings.check()?;
        let NoveltyState {
            run_seed,
            generation,
            population,
            best,
            archive,
        } = state;
        if archive.len() > settings.archive_size as usize {
            return Err(StrategyError::State(format!(
                "an archive of {} behaviours, the settings keep {}",
                archive.len(),
                settings.archive_size
            )));
        }
        let dimensions = archive.first().map_or(0, Vec::len);
        if archive
            .iter()
            .any(|d| d.len() != dimensions || d.iter().any(|v| !v.is_finite()))
        {
            return Err(StrategyError::State(
                "an archive of behaviours of different lengths or non-finite values".into(),
            ));
        }
        let ga_state = GaState {
            run_seed,
            generation,
            population,
            best,
        };
        let ga = Ga::resume(settings.ga.clone(), n_genes, ga_state)?;
        Ok(Novelty {
            settings,
            ga,
            archive,
        })
    }
}

/// Each descriptor's novelty: the mean distance to its `k` nearest among the other
/// descriptors and the archive (fewer when there are fewer; 0 when there are none).
pub fn novelty_scores(descriptors: &[Vec<f64>], archive: &[Vec<f64>], k: usize) -> Vec<f64> {
    descriptors
        .iter()
        .enumerate()
        .map(|(idx, own)| {
            let mut distances: Vec<f64> = descriptors
                .iter()
                .enumerate()
                .filter(|&(other, _)| other != idx)
                .map(|(_, d)| d)
                .chain(archive)
                .map(|other| {
                    own.iter()
                        .zip(other)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt()
                })
                .collect();
            let k = k.min(distances.len());
            if k == 0 {
                return 0.0;
            }
            distances.select_nth_unstable_by(k - 1, f64::total_cmp);
            let mut nearest = distances[..k].to_vec();
            // Summed in a fixed order, so the score does not depend on the selection's.
            nearest.sort_by(f64::total_cmp);
            nearest.iter().sum::<f64>() / k as f64
        })
        .collect()
}

/// Each genome's share of the ranking, 1 for the first and 0 for the last.
fn rank_shares(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    let mut shares = vec![1.0; n];
    if n > 1 {
        for (rank, idx) in ranking(values).into_iter().enumerate() {
            shares[idx] = (n - 1 - rank) as f64 / (n - 1) as f64;
        }
    }
    shares
}

impl Strategy for Novelty {
    fn algorithm(&self) -> &'static str {
        ALGORITHM
    }

    fn generation(&self) -> u32 {
        self.ga.generation()
    }

    fn ask(&self) -> &[Vec<f32>] {
        self.ga.ask()
    }

    fn tell(&mut self, results: &[Evaluation]) -> Result<(), StrategyError> {
        check_results(self.ga.ask().len(), results)?;
        let dimensions = self
            .archive
            .first()
            .map_or(results[0].descriptor.len(), Vec::len);
        if dimensions == 0 {
            return Err(StrategyError::Tell(
                "novelty search needs each genome's behaviour descriptor; none was told".into(),
            ));
        }
        if let Some(genome_idx) = results.iter().position(|r| {
            r.descriptor.len() != dimensions || r.descriptor.iter().any(|v| !v.is_finite())
        }) {
            return Err(StrategyError::Tell(format!(
                "genome {genome_idx}'s descriptor is {:?}, expected {dimensions} finite values",
                results[genome_idx].descriptor
            )));
        }
        let descriptors: Vec<Vec<f64>> = results.iter().map(|r| r.descriptor.clone()).collect();
        let fitness: Vec<f64> = results.iter().map(|r| r.fitness).collect();
        let novelty = novelty_scores(
            &descriptors,
            &self.archive,
            self.settings.neighbours as usize,
        );
        let weight = self.settings.fitness_weight;
        let scores: Vec<Evaluation> = rank_shares(&novelty)
            .into_iter()
            .zip(rank_shares(&fitness))
            .map(|(novel, fit)| Evaluation::new((1.0 - weight) * novel + weight * fit))
            .collect();
        let fittest = self.ga.ask()[ranking(&fitness)[0]].clone();
        self.ga.tell(&scores)?;
        self.ga.state.best = Some(fittest);
        let n_added = self.settings.archive_per_generation as usize;
        for idx in ranking(&novelty).into_iter().take(n_added) {
            self.archive.push(descriptors[idx].clone());
        }
        let excess = self
            .archive
            .len()
            .saturating_sub(self.settings.archive_size as usize);
        self.archive.drain(..excess);
        Ok(())
    }

    fn best(&self) -> Option<&[f32]> {
        self.ga.best()
    }

    fn state(&self) -> StrategyState {
        let GaState {
            run_seed,
            generation,
            population,
            best,
        } = self.ga.state.clone();
        StrategyState::Novelty(NoveltyState {
            run_seed,
            generation,
            population,
            best,
            archive: self.archive.clone(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> NoveltySettings {
        NoveltySettings {
            ga: GaSettings {
                population: 20,
                elites: 4,
                mutation_probability: 0.5,
                ..GaSettings::default()
            },
            neighbours: 3,
            archive_per_generation: 2,
            archive_size: 10,
            fitness_weight: 0.0,
        }
    }

    #[test]
    fn novelty_is_the_mean_distance_to_the_nearest_neighbours() {
        let descriptors = vec![vec![0.0, 0.0], vec![3.0, 4.0], vec![0.0, 1.0]];
        let archive = vec![vec![0.0, 2.0]];
        let scores = novelty_scores(&descriptors, &archive, 2);
        // (0,0): neighbours at 5, 1, 2 -> (1 + 2) / 2.
        assert_eq!(scores[0], 1.5);
        // (3,4): at 5, sqrt(9 + 9), sqrt(9 + 4) -> (sqrt 13 + sqrt 18) / 2.
        assert_eq!(scores[1], (13f64.sqrt() + 18f64.sqrt()) / 2.0);
        // With k above the neighbours there are, all of them.
        assert_eq!(novelty_scores(&descriptors[..1], &[], 5), vec![0.0]);
        assert_eq!(novelty_scores(&descriptors[..2], &[], 5), vec![5.0, 5.0]);
    }

    /// A toy behaviour: the first two genes; fitness: closeness of the first gene to 3.
    fn evaluate(genes: &[f32]) -> Evaluation {
        let descriptor = vec![f64::from(genes[0]), f64::from(genes[1])];
        Evaluation::with_descriptor(-(f64::from(genes[0]) - 3.0).abs(), descriptor)
    }

    /// The farthest behaviour from the start (the origin) asked for in `generations`.
    fn farthest(strategy: &mut Novelty, generations: u32) -> f64 {
        let mut farthest = 0.0f64;
        for _ in 0..generations {
            let results: Vec<Evaluation> = strategy.ask().iter().map(|g| evaluate(g)).collect();
            for result in &results {
                farthest =
                    farthest.max(result.descriptor.iter().map(|v| v * v).sum::<f64>().sqrt());
            }
            strategy.tell(&results).unwrap();
        }
        farthest
    }

    #[test]
    fn pure_novelty_goes_farther_than_fitness_and_the_archive_is_bounded() {
        let mut novelty = Novelty::start(settings(), 4, 3).unwrap();
        let by_fitness = NoveltySettings {
            fitness_weight: 1.0,
            ..settings()
        };
        let mut fitness = Novelty::start(by_fitness, 4, 3).unwrap();
        let (novel, fit) = (farthest(&mut novelty, 40), farthest(&mut fitness, 40));
        assert!(novel > 2.0 * fit, "novelty {novel}, fitness {fit}");
        let StrategyState::Novelty(state) = novelty.state() else {
            unreachable!()
        };
        assert_eq!(state.archive.len(), 10);
        assert_eq!(state.generation, 40);
    }

    #[test]
    fn fitness_weight_one_is_the_ga() {
        let blended = NoveltySettings {
            fitness_weight: 1.0,
            ..settings()
        };
        let mut novelty = Novelty::start(blended, 4, 9).unwrap();
        let mut plain = Ga::start(settings().ga, 4, 9).unwrap();
        for _ in 0..10 {
            let results: Vec<Evaluation> = plain.ask().iter().map(|g| evaluate(g)).collect();
            assert_eq!(novelty.ask(), plain.ask());
            novelty.tell(&results).unwrap();
            plain.tell(&results).unwrap();
            assert_eq!(novelty.best(), plain.best());
        }
    }

    #[test]
    fn missing_or_misshapen_descriptors_are_refused_and_change_nothing() {
        let mut novelty = Novelty::start(settings(), 4, 1).unwrap();
        let before = novelty.state();
        let n = novelty.ask().len();
        let error = novelty.tell(&vec![Evaluation::new(1.0); n]).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("needs each genome's behaviour descriptor")
        );
        let mut results: Vec<Evaluation> = novelty.ask().iter().map(|g| evaluate(g)).collect();
        results[4].descriptor.push(1.0);
        let error = novelty.tell(&results).unwrap_err();
        assert!(
            error.to_string().starts_with("genome 4's descriptor"),
            "{error}"
        );
        assert_eq!(novelty.state(), before);
    }

    #[test]
    fn bad_settings_name_their_key() {
        let key = |settings: NoveltySettings| match settings.check() {
            Err(StrategyError::Settings { key, .. }) => key,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            key(NoveltySettings {
                neighbours: 0,
                ..settings()
            }),
            "novelty_neighbours"
        );
        assert_eq!(
            key(NoveltySettings {
                fitness_weight: 1.5,
                ..settings()
            }),
            "novelty_fitness_weight"
        );
        assert_eq!(
            key(NoveltySettings {
                archive_per_generation: 21,
                ..settings()
            }),
            "novelty_archive_per_generation"
        );
        assert_eq!(
            key(NoveltySettings {
                archive_size: MAX_ARCHIVE + 1,
                ..settings()
            }),
            "novelty_archive_size"
        );
    }
}
