//! hevo's search algorithms behind one seam, in the ask/tell style of evosax and pyribs: a
//! [`Strategy`] is asked for the genomes to evaluate, told their results, and says which genome
//! is its best so far; its whole state is plain serialisable data ([`StrategyState`]) that,
//! with the settings it was started with, determines everything it will ever ask for, so a run
//! saved after any generation and continued gives the genomes an uninterrupted run gives.
//!
//! The paper's generational GA ([`ga`]) is the default strategy, CMA-ES ([`cmaes`]) the
//! second, novelty search over behaviour descriptors ([`novelty`]) the third, MAP-Elites'
//! grid archive over them ([`map_elites`]) the fourth; [`seeds`] holds
//! every run-level
//! seed derivation (a run's seed, its algorithm's streams, its samples' seeds and light
//! configurations). Pure: no async runtime, network, command line or files; every random draw
//! comes from a run's seed. The engine converts an experiment file's settings into
//! [`StrategySettings`] and drives whichever strategy they choose.

pub mod cmaes;
pub mod ga;
pub mod map_elites;
pub mod novelty;
pub mod seeds;

use serde::{Deserialize, Serialize};

/// What a strategy is told about one genome it asked for.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Evaluation {
    /// The genome's fitness (the mean over its samples); finite, larger is better.
    pub fitness: f64,
    /// The genome's behaviour descriptor (each value the mean over its samples); empty when
    /// not known. Strategies that search over behaviours (novelty) need it; others ignore it.
    pub descriptor: Vec<f64>,
}

impl Evaluation {
    /// A genome's result from its fitness alone.
    pub fn new(fitness: f64) -> Evaluation {
        Evaluation {
            fitness,
            descriptor: Vec::new(),
        }
    }

    /// A genome's result with its behaviour descriptor.
    pub fn with_descriptor(fitness: f64, descriptor: Vec<f64>) -> Evaluation {
        Evaluation {
            fitness,
            descriptor,
        }
    }
}

/// A search algorithm in the ask/tell style. One generation is [`Strategy::ask`], evaluating
/// every genome asked for, then [`Strategy::tell`] with their results in the same order.
pub trait Strategy: std::fmt::Debug + Send {
    /// The algorithm's name as an experiment file writes it (`"ga"`, `"cmaes"`).
    fn algorithm(&self) -> &'static str;

    /// Generations told so far: the generation the genomes of [`Strategy::ask`] belong to.
    fn generation(&self) -> u32;

    /// The genomes to evaluate next. Asking again before telling gives the same genomes.
    fn ask(&self) -> &[Vec<f32>];

    /// The results of the genomes of [`Strategy::ask`], one per genome, in order; the
    /// strategy then moves to the next generation. A wrong number of results or a non-finite
    /// fitness is refused and leaves the strategy as it was.
    fn tell(&mut self, results: &[Evaluation]) -> Result<(), StrategyError>;

    /// The genome the strategy offers as its result so far, once it has been told anything.
    fn best(&self) -> Option<&[f32]>;

    /// The whole state: with the settings, it determines every genome asked for from here on.
    fn state(&self) -> StrategyState;

    /// The grid archive of a quality-diversity strategy (MAP-Elites), which a run saves and
    /// plots; `None` for the others.
    fn grid(&self) -> Option<&map_elites::GridArchive> {
        None
    }
}

/// A strategy's whole state, tagged with its algorithm: `{"algorithm": "ga", "state": {...}}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "algorithm", content = "state", rename_all = "snake_case")]
pub enum StrategyState {
    /// The paper's GA.
    Ga(ga::GaState),
    /// CMA-ES.
    Cmaes(cmaes::CmaesState),
    /// Novelty search.
    Novelty(novelty::NoveltyState),
    /// MAP-Elites.
    MapElites(map_elites::MapElitesState),
}

impl StrategyState {
    /// The algorithm the state belongs to.
    pub fn algorithm(&self) -> &'static str {
        match self {
            StrategyState::Ga(_) => ga::ALGORITHM,
            StrategyState::Cmaes(_) => cmaes::ALGORITHM,
            StrategyState::Novelty(_) => novelty::ALGORITHM,
            StrategyState::MapElites(_) => map_elites::ALGORITHM,
        }
    }
}

/// Which strategy a run uses, with its settings.
#[derive(Debug, Clone, PartialEq)]
pub enum StrategySettings {
    /// The paper's GA.
    Ga(ga::GaSettings),
    /// CMA-ES.
    Cmaes(cmaes::CmaesSettings),
    /// Novelty search.
    Novelty(novelty::NoveltySettings),
    /// MAP-Elites.
    MapElites(map_elites::MapElitesSettings),
}

impl StrategySettings {
    /// The algorithm's name.
    pub fn algorithm(&self) -> &'static str {
        match self {
            StrategySettings::Ga(_) => ga::ALGORITHM,
            StrategySettings::Cmaes(_) => cmaes::ALGORITHM,
            StrategySettings::Novelty(_) => novelty::ALGORITHM,
            StrategySettings::MapElites(_) => map_elites::ALGORITHM,
        }
    }

    /// Checks the settings' domain (each error names its key).
    pub fn check(&self) -> Result<(), StrategyError> {
        match self {
            StrategySettings::Ga(settings) => settings.check(),
            StrategySettings::Cmaes(settings) => settings.check(),
            StrategySettings::Novelty(settings) => settings.check(),
            StrategySettings::MapElites(settings) => settings.check(),
        }
    }

    /// A new strategy for genomes of `n_genes` genes, its draws from `run_seed`.
    pub fn start(&self, n_genes: usize, run_seed: u64) -> Result<Box<dyn Strategy>, StrategyError> {
        match self {
            StrategySettings::Ga(settings) => Ok(Box::new(ga::Ga::start(
                settings.clone(),
                n_genes,
                run_seed,
            )?)),
            StrategySettings::Cmaes(settings) => Ok(Box::new(cmaes::Cmaes::start(
                settings.clone(),
                n_genes,
                run_seed,
            )?)),
            StrategySettings::Novelty(settings) => Ok(Box::new(novelty::Novelty::start(
                settings.clone(),
                n_genes,
                run_seed,
            )?)),
            StrategySettings::MapElites(settings) => Ok(Box::new(map_elites::MapElites::start(
                settings.clone(),
                n_genes,
                run_seed,
            )?)),
        }
    }

    /// A strategy continued from a saved state, which must be of this algorithm and fit these
    /// settings and genomes of `n_genes` genes.
    pub fn resume(
        &self,
        n_genes: usize,
        state: StrategyState,
    ) -> Result<Box<dyn Strategy>, StrategyError> {
        match (self, state) {
            (StrategySettings::Ga(settings), StrategyState::Ga(state)) => {
                Ok(Box::new(ga::Ga::resume(settings.clone(), n_genes, state)?))
            }
            (StrategySettings::Cmaes(settings), StrategyState::Cmaes(state)) => Ok(Box::new(
                cmaes::Cmaes::resume(settings.clone(), n_genes, state)?,
            )),
            (StrategySettings::Novelty(settings), StrategyState::Novelty(state)) => Ok(Box::new(
                novelty::Novelty::resume(settings.clone(), n_genes, state)?,
            )),
            (StrategySettings::MapElites(settings), StrategyState::MapElites(state)) => {
                Ok(Box::new(map_elites::MapElites::resume(
                    settings.clone(),
                    n_genes,
                    state,
                )?))
            }
            (settings, state) => Err(StrategyError::State(format!(
                "the state is of algorithm '{}', the settings are for '{}'",
                state.algorithm(),
                settings.algorithm()
            ))),
        }
    }
}

/// Why a strategy cannot start, continue or take results.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StrategyError {
    /// A setting is out of its domain.
    #[error("{key}: {message}")]
    Settings {
        /// The setting's key, as an experiment file writes it.
        key: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A saved state does not fit the settings or the genome.
    #[error("the saved state does not fit: {0}")]
    State(String),
    /// The results told do not fit the genomes asked for.
    #[error("{0}")]
    Tell(String),
}

/// Refuses a spread (a standard deviation) that is not finite and at least 0, naming its key;
/// the first of `spreads` at fault is named.
pub(crate) fn check_spreads(spreads: &[(&'static str, f64)]) -> Result<(), StrategyError> {
    match spreads
        .iter()
        .find(|(_, sigma)| !(sigma.is_finite() && *sigma >= 0.0))
    {
        Some(&(key, sigma)) => Err(StrategyError::Settings {
            key,
            message: format!("must be >= 0, got {sigma}"),
        }),
        None => Ok(()),
    }
}

/// Refuses a gene range that is not finite with low < high.
pub(crate) fn check_gene_range([low, high]: [f64; 2]) -> Result<(), StrategyError> {
    if low.is_finite() && high.is_finite() && low < high {
        return Ok(());
    }
    Err(StrategyError::Settings {
        key: "gene_range",
        message: format!("must be [low, high], finite, with low < high, got [{low}, {high}]"),
    })
}

/// Refuses results that are not one finite fitness per genome asked for.
pub(crate) fn check_results(n_asked: usize, results: &[Evaluation]) -> Result<(), StrategyError> {
    if results.len() != n_asked {
        return Err(StrategyError::Tell(format!(
            "told {} results for {n_asked} genomes",
            results.len()
        )));
    }
    if let Some(genome_idx) = results.iter().position(|r| !r.fitness.is_finite()) {
        return Err(StrategyError::Tell(format!(
            "genome {genome_idx}'s fitness is {}, not a finite number",
            results[genome_idx].fitness
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    //! Every strategy through the trait alone: it improves a toy objective, and its state saved
    //! as JSON and read back continues exactly as the uninterrupted strategy does.

    use super::*;
    use proptest::prelude::{ProptestConfig, any, prop_assert, prop_assert_eq, proptest};

    /// A toy objective with its optimum at every gene = 3: minus the squared distance.
    fn toy_fitness(genes: &[f32]) -> f64 {
        -genes
            .iter()
            .map(|&g| (f64::from(g) - 3.0).powi(2))
            .sum::<f64>()
    }

    /// Asks, evaluates on the toy objective and tells, `generations` times; the best fitness of
    /// each generation.
    fn evolve(strategy: &mut dyn Strategy, generations: u32) -> Vec<f64> {
        (0..generations)
            .map(|_| {
                // The behaviour: the first and the last gene.
                let results: Vec<Evaluation> = strategy
                    .ask()
                    .iter()
                    .map(|genes| {
                        let descriptor =
                            vec![f64::from(genes[0]), f64::from(genes[genes.len() - 1])];
                        Evaluation::with_descriptor(toy_fitness(genes), descriptor)
                    })
                    .collect();
                strategy.tell(&results).unwrap();
                results
                    .iter()
                    .map(|r| r.fitness)
                    .fold(f64::NEG_INFINITY, f64::max)
            })
            .collect()
    }

    /// The strategies under test, each small enough for many cases.
    fn every_strategy() -> Vec<StrategySettings> {
        vec![
            StrategySettings::Ga(ga::GaSettings {
                population: 20,
                elites: 4,
                ..ga::GaSettings::default()
            }),
            StrategySettings::Cmaes(cmaes::CmaesSettings {
                population: 12,
                initial_sigma: 2.0,
                ..cmaes::CmaesSettings::default()
            }),
            StrategySettings::Cmaes(cmaes::CmaesSettings {
                population: 12,
                initial_sigma: 2.0,
                variant: cmaes::CmaesVariant::Separable,
                ..cmaes::CmaesSettings::default()
            }),
            StrategySettings::Cmaes(cmaes::CmaesSettings {
                population: 12,
                initial_sigma: 2.0,
                restarts: 3,
                ..cmaes::CmaesSettings::default()
            }),
            // Novelty blended with fitness, so that it too approaches the optimum.
            StrategySettings::Novelty(novelty::NoveltySettings {
                ga: ga::GaSettings {
                    population: 20,
                    elites: 4,
                    ..ga::GaSettings::default()
                },
                neighbours: 5,
                archive_per_generation: 2,
                archive_size: 30,
                fitness_weight: 0.8,
            }),
            StrategySettings::MapElites(map_elites::MapElitesSettings {
                population: 20,
                // A coarse grid, so that most parents are near the optimum's cell.
                bins: vec![2, 2],
                ranges: vec![[0.0, 6.0]; 2],
                sigma: 0.2,
                initial: 20,
                ..map_elites::MapElitesSettings::default()
            }),
            StrategySettings::MapElites(map_elites::MapElitesSettings {
                population: 20,
                bins: vec![2, 2],
                ranges: vec![[0.0, 6.0]; 2],
                variation: map_elites::Variation::IsoLine,
                sigma: 0.1,
                line_sigma: 0.2,
                initial: 30,
                ..map_elites::MapElitesSettings::default()
            }),
        ]
    }

    #[test]
    fn every_strategy_approaches_the_toy_optimum() {
        for settings in every_strategy() {
            let mut strategy = settings.start(8, 5).unwrap();
            assert_eq!(strategy.algorithm(), settings.algorithm());
            assert_eq!(strategy.best(), None, "nothing told yet");
            let best = evolve(strategy.as_mut(), 60);
            assert_eq!(strategy.generation(), 60);
            let best_genome = strategy.best().expect("told 60 generations");
            assert_eq!(best_genome.len(), 8);
            // From about -8 x (2^2 + 3^2) = -104 at the start to well within a gene's unit.
            assert!(best[0] < -20.0, "{}: {best:?}", settings.algorithm());
            assert!(best[59] > -1.0, "{}: {best:?}", settings.algorithm());
            assert!(toy_fitness(best_genome) > -1.0);
        }
    }

    #[test]
    fn bad_results_are_refused_and_change_nothing() {
        for settings in every_strategy() {
            let mut strategy = settings.start(3, 1).unwrap();
            let before = strategy.state();
            let n = strategy.ask().len();
            let error = strategy
                .tell(&vec![Evaluation::new(0.0); n - 1])
                .unwrap_err();
            assert_eq!(
                error.to_string(),
                format!("told {} results for {n} genomes", n - 1)
            );
            let mut results = vec![Evaluation::new(1.0); n];
            results[2] = Evaluation::new(f64::NAN);
            let error = strategy.tell(&results).unwrap_err();
            assert_eq!(
                error.to_string(),
                "genome 2's fitness is NaN, not a finite number"
            );
            assert_eq!(strategy.state(), before);
        }
    }

    #[test]
    fn a_state_of_another_shape_or_algorithm_is_refused() {
        let settings = |population| {
            StrategySettings::Ga(ga::GaSettings {
                population,
                elites: 4,
                ..ga::GaSettings::default()
            })
        };
        let mut strategy = settings(20).start(4, 9).unwrap();
        evolve(strategy.as_mut(), 2);
        let error = settings(20).resume(5, strategy.state()).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("the saved state does not fit: a genome of 4 genes"),
            "{error}"
        );
        let error = settings(40).resume(4, strategy.state()).unwrap_err();
        assert_eq!(
            error.to_string(),
            "the saved state does not fit: a population of 20 genomes, the settings ask for 40"
        );
        let cmaes = &every_strategy()[1];
        let error = cmaes.resume(4, strategy.state()).unwrap_err();
        assert_eq!(
            error.to_string(),
            "the saved state does not fit: the state is of algorithm 'ga', the settings are for 'cmaes'"
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Saved after `saved_at` generations as JSON, read back and continued for `more`:
        /// the same genomes asked for, the same best and the same state, bit for bit, as
        /// `saved_at + more` generations without a pause.
        #[test]
        fn a_saved_state_continues_exactly_as_the_uninterrupted_run(
            run_seed in any::<u64>(),
            n_genes in 1usize..12,
            saved_at in 0u32..8,
            more in 1u32..8,
        ) {
            for settings in every_strategy() {
                let mut straight = settings.start(n_genes, run_seed).unwrap();
                evolve(straight.as_mut(), saved_at + more);

                let mut first = settings.start(n_genes, run_seed).unwrap();
                evolve(first.as_mut(), saved_at);
                let json = serde_json::to_string(&first.state()).unwrap();
                let expected_tag = format!("{{\"algorithm\":\"{}\",\"state\":{{", settings.algorithm());
                prop_assert!(json.starts_with(&expected_tag), "{}", json);
                drop(first);
                let state: StrategyState = serde_json::from_str(&json).unwrap();
                let mut resumed = settings.resume(n_genes, state).unwrap();
                evolve(resumed.as_mut(), more);

                prop_assert_eq!(resumed.generation(), straight.generation());
                prop_assert_eq!(resumed.ask(), straight.ask());
                prop_assert_eq!(resumed.best(), straight.best());
                // As JSON, so that -0.0 and 0.0 differ as they do in a checkpoint.
                prop_assert_eq!(
                    serde_json::to_string(&resumed.state()).unwrap(),
                    serde_json::to_string(&straight.state()).unwrap()
                );
            }
        }
    }
}
