//! The evolutionary algorithm of the paper (SPEC section 6): a simple generational algorithm
//! without crossover. The best `elites` genomes are copied unchanged and each also gets
//! `population / elites - 1` mutated copies; a copy's every gene is mutated with probability
//! `mutation_probability` by a Gaussian offset and clamped to the gene range. Every random draw
//! comes from the run's seed ([`crate::seeds`]): the initial population from one stream, the
//! mutations that make generation g+1 from a stream of their own for g, so a run is
//! reproducible from its seed alone and its state is the population to evaluate next.

use crate::seeds::{RunStream, stream};
use crate::{
    Evaluation, Strategy, StrategyError, StrategyState, check_gene_range, check_results,
    check_spreads,
};
use rand::RngExt;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

/// The GA's name in experiment files and saved states.
pub const ALGORITHM: &str = "ga";

/// The GA's parameters; the default is the paper's.
#[derive(Debug, Clone, PartialEq)]
pub struct GaSettings {
    /// Genomes per generation.
    pub population: u32,
    /// Best genomes copied unchanged; each also gets `population / elites - 1` mutated copies.
    pub elites: u32,
    /// Probability that a gene of a copy is mutated.
    pub mutation_probability: f64,
    /// Standard deviation of the Gaussian offset added to a mutated gene.
    pub mutation_sigma: f64,
    /// Standard deviation of the initial genes (mean 0).
    pub initial_sigma: f64,
    /// Genes are clamped to this range.
    pub gene_range: [f64; 2],
}

impl Default for GaSettings {
    fn default() -> Self {
        GaSettings {
            population: 100,
            elites: 5,
            mutation_probability: 0.1,
            mutation_sigma: 1.0,
            initial_sigma: 2.0,
            gene_range: [-10.0, 10.0],
        }
    }
}

impl GaSettings {
    /// Checks the settings' domain: elites that divide a larger population, a probability, two
    /// finite non-negative spreads and a finite, non-empty gene range.
    pub fn check(&self) -> Result<(), StrategyError> {
        let fail =
            |key: &'static str, message: String| Err(StrategyError::Settings { key, message });
        if self.elites == 0
            || self.population < 2
            || !self.population.is_multiple_of(self.elites)
            || self.population == self.elites
        {
            return fail(
                "population",
                format!(
                    "population ({}) must be a multiple of elites ({}) and larger, so each elite gets the same number of mutated copies",
                    self.population, self.elites
                ),
            );
        }
        if !(0.0..=1.0).contains(&self.mutation_probability) {
            return fail(
                "mutation_probability",
                format!("must be in [0, 1], got {}", self.mutation_probability),
            );
        }
        check_spreads(&[
            ("mutation_sigma", self.mutation_sigma),
            ("initial_sigma", self.initial_sigma),
        ])?;
        check_gene_range(self.gene_range)
    }
}

/// The GA's whole state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaState {
    /// The run's seed: every draw of the run derives from it.
    pub run_seed: u64,
    /// Generations told so far (the generation `population` is).
    pub generation: u32,
    /// The population to evaluate next.
    pub population: Vec<Vec<f32>>,
    /// The fittest genome of the last generation told (ties to the lower index). Fitness is
    /// measured on each generation's fresh samples, so the latest measurement is the one
    /// trusted, as in the paper; `None` before anything was told.
    pub best: Option<Vec<f32>>,
}

/// The paper's GA as a [`Strategy`].
#[derive(Debug, Clone)]
pub struct Ga {
    settings: GaSettings,
    /// Novelty search reproduces with the GA's scheme and sets the best itself.
    pub(crate) state: GaState,
}

impl Ga {
    /// A new run: the initial population of genomes of `n_genes` genes.
    pub fn start(settings: GaSettings, n_genes: usize, run_seed: u64) -> Result<Ga, StrategyError> {
        settings.check()?;
        let population = initial_population(n_genes, &settings, run_seed);
        Ok(Ga {
            settings,
            state: GaState {
                run_seed,
                generation: 0,
                population,
                best: None,
            },
        })
    }

    /// A run continued from its saved state, which must hold a population of the settings'
    /// size of finite genomes of `n_genes` genes.
    pub fn resume(
        settings: GaSettings,
        n_genes: usize,
        state: GaState,
    ) -> Result<Ga, StrategyError> {
        settings.check()?;
        if state.population.len() != settings.population as usize {
            return Err(StrategyError::State(format!(
                "a population of {} genomes, the settings ask for {}",
                state.population.len(),
                settings.population
            )));
        }
        let genomes = state.population.iter().chain(&state.best);
        for genome in genomes {
            if genome.len() != n_genes || genome.iter().any(|g| !g.is_finite()) {
                return Err(StrategyError::State(format!(
                    "a genome of {} genes (finite: {}), expected {n_genes} finite genes",
                    genome.len(),
                    genome.iter().all(|g| g.is_finite())
                )));
            }
        }
        Ok(Ga { settings, state })
    }
}

impl Strategy for Ga {
    fn algorithm(&self) -> &'static str {
        ALGORITHM
    }

    fn generation(&self) -> u32 {
        self.state.generation
    }

    fn ask(&self) -> &[Vec<f32>] {
        &self.state.population
    }

    fn tell(&mut self, results: &[Evaluation]) -> Result<(), StrategyError> {
        check_results(self.state.population.len(), results)?;
        let fitness: Vec<f64> = results.iter().map(|r| r.fitness).collect();
        let state = &mut self.state;
        state.best = Some(state.population[ranking(&fitness)[0]].clone());
        state.population = next_generation(
            &state.population,
            &fitness,
            &self.settings,
            state.run_seed,
            state.generation,
        );
        state.generation += 1;
        Ok(())
    }

    fn best(&self) -> Option<&[f32]> {
        self.state.best.as_deref()
    }

    fn state(&self) -> StrategyState {
        StrategyState::Ga(self.state.clone())
    }
}

/// The initial population: genes drawn from N(0, initial_sigma^2), clamped to the gene range.
pub fn initial_population(n_genes: usize, settings: &GaSettings, run_seed: u64) -> Vec<Vec<f32>> {
    let mut rng = stream(run_seed, RunStream::Initial, &[]);
    let normal =
        Normal::new(0.0, settings.initial_sigma).expect("sigma checked non-negative and finite");
    let [low, high] = settings.gene_range;
    (0..settings.population)
        .map(|_| {
            (0..n_genes)
                .map(|_| normal.sample(&mut rng).clamp(low, high) as f32)
                .collect()
        })
        .collect()
}

/// Genome indices from best to worst; ties keep the lower index first, so the order is fully
/// determined by the fitness values.
pub fn ranking(fitness: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..fitness.len()).collect();
    order.sort_by(|&a, &b| fitness[b].total_cmp(&fitness[a]).then(a.cmp(&b)));
    order
}

/// The next generation from the current one and its fitness: for each elite in rank order,
/// the elite itself and then its mutated copies.
pub fn next_generation(
    population: &[Vec<f32>],
    fitness: &[f64],
    settings: &GaSettings,
    run_seed: u64,
    generation: u32,
) -> Vec<Vec<f32>> {
    let mut rng = stream(run_seed, RunStream::Mutation, &[u64::from(generation)]);
    let normal =
        Normal::new(0.0, settings.mutation_sigma).expect("sigma checked non-negative and finite");
    let copies_per_elite = (settings.population / settings.elites) as usize - 1;
    let [low, high] = settings.gene_range;
    let mut next = Vec::with_capacity(settings.population as usize);
    for &elite_idx in ranking(fitness).iter().take(settings.elites as usize) {
        let elite = &population[elite_idx];
        next.push(elite.clone());
        for _ in 0..copies_per_elite {
            next.push(
                elite
                    .iter()
                    .map(|&gene| {
                        if rng.random::<f64>() < settings.mutation_probability {
                            (f64::from(gene) + normal.sample(&mut rng)).clamp(low, high) as f32
                        } else {
                            gene
                        }
                    })
                    .collect(),
            );
        }
    }
    next
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> GaSettings {
        GaSettings::default()
    }

    /// The parent of a genome of [`marked_population`]: the marker most of its genes still carry
    /// (a copy's genes are mutated with probability 0.1, so most are left as they were).
    fn parent_of(genome: &[f32], population: &[Vec<f32>]) -> Option<usize> {
        population.iter().position(|parent| {
            let kept = genome.iter().zip(parent).filter(|(a, b)| a == b).count();
            2 * kept > genome.len()
        })
    }

    /// `n` genomes of 50 genes; genome i has every gene equal to its own marker i / 10 - 5, so
    /// any gene a copy still has unmutated names its parent.
    fn marked_population(n: usize) -> Vec<Vec<f32>> {
        (0..n).map(|i| vec![i as f32 / 10.0 - 5.0; 50]).collect()
    }

    #[test]
    fn the_five_fittest_are_kept_in_rank_order_each_with_nineteen_mutated_copies() {
        // The paper's scheme (SPEC section 6): population 100, 5 elites, each copied unchanged
        // and followed by 19 mutated copies.
        let population = marked_population(100);
        let mut fitness = vec![-1.0; 100];
        for (genome, value) in [
            (63, 0.97),
            // A tie inside the elites: the lower index ranks first.
            (70, 0.9),
            (7, 0.9),
            // A tie across the cut after the fifth: 12 and 40 are kept, 88 is not.
            (88, 0.5),
            (40, 0.5),
            (12, 0.5),
            (99, 0.49),
            (0, 0.0),
            (1, -0.5),
        ] {
            fitness[genome] = value;
        }
        const ELITES: [usize; 5] = [63, 7, 70, 12, 40];

        let next = next_generation(&population, &fitness, &params(), 1, 0);
        assert_eq!(next.len(), 100);
        let mut mutated_genes = 0;
        for (rank, &elite) in ELITES.iter().enumerate() {
            let block = &next[20 * rank..20 * (rank + 1)];
            assert_eq!(
                block[0], population[elite],
                "elite {rank} is genome {elite}"
            );
            for (copy, genome) in block[1..].iter().enumerate() {
                assert_eq!(
                    parent_of(genome, &population),
                    Some(elite),
                    "copy {copy} of elite {rank}"
                );
                mutated_genes += genome
                    .iter()
                    .zip(&population[elite])
                    .filter(|(a, b)| a != b)
                    .count();
            }
        }
        // Every genome of the next generation descends from one of the five: 20 each.
        let mut children = [0; 100];
        for genome in &next {
            children[parent_of(genome, &population).expect("a parent")] += 1;
        }
        let parents: Vec<(usize, usize)> = children
            .iter()
            .enumerate()
            .filter(|&(_, &n)| n > 0)
            .map(|(genome, &n)| (genome, n))
            .collect();
        assert_eq!(parents, [(7, 20), (12, 20), (40, 20), (63, 20), (70, 20)]);
        // The copies are mutated copies: 95 copies x 50 genes at probability 0.1 is 475 genes
        // expected, with a standard deviation of about 21.
        assert!(
            (380..=570).contains(&mutated_genes),
            "{mutated_genes} genes mutated"
        );
    }

    #[test]
    fn a_smaller_scheme_keeps_its_elites_with_population_over_elites_minus_one_copies() {
        // Population 10 with 2 elites: each elite and 4 mutated copies.
        let params = GaSettings {
            population: 10,
            elites: 2,
            ..params()
        };
        let population = marked_population(10);
        let fitness = [0.1, 0.7, -0.2, 0.3, 0.7, 0.0, 0.69, 0.2, 0.1, 0.0];
        let next = next_generation(&population, &fitness, &params, 3, 5);
        let parents: Vec<Option<usize>> = next.iter().map(|g| parent_of(g, &population)).collect();
        assert_eq!(
            parents,
            [1, 1, 1, 1, 1, 4, 4, 4, 4, 4].map(Some),
            "genomes 1 and 4 tie at 0.7 for first; 6 at 0.69 is third and not kept"
        );
        assert_eq!(next[0], population[1]);
        assert_eq!(next[5], population[4]);
    }

    #[test]
    fn ranking_orders_best_first_with_ties_by_index() {
        assert_eq!(ranking(&[]), Vec::<usize>::new());
        assert_eq!(ranking(&[0.4]), [0]);
        assert_eq!(ranking(&[0.1, 0.9, 0.5]), [1, 2, 0]);
        // Ties keep the lower index first, wherever they fall.
        assert_eq!(ranking(&[0.5, 0.5, 0.9, 0.5]), [2, 0, 1, 3]);
        // Negative fitness ranks below zero; large and tiny magnitudes keep their order.
        assert_eq!(
            ranking(&[-3.0, 1e-300, -1e-300, 2.5e6, -2.5e6, 0.25]),
            [3, 5, 1, 2, 0, 4]
        );
        // The order is IEEE 754's total order (`f64::total_cmp`), so 0.0 ranks above -0.0 even
        // though they compare equal: a "tie" between them is not broken by index.
        assert_eq!(ranking(&[-0.0, 0.0, -0.0]), [1, 0, 2]);
        // Fitness is a mean of finite sample values (the dispatcher refuses non-finite ones),
        // so infinities and NaN do not reach here; for completeness, the total order puts
        // +inf first and -inf last.
        assert_eq!(
            ranking(&[0.0, f64::NEG_INFINITY, f64::INFINITY, 1.0]),
            [2, 3, 0, 1]
        );
    }

    #[test]
    fn mutation_statistics_match_the_parameters() {
        // One elite repeated: count mutated genes and measure their offsets.
        let population = vec![vec![0.0f32; 200]; 100];
        let fitness = vec![1.0; 100];
        let mut mutated = 0usize;
        let mut total = 0usize;
        let mut sum_sq = 0.0f64;
        for generation in 0..20 {
            let next = next_generation(&population, &fitness, &params(), 9, generation);
            for (genome_idx, genome) in next.iter().enumerate() {
                if genome_idx % 20 == 0 {
                    assert!(genome.iter().all(|&g| g == 0.0), "elites are not mutated");
                    continue;
                }
                for &gene in genome {
                    total += 1;
                    if gene != 0.0 {
                        mutated += 1;
                        sum_sq += f64::from(gene) * f64::from(gene);
                    }
                }
            }
        }
        let rate = mutated as f64 / total as f64;
        assert!((rate - 0.1).abs() < 0.005, "mutation rate {rate}");
        let sigma = (sum_sq / mutated as f64).sqrt();
        assert!((sigma - 1.0).abs() < 0.03, "mutation sigma {sigma}");
    }

    #[test]
    fn genes_stay_in_range() {
        let mut p = params();
        p.initial_sigma = 50.0;
        let population = initial_population(30, &p, 4);
        assert!(
            population
                .iter()
                .flatten()
                .all(|&g| (-10.0..=10.0).contains(&g))
        );
        assert!(
            population.iter().flatten().any(|&g| g == 10.0),
            "clamping happens at the edge"
        );
    }

    #[test]
    fn initial_genes_have_the_configured_spread() {
        let population = initial_population(100, &params(), 5);
        let genes: Vec<f64> = population.iter().flatten().map(|&g| f64::from(g)).collect();
        let mean = genes.iter().sum::<f64>() / genes.len() as f64;
        let var = genes.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / genes.len() as f64;
        assert!(mean.abs() < 0.05, "{mean}");
        assert!((var.sqrt() - 2.0).abs() < 0.05, "{}", var.sqrt());
    }

    /// The bits of a run's genomes, hashed: a short pin for long sequences of them.
    fn genome_hash(genomes: &[Vec<f32>]) -> u64 {
        let bytes: Vec<u8> = genomes
            .iter()
            .flatten()
            .flat_map(|g| g.to_bits().to_le_bytes())
            .collect();
        hevo_sim_core::fnv1a(&bytes)
    }

    #[test]
    fn the_strategy_asks_for_what_the_paper_s_scheme_makes() {
        // Through the trait: the initial population, then each generation made from the last
        // by `next_generation` with that generation's fitness, which is what every stored run
        // was evolved with.
        let settings = params();
        let mut ga = Ga::start(settings.clone(), 30, 77).unwrap();
        let mut expected = initial_population(30, &settings, 77);
        assert_eq!(ga.ask(), &expected[..]);
        let mut seen = expected.clone();
        for generation in 0..4u32 {
            let fitness: Vec<f64> = (0..100)
                .map(|i| f64::from((i * 37 + generation * 11) % 23))
                .collect();
            let results: Vec<Evaluation> = fitness.iter().map(|&f| Evaluation::new(f)).collect();
            ga.tell(&results).unwrap();
            assert_eq!(ga.best(), Some(&expected[ranking(&fitness)[0]][..]));
            expected = next_generation(&expected, &fitness, &settings, 77, generation);
            assert_eq!(ga.ask(), &expected[..]);
            assert_eq!(ga.generation(), generation + 1);
            seen.extend_from_slice(&expected);
        }
        // Pinned: a change to any draw of the GA changes this.
        assert_eq!(genome_hash(&seen), PINNED_GENOME_HASH);
    }

    const PINNED_GENOME_HASH: u64 = 0xb58d_e59f_2ad7_0670;

    #[test]
    fn bad_settings_are_refused_naming_their_key() {
        let refused = |settings: GaSettings| match Ga::start(settings, 3, 0).unwrap_err() {
            StrategyError::Settings { key, .. } => key,
            other => panic!("{other}"),
        };
        let paper = GaSettings::default;
        assert_eq!(
            refused(GaSettings {
                elites: 0,
                ..paper()
            }),
            "population"
        );
        assert_eq!(
            refused(GaSettings {
                elites: 100,
                ..paper()
            }),
            "population"
        );
        assert_eq!(
            refused(GaSettings {
                population: 101,
                ..paper()
            }),
            "population"
        );
        assert_eq!(
            refused(GaSettings {
                mutation_probability: 1.5,
                ..paper()
            }),
            "mutation_probability"
        );
        assert_eq!(
            refused(GaSettings {
                mutation_sigma: f64::NAN,
                ..paper()
            }),
            "mutation_sigma"
        );
        assert_eq!(
            refused(GaSettings {
                initial_sigma: -1.0,
                ..paper()
            }),
            "initial_sigma"
        );
        assert_eq!(
            refused(GaSettings {
                gene_range: [1.0, 1.0],
                ..paper()
            }),
            "gene_range"
        );
        assert_eq!(
            refused(GaSettings {
                gene_range: [f64::NEG_INFINITY, 1.0],
                ..paper()
            }),
            "gene_range"
        );
    }
}
