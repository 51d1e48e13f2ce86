//! Experiment files: the TOML that declares a controller hierarchy to evolve, node by node,
//! with each node's kind, topology, inputs, task, samples, cycles, generations and runs.
//! Parsing is strict (unknown keys are errors) and every error names the file, the key path and
//! what was expected, because a typo in a week-long experiment must fail in the first second.

use hevo_evolve::cmaes::{CmaesSettings, CmaesVariant};
use hevo_evolve::ga::GaSettings;
use hevo_evolve::map_elites::{MapElitesSettings, Variation};
use hevo_evolve::novelty::NoveltySettings;
use hevo_evolve::seeds::VariantDraw;
use hevo_evolve::{StrategyError, StrategySettings};
use hevo_sim_core::Scenario;
use hevo_sim_core::{ControllerFile, NodeKind};
use hevo_sim_core::{Evaluator, TaskConfig};
use hevo_sim_core::{InputGroup, SensorSet};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The bounds every experiment is held to, by `hevo run` and a service alike, so that no
/// file can make hevo allocate without limit: a generation's results are held in memory
/// (about 100 bytes per evaluation, plus the population's genes), and every batch must fit
/// a message. docs/experiment-file.md lists them.
pub mod limits {
    /// Runs per node.
    pub const RUNS: u32 = 1_000;
    /// Generations per run.
    pub const GENERATIONS: u32 = 1_000_000;
    /// Genomes per generation.
    pub const POPULATION: u32 = 100_000;
    /// Samples per genome per generation, and post-evaluation samples per variant.
    pub const SAMPLES: u32 = 100_000;
    /// Genomes x samples in one generation, and samples in one post-evaluation.
    pub const EVALUATIONS_PER_GENERATION: u64 = 1_000_000;
    /// Nodes in one experiment.
    pub const NODES: usize = 256;
    /// Characters of a node's name.
    pub const NODE_NAME_CHARS: usize = 64;
    /// Characters of the experiment's name.
    pub const EXPERIMENT_NAME_CHARS: usize = 128;
    /// Bytes one node's generation may hold in memory, as [`super::generation_bytes`]
    /// estimates them.
    pub const GENERATION_BYTES: u64 = 1 << 30;
    /// Bytes one gene costs while a generation is evaluated: the population, the copy sent
    /// for evaluation and the next generation hold it as an `f32` each, and the checkpoint
    /// writes it as decimal text (up to 16 characters).
    pub const BYTES_PER_GENE: u64 = 3 * 4 + 16;
    /// Bytes one (genome, sample) result costs while its generation is evaluated: the summary,
    /// its node use, and its copy in the message that carries it.
    pub const BYTES_PER_RESULT: u64 = 256;
}

/// What a generation of `population` genomes of `n_genes` genes, each evaluated on `samples`
/// samples, holds in memory at once, about: the genes ([`limits::BYTES_PER_GENE`] each) and
/// the results ([`limits::BYTES_PER_RESULT`] each). Shared by validation and `--dry-run`.
pub fn generation_bytes(population: u32, n_genes: usize, samples: u32) -> u64 {
    let genomes = u64::from(population);
    genomes
        .saturating_mul(n_genes as u64)
        .saturating_mul(limits::BYTES_PER_GENE)
        .saturating_add(
            genomes
                .saturating_mul(u64::from(samples))
                .saturating_mul(limits::BYTES_PER_RESULT),
        )
}

/// The genes of a node's network, as declared: its inputs, hidden neurons and outputs (two
/// for a primitive, one per child for an arbitrator).
pub fn declared_genes(node: &NodeDecl) -> usize {
    let n_inputs = node.inputs.iter().map(|group| group.width()).sum();
    let n_outputs = match node.kind {
        NodeKind::Primitive => hevo_sim_core::PRIMITIVE_OUTPUTS,
        NodeKind::Arbitrator => node.children.len(),
    };
    hevo_sim_core::CtrnnTopology::new(n_inputs, node.hidden, n_outputs).n_genes()
}

/// Refuses a node whose work would cost more than the limits allow, before anything is
/// allocated: evaluations per generation and per post-evaluation, and the memory of a
/// generation. The error is (key, message), the key relative to the node.
fn check_node_cost(
    node: &NodeDecl,
    evolution: &EvolutionParams,
    scenario: &Scenario,
) -> Result<(), (String, String)> {
    let per_generation = u64::from(evolution.population) * u64::from(node.samples);
    let post_evaluation =
        u64::from(evolution.post_evaluation_samples) * u64::from(scenario.n_variants());
    for (key, evaluations) in [
        ("samples", per_generation),
        ("evolution.post_evaluation_samples", post_evaluation),
    ] {
        if evaluations > limits::EVALUATIONS_PER_GENERATION {
            return Err((
                key.to_string(),
                format!(
                    "{evaluations} evaluations at once (population x samples, or post-evaluation samples x variants), at most {}",
                    limits::EVALUATIONS_PER_GENERATION
                ),
            ));
        }
    }
    let n_genes = declared_genes(node);
    let bytes = generation_bytes(evolution.population, n_genes, node.samples);
    if bytes > limits::GENERATION_BYTES {
        const MIB: u64 = 1024 * 1024;
        return Err((
            "evolution.population".to_string(),
            format!(
                "a generation of {} genomes of {n_genes} genes (hidden {}), each on {} samples, holds about {} MiB, at most {} MiB are accepted: lower the population, hidden or samples",
                evolution.population,
                node.hidden,
                node.samples,
                bytes.div_ceil(MIB),
                limits::GENERATION_BYTES / MIB
            ),
        ));
    }
    Ok(())
}

/// Refuses a one-off evaluation (a master's remote evaluation) of `genomes` genomes of
/// `n_genes` genes on `samples_per_variant` samples of each of `n_variants` variants that would
/// cost more than one generation of a job may: the limits a node is checked against
/// ([`limits`]). The error is (field, message), the field `genomes` or `samples`.
pub fn check_evaluation_cost(
    genomes: u32,
    n_genes: usize,
    samples_per_variant: u32,
    n_variants: u32,
) -> Result<(), (&'static str, String)> {
    if genomes > limits::POPULATION {
        return Err((
            "genomes",
            format!("{genomes} genomes, at most {}", limits::POPULATION),
        ));
    }
    if samples_per_variant > limits::SAMPLES {
        return Err((
            "samples",
            format!(
                "{samples_per_variant} samples per variant, at most {}",
                limits::SAMPLES
            ),
        ));
    }
    let samples = u64::from(samples_per_variant) * u64::from(n_variants.max(1));
    let evaluations = u64::from(genomes) * samples;
    if evaluations > limits::EVALUATIONS_PER_GENERATION {
        return Err((
            "genomes",
            format!(
                "{evaluations} evaluations at once (genomes x samples x variants), at most {}: send fewer genomes per call",
                limits::EVALUATIONS_PER_GENERATION
            ),
        ));
    }
    let samples = u32::try_from(samples).unwrap_or(u32::MAX);
    let bytes = generation_bytes(genomes, n_genes, samples);
    if bytes > limits::GENERATION_BYTES {
        const MIB: u64 = 1024 * 1024;
        return Err((
            "genomes",
            format!(
                "{genomes} genomes of {n_genes} genes, each on {samples} samples, hold about {} MiB, at most {} MiB are accepted: send fewer genomes per call",
                bytes.div_ceil(MIB),
                limits::GENERATION_BYTES / MIB
            ),
        ));
    }
    Ok(())
}

/// Whether `name` can name a node: a plain identifier (ASCII letters, digits, `_` and `-`,
/// not starting with `-`), so it is a safe directory name and a safe command-line word.
pub fn check_node_name(name: &str) -> Result<(), String> {
    let plain = name
        .bytes()
        .all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
    if name.is_empty() || name.len() > limits::NODE_NAME_CHARS || !plain || name.starts_with('-') {
        return Err(format!(
            "'{}' is not a node name: use 1 to {} letters, digits, '_' or '-' (not first)",
            cut(&name.escape_default().to_string(), 40),
            limits::NODE_NAME_CHARS
        ));
    }
    Ok(())
}

/// A problem with an experiment file.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// The file could not be read.
    #[error("{file}: cannot read: {reason}")]
    Read {
        /// The file.
        file: PathBuf,
        /// Why. Not a `source`: the message says it already, and error chains would repeat it.
        reason: std::io::Error,
    },
    /// The TOML is malformed or a key has the wrong type or is unknown. The message keeps the
    /// TOML parser's layout: the line quoted, a caret under the place.
    #[error("{file}:{}\n{message}", at_key(.path))]
    Syntax {
        /// The file.
        file: PathBuf,
        /// Key path, e.g. `node[2].hidden`.
        path: String,
        /// What was expected.
        message: String,
    },
    /// A command named a node the experiment does not have.
    #[error("no node named '{}' in {file}; nodes: {}", cut(name, 80), .known.join(", "))]
    UnknownNode {
        /// The file.
        file: PathBuf,
        /// The name given.
        name: String,
        /// The nodes there are.
        known: Vec<String>,
    },
    /// The values are inconsistent.
    #[error("{file}: at `{path}`: {message}")]
    Invalid {
        /// The file.
        file: PathBuf,
        /// Key path.
        path: String,
        /// What is wrong.
        message: String,
    },
}

/// ` at `node[2].hidden`:`, or nothing for a message without a key path.
fn at_key(path: &str) -> String {
    if path.is_empty() {
        String::new()
    } else {
        format!(" at `{path}`:")
    }
}

/// `[experiment]`: name and master seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentHeader {
    /// A short name, used in outputs.
    pub name: String,
    /// Master seed: every run's seed derives from it, the node's name and the run index.
    #[serde(default)]
    pub seed: u64,
    /// Free-text description.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
}

/// The evolutionary algorithm's parameters (SPEC section 6). Any of them may be set for the
/// whole experiment in `[evolution]` and overridden per node in `[node.evolution]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvolutionParams {
    /// The search algorithm. Left out of the serialized form when it is the paper's GA, so
    /// the fingerprints of runs made before there was a choice stay valid.
    #[serde(default, skip_serializing_if = "Algorithm::is_ga")]
    pub algorithm: Algorithm,
    /// Genomes per generation (CMA-ES's lambda).
    pub population: u32,
    /// GA: best genomes copied unchanged; each also gets `population / elites - 1` mutated
    /// copies.
    pub elites: u32,
    /// GA: probability that a gene of a copy is mutated.
    pub mutation_probability: f64,
    /// GA: standard deviation of the Gaussian offset added to a mutated gene.
    pub mutation_sigma: f64,
    /// Standard deviation of the initial genes (mean 0); CMA-ES's initial step size.
    pub initial_sigma: f64,
    /// Genes are clamped to this range.
    pub gene_range: [f64; 2],
    /// Post-evaluation samples per controller (per light configuration for maze tasks).
    pub post_evaluation_samples: u32,
    /// How a generation's samples spread over the task's light configurations or start branches.
    /// Left out of the serialized form when balanced, so the fingerprints of runs made before
    /// the choice existed stay valid.
    #[serde(default, skip_serializing_if = "TrainingVariants::is_balanced")]
    pub training_variants: TrainingVariants,
    /// CMA-ES: the full covariance matrix or its diagonal. Left out of the serialized form
    /// when full, so the fingerprints of CMA-ES runs made before the choice stay valid.
    #[serde(default, skip_serializing_if = "CmaesVariantName::is_full")]
    pub cmaes_variant: CmaesVariantName,
    /// CMA-ES: IPOP restarts at most (0: none). Left out of the serialized form when 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub restarts: u32,
    /// CMA-ES: each restart multiplies the population by this. Left out of the serialized
    /// form when 2.
    #[serde(
        default = "default_restart_population_factor",
        skip_serializing_if = "is_default_restart_population_factor"
    )]
    pub restart_population_factor: u32,
    /// Novelty search's own settings; absent (and out of the fingerprint) for the others.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub novelty: Option<NoveltyParams>,
    /// MAP-Elites' own settings; absent (and out of the fingerprint) for the others.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map_elites: Option<MapElitesParams>,
}

/// MAP-Elites' keys (`map_elites_*`). The grid's ranges are required (a descriptor quantity's
/// own range, e.g. a position's, is far wider than any world); bins left out are 10 per
/// descriptor value, filled in when the experiment is read, so a plan (and its fingerprint)
/// always holds the grid it runs on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapElitesParams {
    /// Bins along each descriptor value.
    pub bins: Vec<u32>,
    /// Each descriptor value's range, `[lo, hi]`.
    pub ranges: Vec<[f64; 2]>,
    /// `gaussian` or `iso_line`.
    pub variation: Variation,
    /// The Gaussian offset's standard deviation (iso+line's sigma_iso).
    pub sigma: f64,
    /// Iso+line's sigma_line.
    pub line_sigma: f64,
    /// Random genomes before variation starts; one population when left out.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<u32>,
}

impl Default for MapElitesParams {
    /// `hevo_evolve`'s defaults, with the grid still to be filled in from the descriptor.
    fn default() -> MapElitesParams {
        let defaults = MapElitesSettings::default();
        MapElitesParams {
            bins: Vec::new(),
            ranges: Vec::new(),
            variation: defaults.variation,
            sigma: defaults.sigma,
            line_sigma: defaults.line_sigma,
            initial: None,
        }
    }
}

/// Bins per descriptor value when a file names none.
pub const DEFAULT_MAP_ELITES_BINS: u32 = 10;

impl MapElitesParams {
    /// The grid's bins filled in for the node's descriptor where the file left them out, and
    /// the grid checked against it: one bin count and one range per descriptor value.
    fn with_descriptor(mut self, names: &[&str]) -> Result<MapElitesParams, (String, String)> {
        if self.bins.is_empty() {
            self.bins = vec![DEFAULT_MAP_ELITES_BINS; names.len()];
        }
        if self.ranges.is_empty() {
            return Err((
                "map_elites_ranges".into(),
                format!(
                    "required: the range [lo, hi] of each descriptor value ({}) to cut into bins",
                    names.join(", ")
                ),
            ));
        }
        for (key, len) in [
            ("map_elites_bins", self.bins.len()),
            ("map_elites_ranges", self.ranges.len()),
        ] {
            if len != names.len() {
                return Err((
                    key.to_string(),
                    format!(
                        "has {len} entries; the task's descriptor has {} values ({})",
                        names.len(),
                        names.join(", ")
                    ),
                ));
            }
        }
        Ok(self)
    }
}

/// Novelty search's keys (`novelty_*`), each with its default when the file leaves it out.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoveltyParams {
    /// k: the nearest neighbours a genome's novelty averages over.
    pub neighbours: u32,
    /// Descriptors added to the archive after each generation (its most novel genomes').
    pub archive_per_generation: u32,
    /// The most descriptors the archive keeps.
    pub archive_size: u32,
    /// The weight of fitness against novelty, in [0, 1].
    pub fitness_weight: f64,
}

impl Default for NoveltyParams {
    fn default() -> NoveltyParams {
        let defaults = NoveltySettings::default();
        NoveltyParams {
            neighbours: defaults.neighbours,
            archive_per_generation: defaults.archive_per_generation,
            archive_size: defaults.archive_size,
            fitness_weight: defaults.fitness_weight,
        }
    }
}

/// CMA-ES's covariance matrix as a file names it (`hevo_evolve`'s [`CmaesVariant`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CmaesVariantName {
    /// The full matrix.
    #[default]
    Full,
    /// Its diagonal: sep-CMA-ES, for large genomes.
    Separable,
}

impl CmaesVariantName {
    fn is_full(&self) -> bool {
        *self == CmaesVariantName::Full
    }
}

fn default_restart_population_factor() -> u32 {
    CmaesSettings::default().restart_population_factor
}

fn is_default_restart_population_factor(factor: &u32) -> bool {
    *factor == default_restart_population_factor()
}

/// How the samples of a generation meet a task's light configurations (or start branches). The
/// paper says only that the samples' initial conditions vary; see
/// `docs/decisions/reproduction/0019-training-variants-equal-shares.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrainingVariants {
    /// In turn, so each gets an equal share of every generation.
    #[default]
    Balanced,
    /// Each sample draws its own, uniformly at random (seeded per run and generation).
    Random,
}

impl TrainingVariants {
    fn is_balanced(&self) -> bool {
        *self == TrainingVariants::Balanced
    }
}

/// The search algorithm a node is evolved with (`hevo_evolve`'s strategies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Algorithm {
    /// The paper's generational GA.
    #[default]
    Ga,
    /// (mu/mu_w, lambda)-CMA-ES with the standard parameters.
    Cmaes,
    /// Novelty search over behaviour descriptors, bred by the GA's scheme.
    Novelty,
    /// MAP-Elites: a grid archive over behaviour descriptors.
    MapElites,
}

impl Algorithm {
    fn is_ga(&self) -> bool {
        *self == Algorithm::Ga
    }

    /// The name a file writes.
    pub fn name(self) -> &'static str {
        match self {
            Algorithm::Ga => hevo_evolve::ga::ALGORITHM,
            Algorithm::Cmaes => hevo_evolve::cmaes::ALGORITHM,
            Algorithm::Novelty => hevo_evolve::novelty::ALGORITHM,
            Algorithm::MapElites => hevo_evolve::map_elites::ALGORITHM,
        }
    }
}

impl Default for EvolutionParams {
    /// The paper's settings (the GA's come from [`GaSettings::default`]).
    fn default() -> Self {
        let ga = GaSettings::default();
        EvolutionParams {
            algorithm: Algorithm::Ga,
            population: ga.population,
            elites: ga.elites,
            mutation_probability: ga.mutation_probability,
            mutation_sigma: ga.mutation_sigma,
            initial_sigma: ga.initial_sigma,
            gene_range: ga.gene_range,
            post_evaluation_samples: 100,
            training_variants: TrainingVariants::Balanced,
            cmaes_variant: CmaesVariantName::Full,
            restarts: 0,
            restart_population_factor: default_restart_population_factor(),
            novelty: None,
            map_elites: None,
        }
    }
}

/// The edge between the file's schema and the search algorithms: what `hevo_evolve` is given.
impl EvolutionParams {
    /// The strategy the node is evolved with, and its settings.
    pub fn strategy_settings(&self) -> StrategySettings {
        let ga = GaSettings {
            population: self.population,
            elites: self.elites,
            mutation_probability: self.mutation_probability,
            mutation_sigma: self.mutation_sigma,
            initial_sigma: self.initial_sigma,
            gene_range: self.gene_range,
        };
        match self.algorithm {
            Algorithm::Ga => StrategySettings::Ga(ga),
            Algorithm::Novelty => {
                let novelty = self.novelty.unwrap_or_default();
                StrategySettings::Novelty(NoveltySettings {
                    ga,
                    neighbours: novelty.neighbours,
                    archive_per_generation: novelty.archive_per_generation,
                    archive_size: novelty.archive_size,
                    fitness_weight: novelty.fitness_weight,
                })
            }
            Algorithm::MapElites => {
                let map_elites = self.map_elites.clone().unwrap_or_default();
                StrategySettings::MapElites(MapElitesSettings {
                    population: self.population,
                    initial_sigma: self.initial_sigma,
                    gene_range: self.gene_range,
                    bins: map_elites.bins,
                    ranges: map_elites.ranges,
                    variation: map_elites.variation,
                    sigma: map_elites.sigma,
                    line_sigma: map_elites.line_sigma,
                    initial: map_elites.initial.unwrap_or(self.population),
                })
            }
            Algorithm::Cmaes => StrategySettings::Cmaes(CmaesSettings {
                population: self.population,
                initial_sigma: self.initial_sigma,
                gene_range: self.gene_range,
                variant: match self.cmaes_variant {
                    CmaesVariantName::Full => CmaesVariant::Full,
                    CmaesVariantName::Separable => CmaesVariant::Separable,
                },
                restarts: self.restarts,
                restart_population_factor: self.restart_population_factor,
            }),
        }
    }

    /// How a generation's samples are given the task's light configurations.
    pub fn variant_draw(&self) -> VariantDraw {
        match self.training_variants {
            TrainingVariants::Balanced => VariantDraw::InTurn,
            TrainingVariants::Random => VariantDraw::AtRandom,
        }
    }
}

/// An `[evolution]` table read on its own, by an experiment file's rules: the same keys,
/// defaults, checks and messages (each naming `evolution.KEY`), for what drives a strategy
/// without an experiment (the Python module's `hevo.Strategy`). `table` holds the table's keys
/// as a JSON object ([`evolution_table_from_toml`] makes one of TOML text); `file` names where
/// it came from in messages. Algorithms added to the file's schema work here unchanged.
pub fn evolution_from_table(
    table: serde_json::Value,
    file: &Path,
) -> Result<EvolutionParams, ExperimentError> {
    let overrides: EvolutionOverrides = serde_path_to_error::deserialize(table).map_err(|e| {
        let path = e.path().to_string();
        ExperimentError::Syntax {
            file: file.to_path_buf(),
            path: if path == "." {
                "evolution".to_string()
            } else {
                format!("evolution.{}", cut(&path, MAX_EXCERPT_CHARS))
            },
            message: bounded_excerpt(&e.inner().to_string()),
        }
    })?;
    let invalid = |key: &str, message: String| ExperimentError::Invalid {
        file: file.to_path_buf(),
        path: format!("evolution.{key}"),
        message,
    };
    let params = overrides.apply(&EvolutionParams::default());
    if let Some((key, owner)) = overrides.key_of_another_algorithm(params.algorithm) {
        return Err(invalid(
            key,
            format!(
                "is a setting of algorithm \"{}\"; the algorithm here is \"{}\"",
                owner.name(),
                params.algorithm.name()
            ),
        ));
    }
    validate_evolution(&params).map_err(|(key, message)| invalid(&key, message))?;
    Ok(params)
}

/// TOML text of an `[evolution]` table's keys, with or without the `[evolution]` line, as the
/// JSON object [`evolution_from_table`] reads; `file` names it in messages.
pub fn evolution_table_from_toml(
    text: &str,
    file: &Path,
) -> Result<serde_json::Value, ExperimentError> {
    let syntax = |message: String| ExperimentError::Syntax {
        file: file.to_path_buf(),
        path: String::new(),
        message: bounded_excerpt(&message),
    };
    let mut table: toml::Table = text
        .parse()
        .map_err(|e: toml::de::Error| syntax(e.to_string()))?;
    if table.len() == 1
        && let Some(toml::Value::Table(inner)) = table.remove("evolution")
    {
        table = inner;
    }
    serde_json::to_value(table).map_err(|e| syntax(e.to_string()))
}

/// Partial evolution parameters: what a file sets.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvolutionOverrides {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    algorithm: Option<Algorithm>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    population: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    elites: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mutation_probability: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    mutation_sigma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    initial_sigma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gene_range: Option<[f64; 2]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    post_evaluation_samples: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    training_variants: Option<TrainingVariants>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cmaes_variant: Option<CmaesVariantName>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    restarts: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    restart_population_factor: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    novelty_neighbours: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    novelty_archive_per_generation: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    novelty_archive_size: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    novelty_fitness_weight: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_bins: Option<Vec<u32>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_ranges: Option<Vec<[f64; 2]>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_variation: Option<Variation>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_sigma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_line_sigma: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    map_elites_initial: Option<u32>,
}

impl EvolutionOverrides {
    fn apply(&self, base: &EvolutionParams) -> EvolutionParams {
        EvolutionParams {
            algorithm: self.algorithm.unwrap_or(base.algorithm),
            population: self.population.unwrap_or(base.population),
            elites: self.elites.unwrap_or(base.elites),
            mutation_probability: self
                .mutation_probability
                .unwrap_or(base.mutation_probability),
            mutation_sigma: self.mutation_sigma.unwrap_or(base.mutation_sigma),
            initial_sigma: self.initial_sigma.unwrap_or(base.initial_sigma),
            gene_range: self.gene_range.unwrap_or(base.gene_range),
            post_evaluation_samples: self
                .post_evaluation_samples
                .unwrap_or(base.post_evaluation_samples),
            training_variants: self.training_variants.unwrap_or(base.training_variants),
            cmaes_variant: self.cmaes_variant.unwrap_or(base.cmaes_variant),
            restarts: self.restarts.unwrap_or(base.restarts),
            restart_population_factor: self
                .restart_population_factor
                .unwrap_or(base.restart_population_factor),
            novelty: self.novelty(base),
            map_elites: self.map_elites(base),
        }
    }

    /// MAP-Elites' settings, as [`EvolutionOverrides::novelty`] has novelty search's.
    fn map_elites(&self, base: &EvolutionParams) -> Option<MapElitesParams> {
        if self.algorithm.unwrap_or(base.algorithm) != Algorithm::MapElites {
            return None;
        }
        let base = base.map_elites.clone().unwrap_or_default();
        Some(MapElitesParams {
            bins: self.map_elites_bins.clone().unwrap_or(base.bins),
            ranges: self.map_elites_ranges.clone().unwrap_or(base.ranges),
            variation: self.map_elites_variation.unwrap_or(base.variation),
            sigma: self.map_elites_sigma.unwrap_or(base.sigma),
            line_sigma: self.map_elites_line_sigma.unwrap_or(base.line_sigma),
            initial: self.map_elites_initial.or(base.initial),
        })
    }

    /// Novelty search's settings: the base's (or the defaults) with this table's keys; `None`
    /// unless the algorithm in force is novelty search, so the others' fingerprints keep
    /// their form.
    fn novelty(&self, base: &EvolutionParams) -> Option<NoveltyParams> {
        if self.algorithm.unwrap_or(base.algorithm) != Algorithm::Novelty {
            return None;
        }
        let base = base.novelty.unwrap_or_default();
        Some(NoveltyParams {
            neighbours: self.novelty_neighbours.unwrap_or(base.neighbours),
            archive_per_generation: self
                .novelty_archive_per_generation
                .unwrap_or(base.archive_per_generation),
            archive_size: self.novelty_archive_size.unwrap_or(base.archive_size),
            fitness_weight: self.novelty_fitness_weight.unwrap_or(base.fitness_weight),
        })
    }

    /// The first key set here that `algorithm` does not have, with an algorithm that has it:
    /// a file that sets the GA's `elites` for a CMA-ES node is refused rather than silently
    /// ignored. (Novelty search breeds by the GA's scheme, so it has the GA's keys.)
    fn key_of_another_algorithm(&self, algorithm: Algorithm) -> Option<(&'static str, Algorithm)> {
        use Algorithm::{Cmaes, Ga, MapElites, Novelty};
        let keys: [(&'static str, bool, &[Algorithm]); 16] = [
            ("elites", self.elites.is_some(), &[Ga, Novelty]),
            (
                "mutation_probability",
                self.mutation_probability.is_some(),
                &[Ga, Novelty],
            ),
            (
                "mutation_sigma",
                self.mutation_sigma.is_some(),
                &[Ga, Novelty],
            ),
            ("cmaes_variant", self.cmaes_variant.is_some(), &[Cmaes]),
            ("restarts", self.restarts.is_some(), &[Cmaes]),
            (
                "restart_population_factor",
                self.restart_population_factor.is_some(),
                &[Cmaes],
            ),
            (
                "novelty_neighbours",
                self.novelty_neighbours.is_some(),
                &[Novelty],
            ),
            (
                "novelty_archive_per_generation",
                self.novelty_archive_per_generation.is_some(),
                &[Novelty],
            ),
            (
                "novelty_archive_size",
                self.novelty_archive_size.is_some(),
                &[Novelty],
            ),
            (
                "novelty_fitness_weight",
                self.novelty_fitness_weight.is_some(),
                &[Novelty],
            ),
            (
                "map_elites_bins",
                self.map_elites_bins.is_some(),
                &[MapElites],
            ),
            (
                "map_elites_ranges",
                self.map_elites_ranges.is_some(),
                &[MapElites],
            ),
            (
                "map_elites_variation",
                self.map_elites_variation.is_some(),
                &[MapElites],
            ),
            (
                "map_elites_sigma",
                self.map_elites_sigma.is_some(),
                &[MapElites],
            ),
            (
                "map_elites_line_sigma",
                self.map_elites_line_sigma.is_some(),
                &[MapElites],
            ),
            (
                "map_elites_initial",
                self.map_elites_initial.is_some(),
                &[MapElites],
            ),
        ];
        keys.into_iter()
            .find(|(_, set, owners)| *set && !owners.contains(&algorithm))
            .map(|(key, _, owners)| (key, owners[0]))
    }
}

/// One `[[node]]` as written in the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDecl {
    /// Unique name; children refer to it.
    pub name: String,
    /// `primitive` (drives the wheels) or `arbitrator` (chooses a child).
    pub kind: NodeKind,
    /// Input groups, in order: `ir`, `light`, `near_robot`, `rab`, `items`.
    pub inputs: Vec<InputGroup>,
    /// Hidden neurons.
    pub hidden: usize,
    /// For arbitrators: the sub-controllers, one output each, in output order: nodes of this
    /// experiment by name, or finished controllers from elsewhere (see [`ChildDecl`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub children: Vec<ChildDecl>,
    /// For arbitrators: the fewest cycles a child stays on once switched on; 0 (the default)
    /// is the paper's activator, which may switch in any cycle.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_active_cycles: u32,
    /// The task the node is evolved on: a shipped scenario (`exit_room`, `follow_wall`,
    /// `turn_left`, `turn_right`, `solve_maze`, `maze_single`, `return_room`, `rescue`) or a
    /// scenario file, a path ending in `.toml` relative to the experiment file. The key may
    /// be written `scenario`; it is the same key, serialized (and fingerprinted) as `task`.
    #[serde(alias = "scenario")]
    pub task: String,
    /// Samples per genome per generation.
    pub samples: u32,
    /// Cycle limit per sample; the task's default when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cycles: Option<u32>,
    /// Generations per run.
    pub generations: u32,
    /// Independent evolutionary runs.
    pub runs: u32,
    /// Overrides of the experiment's `[evolution]` parameters for this node.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub evolution: Option<EvolutionOverrides>,
    /// Overrides of the task's configuration, as in sim-core's `TaskConfig`: the sub-tables
    /// robot, ir, light, room, corridor and start, and the top-level keys `max_cycles` (the
    /// node's `cycles` wins when both are set), `end_on_collision`, and the task-specific flags
    /// `end_on_wrong_branch`, `rescue_time_bonus` (rescue only) and `wrong_branch_at_end_only`
    /// (solve maze and return to room only). Every key is listed in `docs/experiment-file.md`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_config: Option<toml::Table>,
}

/// One child of an arbitrator, as written: a node of the same experiment (`"follow_wall"`), a
/// finished controller file (`{ file = "../controllers/follow_wall.json" }`), or a finished node
/// of another run directory (`{ runs = "runs", node = "follow_wall" }`, its `best.json`). Paths
/// are relative to the experiment file. A controller from elsewhere is fixed: it is not evolved
/// here, and its content, like any child's, is part of the parent's fingerprint.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ChildDecl {
    /// A node of this experiment.
    Node(String),
    /// A controller file.
    File {
        /// Its path, relative to the experiment file.
        file: String,
    },
    /// A finished node of another run output directory.
    RunDir {
        /// The run output directory, relative to the experiment file.
        runs: String,
        /// The node's name there.
        node: String,
    },
}

impl ChildDecl {
    /// The node of this experiment it names, if it names one.
    pub fn node_name(&self) -> Option<&str> {
        match self {
            ChildDecl::Node(name) => Some(name),
            _ => None,
        }
    }

    /// The files a child from elsewhere is read from, relative to the experiment file: the
    /// controller, and for a run directory's node also its summary (which shows it finished).
    fn files(&self) -> Vec<String> {
        match self {
            ChildDecl::Node(_) => Vec::new(),
            ChildDecl::File { file } => vec![file.clone()],
            ChildDecl::RunDir { runs, node } => vec![
                format!("{runs}/{node}/{}", crate::rundir::BEST),
                format!("{runs}/{node}/{}", crate::rundir::SUMMARY),
            ],
        }
    }
}

impl Serialize for ChildDecl {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self {
            ChildDecl::Node(name) => serializer.serialize_str(name),
            ChildDecl::File { file } => {
                let mut map = serializer.serialize_map(Some(1))?;
                map.serialize_entry("file", file)?;
                map.end()
            }
            ChildDecl::RunDir { runs, node } => {
                let mut map = serializer.serialize_map(Some(2))?;
                map.serialize_entry("runs", runs)?;
                map.serialize_entry("node", node)?;
                map.end()
            }
        }
    }
}

impl<'de> Deserialize<'de> for ChildDecl {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Visitor;
        const EXPECTED: &str =
            "a node name, { file = \"PATH\" } or { runs = \"DIR\", node = \"NAME\" }";
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = ChildDecl;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(EXPECTED)
            }
            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<ChildDecl, E> {
                Ok(ChildDecl::Node(name.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<ChildDecl, A::Error> {
                use serde::de::Error;
                let (mut file, mut runs, mut node) = (None, None, None);
                while let Some(key) = map.next_key::<String>()? {
                    let slot = match key.as_str() {
                        "file" => &mut file,
                        "runs" => &mut runs,
                        "node" => &mut node,
                        other => {
                            return Err(A::Error::unknown_field(other, &["file", "runs", "node"]));
                        }
                    };
                    *slot = Some(map.next_value::<String>()?);
                }
                match (file, runs, node) {
                    (Some(file), None, None) => Ok(ChildDecl::File { file }),
                    (None, Some(runs), Some(node)) => Ok(ChildDecl::RunDir { runs, node }),
                    _ => Err(A::Error::custom(format!("expected {EXPECTED}"))),
                }
            }
        }
        deserializer.deserialize_any(Visitor)
    }
}

impl std::fmt::Display for ChildDecl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ChildDecl::Node(name) => write!(f, "{name}"),
            ChildDecl::File { file } => write!(f, "{file}"),
            ChildDecl::RunDir { runs, node } => write!(f, "{runs}/{node}"),
        }
    }
}

/// Where an experiment's files from elsewhere (children given as a controller file or another
/// run directory's node) are read: the disk beside the experiment file for `hevo run`, the
/// files a submission carried for a service job.
pub trait ExternalFiles {
    /// The text of the file at `path`, relative to the experiment file.
    fn read(&self, path: &str) -> std::io::Result<String>;
}

/// [`ExternalFiles`] on disk, relative to a directory; it remembers what it read, so a client
/// can send those files along with the experiment.
#[derive(Debug)]
pub struct DiskFiles {
    base: PathBuf,
    read: std::sync::Mutex<BTreeMap<String, String>>,
}

impl DiskFiles {
    /// Files relative to the directory of `experiment_file`.
    pub fn beside(experiment_file: &Path) -> DiskFiles {
        let base = experiment_file
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default();
        DiskFiles {
            base,
            read: std::sync::Mutex::new(BTreeMap::new()),
        }
    }

    /// Every file read so far, by its relative path.
    pub fn files_read(&self) -> BTreeMap<String, String> {
        self.read
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .clone()
    }
}

impl ExternalFiles for DiskFiles {
    fn read(&self, path: &str) -> std::io::Result<String> {
        let text = std::fs::read_to_string(self.base.join(path))?;
        self.read
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .insert(path.to_string(), text.clone());
        Ok(text)
    }
}

/// [`ExternalFiles`] that a submission carried, by relative path.
impl ExternalFiles for BTreeMap<String, String> {
    fn read(&self, path: &str) -> std::io::Result<String> {
        self.get(path).cloned().ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "not among the files sent with the experiment",
            )
        })
    }
}

fn is_zero(value: &u32) -> bool {
    *value == 0
}

/// The file as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ExperimentFile {
    experiment: ExperimentHeader,
    #[serde(default)]
    evolution: EvolutionOverrides,
    #[serde(rename = "node")]
    nodes: Vec<NodeDecl>,
}

/// A node with everything resolved: its evolution parameters and its full task configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodePlan {
    /// The declaration.
    pub decl: NodeDecl,
    /// Evolution parameters in force.
    pub evolution: EvolutionParams,
    /// The task configuration in force (cycles applied).
    pub task: TaskConfig,
    /// The children from elsewhere, read and checked, by their index in `decl.children`
    /// (children that are nodes of this experiment come from its run directory instead).
    pub fixed_children: BTreeMap<usize, ControllerFile>,
}

/// A parsed, validated experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// The file it came from.
    pub file: PathBuf,
    /// `[experiment]`.
    pub header: ExperimentHeader,
    /// Nodes in dependency order: every node after all its children.
    pub nodes: Vec<NodePlan>,
}

impl Experiment {
    /// Reads and validates an experiment file (and the children it takes from elsewhere).
    pub fn load(file: &Path) -> Result<Experiment, ExperimentError> {
        let text = std::fs::read_to_string(file).map_err(|reason| ExperimentError::Read {
            file: file.to_path_buf(),
            reason,
        })?;
        Experiment::parse_with(&text, file, &DiskFiles::beside(file))
    }

    /// Parses and validates experiment text; `file` is used in messages, and children from
    /// elsewhere are read relative to it.
    pub fn parse(text: &str, file: &Path) -> Result<Experiment, ExperimentError> {
        Experiment::parse_with(text, file, &DiskFiles::beside(file))
    }

    /// [`Experiment::parse`], reading children from elsewhere through `files`.
    pub fn parse_with(
        text: &str,
        file: &Path,
        files: &dyn ExternalFiles,
    ) -> Result<Experiment, ExperimentError> {
        let syntax = |path: String, message: String| ExperimentError::Syntax {
            file: file.to_path_buf(),
            path,
            message,
        };
        let deserializer = toml::Deserializer::parse(text)
            .map_err(|e| syntax(String::new(), bounded_excerpt(&e.to_string())))?;
        let parsed: ExperimentFile =
            serde_path_to_error::deserialize(deserializer).map_err(|e| {
                // A key path holds the file's own keys, which may be of any length.
                syntax(
                    cut(&e.path().to_string(), MAX_EXCERPT_CHARS),
                    bounded_excerpt(&e.inner().to_string()),
                )
            })?;
        let invalid = |path: String, message: String| ExperimentError::Invalid {
            file: file.to_path_buf(),
            path,
            message,
        };

        let base = parsed.evolution.apply(&EvolutionParams::default());
        // Each `[evolution]` table sets keys of the algorithm in force where it stands: the
        // experiment's for the experiment's algorithm, a node's for the node's.
        let another_algorithm_s = |path: String, owner: Algorithm, algorithm: Algorithm| {
            invalid(
                path,
                format!(
                    "is a setting of algorithm \"{}\"; the algorithm here is \"{}\"",
                    owner.name(),
                    algorithm.name()
                ),
            )
        };
        if let Some((key, owner)) = parsed.evolution.key_of_another_algorithm(base.algorithm) {
            return Err(another_algorithm_s(
                format!("evolution.{key}"),
                owner,
                base.algorithm,
            ));
        }
        let name = &parsed.experiment.name;
        if name.trim().is_empty()
            || name.chars().count() > limits::EXPERIMENT_NAME_CHARS
            || name.chars().any(char::is_control)
        {
            return Err(invalid(
                "experiment.name".into(),
                format!(
                    "must be 1 to {} characters without control characters",
                    limits::EXPERIMENT_NAME_CHARS
                ),
            ));
        }
        if parsed.nodes.len() > limits::NODES {
            return Err(invalid(
                "node".into(),
                format!(
                    "{} nodes, at most {} are accepted",
                    parsed.nodes.len(),
                    limits::NODES
                ),
            ));
        }
        let mut index_of: HashMap<&str, usize> = HashMap::new();
        for (node_idx, node) in parsed.nodes.iter().enumerate() {
            check_node_name(&node.name)
                .map_err(|message| invalid(format!("node[{node_idx}].name"), message))?;
            if index_of.insert(node.name.as_str(), node_idx).is_some() {
                return Err(invalid(
                    format!("node[{node_idx}].name"),
                    format!("'{}' is declared twice", node.name),
                ));
            }
        }
        if parsed.nodes.is_empty() {
            return Err(invalid(
                "node".into(),
                "at least one [[node]] is required".into(),
            ));
        }

        let mut plans: Vec<Option<NodePlan>> = vec![None; parsed.nodes.len()];
        for (node_idx, node) in parsed.nodes.iter().enumerate() {
            let at = |key: &str| format!("node[{node_idx}].{key}");
            match node.kind {
                NodeKind::Primitive if !node.children.is_empty() => {
                    return Err(invalid(
                        at("children"),
                        "a primitive drives the wheels and has no children".into(),
                    ));
                }
                NodeKind::Arbitrator if node.children.is_empty() => {
                    return Err(invalid(
                        at("children"),
                        "an arbitrator needs at least one child".into(),
                    ));
                }
                NodeKind::Primitive if node.min_active_cycles > 0 => {
                    return Err(invalid(
                        at("min_active_cycles"),
                        "only an arbitrator switches children; a primitive has none to keep on"
                            .into(),
                    ));
                }
                _ => {}
            }
            let mut fixed_children = BTreeMap::new();
            for (child_idx, child) in node.children.iter().enumerate() {
                let at_child = format!("node[{node_idx}].children[{child_idx}]");
                match child {
                    ChildDecl::Node(name) if !index_of.contains_key(name.as_str()) => {
                        return Err(invalid(
                            at_child,
                            format!("no node is named '{}'", cut(name, 80)),
                        ));
                    }
                    ChildDecl::Node(_) => {}
                    external => {
                        let controller = read_fixed_child(external, files)
                            .map_err(|message| invalid(at_child, message))?;
                        fixed_children.insert(child_idx, controller);
                    }
                }
            }
            if node.inputs.is_empty() {
                return Err(invalid(
                    at("inputs"),
                    "at least one input group is required".into(),
                ));
            }
            if node.hidden == 0 || node.hidden > 1000 {
                return Err(invalid(
                    at("hidden"),
                    format!("must be between 1 and 1000, got {}", node.hidden),
                ));
            }
            let scenario =
                node_scenario(&node.task, files).map_err(|message| invalid(at("task"), message))?;
            for (key, value, max) in [
                ("samples", node.samples, limits::SAMPLES),
                ("generations", node.generations, limits::GENERATIONS),
                ("runs", node.runs, limits::RUNS),
            ] {
                if !(1..=max).contains(&value) {
                    return Err(invalid(
                        at(key),
                        format!("must be between 1 and {max}, got {value}"),
                    ));
                }
            }
            let mut evolution = node
                .evolution
                .as_ref()
                .map_or_else(|| base.clone(), |o| o.apply(&base));
            let evolution_key = |key: &str| {
                if node.evolution.is_some() {
                    at(&format!("evolution.{key}"))
                } else {
                    format!("evolution.{key}")
                }
            };
            if let Some((key, owner)) = node
                .evolution
                .as_ref()
                .and_then(|o| o.key_of_another_algorithm(evolution.algorithm))
            {
                return Err(another_algorithm_s(
                    at(&format!("evolution.{key}")),
                    owner,
                    evolution.algorithm,
                ));
            }
            if let Some(map_elites) = evolution.map_elites.take() {
                let filled = map_elites
                    .with_descriptor(&scenario.descriptor_names())
                    .map_err(|(key, message)| invalid(evolution_key(&key), message))?;
                evolution.map_elites = Some(filled);
            }
            validate_evolution(&evolution)
                .map_err(|(key, message)| invalid(evolution_key(&key), message))?;
            // A full archive holds a genome per cell: refused before anything runs when large.
            if let StrategySettings::MapElites(settings) = evolution.strategy_settings() {
                settings
                    .check_archive_size(declared_genes(node))
                    .map_err(|error| {
                        let message = match error {
                            StrategyError::Settings { message, .. } => message,
                            other => other.to_string(),
                        };
                        invalid(evolution_key("map_elites_bins"), message)
                    })?;
            }
            check_node_cost(node, &evolution, &scenario)
                .map_err(|(key, message)| invalid(at(&key), message))?;
            if scenario.has_phases() {
                // The names the composed controller's root will know its children by.
                let children: Vec<String> = node
                    .children
                    .iter()
                    .enumerate()
                    .map(
                        |(child_idx, child)| match (child, fixed_children.get(&child_idx)) {
                            (ChildDecl::Node(name), _) => name.clone(),
                            (_, Some(controller)) => controller.root.name.clone(),
                            (_, None) => String::new(),
                        },
                    )
                    .collect();
                if node.kind != NodeKind::Arbitrator {
                    return Err(invalid(
                        at("task"),
                        format!(
                            "scenario '{}' scores an arbitrator's choices (it has phases); this node is a primitive",
                            scenario.name()
                        ),
                    ));
                }
                scenario
                    .phase_children(&children)
                    .map_err(|refusal| invalid(at("children"), refusal.to_string()))?;
            }
            let task = task_config(scenario.clone(), node)
                .map_err(|(key, message)| invalid(at(&key), message))?;
            // What an evaluator refuses (a start touching a solid) is refused here, before
            // anything runs, naming the scenario file's key as well as the node.
            Evaluator::new(task.clone()).map_err(|error| invalid(at("task"), error.to_string()))?;
            plans[node_idx] = Some(NodePlan {
                decl: node.clone(),
                evolution,
                task,
                fixed_children,
            });
        }

        // Dependency order, and no cycles.
        let mut order = Vec::with_capacity(parsed.nodes.len());
        let mut state = vec![0u8; parsed.nodes.len()]; // 0 new, 1 visiting, 2 done
        fn visit(
            node_idx: usize,
            nodes: &[NodeDecl],
            index_of: &HashMap<&str, usize>,
            state: &mut [u8],
            order: &mut Vec<usize>,
        ) -> Result<(), String> {
            match state[node_idx] {
                2 => return Ok(()),
                1 => return Err(nodes[node_idx].name.clone()),
                _ => {}
            }
            state[node_idx] = 1;
            for child in nodes[node_idx]
                .children
                .iter()
                .filter_map(ChildDecl::node_name)
            {
                visit(index_of[child], nodes, index_of, state, order)?;
            }
            state[node_idx] = 2;
            order.push(node_idx);
            Ok(())
        }
        for node_idx in 0..parsed.nodes.len() {
            visit(node_idx, &parsed.nodes, &index_of, &mut state, &mut order).map_err(|name| {
                invalid(
                    "node".into(),
                    format!("the children of '{name}' form a cycle"),
                )
            })?;
        }
        // Children first: every node's sub-tree, children evolved elsewhere included, may read
        // only the sensors its own scenario gives the robot.
        let mut groups_read: Vec<Vec<InputGroup>> = vec![Vec::new(); parsed.nodes.len()];
        for &node_idx in &order {
            let plan = plans[node_idx].as_ref().expect("each node planned once");
            let scenario = &plan.task.scenario;
            scenario
                .check_sensors(&plan.decl.inputs)
                .map_err(|message| invalid(format!("node[{node_idx}].inputs"), message))?;
            let mut read = plan.decl.inputs.clone();
            for (child_idx, child) in plan.decl.children.iter().enumerate() {
                let child_reads = match (child, plan.fixed_children.get(&child_idx)) {
                    (ChildDecl::Node(name), _) => groups_read[index_of[name.as_str()]].clone(),
                    (_, Some(controller)) => controller.root.groups_read(),
                    (_, None) => Vec::new(),
                };
                scenario.check_sensors(&child_reads).map_err(|message| {
                    invalid(
                        format!("node[{node_idx}].children[{child_idx}]"),
                        format!("the child {message}"),
                    )
                })?;
                read.extend(child_reads);
            }
            groups_read[node_idx] = SensorSet::of(&read).groups().collect();
        }
        let nodes = order
            .into_iter()
            .map(|i| plans[i].take().expect("each node planned once"))
            .collect();
        Ok(Experiment {
            file: file.to_path_buf(),
            header: parsed.experiment,
            nodes,
        })
    }

    /// The node with this name.
    pub fn node(&self, name: &str) -> Option<&NodePlan> {
        self.nodes.iter().find(|n| n.decl.name == name)
    }

    /// The node a user named: an unknown name is refused with one message, naming the file
    /// and the known nodes, whichever command (run, submit, eval, replay) asked.
    pub fn named_node(&self, name: &str) -> Result<&NodePlan, ExperimentError> {
        self.node(name).ok_or_else(|| ExperimentError::UnknownNode {
            file: self.file.clone(),
            name: name.to_string(),
            known: self.nodes.iter().map(|n| n.decl.name.clone()).collect(),
        })
    }

    /// The names of the nodes to evolve, in dependency order: `node` and everything below it,
    /// or every node when no node is named. The runner and the service both ask this, so an
    /// unknown node is refused with the same message either way.
    pub fn nodes_to_run(&self, node: Option<&str>) -> Result<Vec<String>, ExperimentError> {
        let Some(node) = node else {
            return Ok(self.nodes.iter().map(|n| n.decl.name.clone()).collect());
        };
        self.named_node(node)?;
        Ok(self.subtree(node))
    }

    /// The names of a node and everything below it, in dependency order.
    pub fn subtree(&self, name: &str) -> Vec<String> {
        let mut wanted: BTreeMap<String, ()> = BTreeMap::new();
        let mut stack = vec![name.to_string()];
        while let Some(current) = stack.pop() {
            if wanted.insert(current.clone(), ()).is_none()
                && let Some(plan) = self.node(&current)
            {
                stack.extend(
                    plan.decl
                        .children
                        .iter()
                        .filter_map(ChildDecl::node_name)
                        .map(str::to_string),
                );
            }
        }
        self.nodes
            .iter()
            .map(|n| n.decl.name.clone())
            .filter(|n| wanted.contains_key(n))
            .collect()
    }
}

/// Reads a child from elsewhere: a complete controller (every node has its genes), and for a
/// run directory's node, one that finished (it has a node summary).
fn read_fixed_child(
    child: &ChildDecl,
    files: &dyn ExternalFiles,
) -> Result<ControllerFile, String> {
    let paths = child.files();
    let controller_path = &paths[0];
    for path in &paths[1..] {
        files.read(path).map_err(|e| {
            format!("{path}: cannot read ({e}); the node must be finished in that run directory")
        })?;
    }
    let text = files
        .read(controller_path)
        .map_err(|e| format!("{controller_path}: cannot read ({e})"))?;
    let controller = ControllerFile::from_json_str(&text)
        .map_err(|e| format!("{controller_path}: not a controller file: {e}"))?;
    if let Some((node, _)) = controller.free_node_topology() {
        return Err(format!(
            "{controller_path}: node '{node}' has no genome; a fixed child must be a finished controller"
        ));
    }
    Ok(controller)
}

/// The files an experiment reads from elsewhere (its fixed children and scenario files),
/// relative to it.
pub fn external_files(experiment: &Experiment) -> Vec<String> {
    experiment
        .nodes
        .iter()
        .flat_map(|plan| {
            let scenario = plan
                .decl
                .task
                .ends_with(".toml")
                .then(|| plan.decl.task.clone());
            plan.decl
                .children
                .iter()
                .flat_map(ChildDecl::files)
                .chain(scenario)
        })
        .collect()
}

/// The widest line of a quoted input an error message keeps. An error on a 16,000-character
/// line must not quote all of it (a client receives the message, and some transports cap it).
pub const MAX_EXCERPT_CHARS: usize = 120;
/// The widest line of a parser's own text (which may still repeat a key or value of the input).
pub const MAX_MESSAGE_LINE_CHARS: usize = 400;

/// A parser's message with its lines bounded: a quoted input line (`12 | ...`) keeps at most
/// [`MAX_EXCERPT_CHARS`] characters, windowed around the caret (`^`) of the line below it so the
/// caret still points at the place; any other line at most [`MAX_MESSAGE_LINE_CHARS`].
pub fn bounded_excerpt(message: &str) -> String {
    let lines: Vec<&str> = message.lines().collect();
    let mut out: Vec<String> = Vec::with_capacity(lines.len());
    let mut line_idx = 0;
    while line_idx < lines.len() {
        let line = lines[line_idx];
        let caret_line = lines.get(line_idx + 1).copied().filter(|next| {
            let rest = next.trim_start();
            rest.starts_with('|') && rest.trim_start_matches('|').trim_start().starts_with('^')
        });
        match caret_line {
            Some(caret_line) if line.chars().count() > MAX_EXCERPT_CHARS => {
                let caret_col = caret_line.find('^').unwrap_or(0);
                let start = caret_col.saturating_sub(MAX_EXCERPT_CHARS / 2);
                let window = |text: &str| -> String {
                    // The gutter (`12 | `) stays; the rest is windowed.
                    let gutter_end = text.find('|').map_or(0, |i| i + 2).min(text.len());
                    let gutter: String = text.chars().take(gutter_end).collect();
                    let body: String = text
                        .chars()
                        .skip(start.max(gutter_end))
                        .take(MAX_EXCERPT_CHARS - gutter_end.min(MAX_EXCERPT_CHARS))
                        .collect();
                    let cut_left = start > gutter_end;
                    format!("{gutter}{}{body}", if cut_left { "…" } else { "" })
                };
                out.push(format!("{} …", window(line)));
                out.push(window(caret_line));
                line_idx += 2;
            }
            _ => {
                let quoted = line.trim_start().starts_with(|c: char| c.is_ascii_digit())
                    && line.contains(" | ");
                let max = if quoted {
                    MAX_EXCERPT_CHARS
                } else {
                    MAX_MESSAGE_LINE_CHARS
                };
                out.push(cut(line, max));
                line_idx += 1;
            }
        }
    }
    out.join("\n")
}

/// `text` cut to `max` characters, with `…` where it was cut.
pub fn cut(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        text.to_string()
    } else {
        let kept: String = text.chars().take(max).collect();
        format!("{kept} …")
    }
}

fn one_line(message: &str) -> String {
    message.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn validate_evolution(params: &EvolutionParams) -> Result<(), (String, String)> {
    let fail = |key: &str, message: String| Err((key.to_string(), message));
    if matches!(params.algorithm, Algorithm::Ga | Algorithm::Novelty)
        && (params.elites == 0
            || params.population < 2
            || !params.population.is_multiple_of(params.elites)
            || params.population == params.elites)
    {
        return fail(
            "population",
            format!(
                "population ({}) must be a multiple of elites ({}) and larger, so each elite gets the same number of mutated copies",
                params.population, params.elites
            ),
        );
    }
    if params.population > limits::POPULATION {
        return fail(
            "population",
            format!(
                "must be at most {}, got {}",
                limits::POPULATION,
                params.population
            ),
        );
    }
    // IPOP's last restart asks for population x factor^restarts genomes a generation.
    if let StrategySettings::Cmaes(settings) = params.strategy_settings()
        && settings.restarts > 0
        && settings
            .largest_population()
            .is_none_or(|largest| largest > limits::POPULATION)
    {
        return fail(
            "restarts",
            format!(
                "the last restart's population, {} x {}^{}, must be at most {}",
                params.population,
                params.restart_population_factor,
                params.restarts,
                limits::POPULATION
            ),
        );
    }
    if params.post_evaluation_samples > limits::SAMPLES {
        return fail(
            "post_evaluation_samples",
            format!(
                "must be at most {}, got {}",
                limits::SAMPLES,
                params.post_evaluation_samples
            ),
        );
    }
    if !(0.0..=1.0).contains(&params.mutation_probability) {
        return fail(
            "mutation_probability",
            format!("must be in [0, 1], got {}", params.mutation_probability),
        );
    }
    if !(params.mutation_sigma.is_finite() && params.mutation_sigma >= 0.0) {
        return fail(
            "mutation_sigma",
            format!("must be >= 0, got {}", params.mutation_sigma),
        );
    }
    if !(params.initial_sigma.is_finite() && params.initial_sigma >= 0.0) {
        return fail(
            "initial_sigma",
            format!("must be >= 0, got {}", params.initial_sigma),
        );
    }
    let [low, high] = params.gene_range;
    if !(low.is_finite() && high.is_finite() && low < high && low >= -10.0 && high <= 10.0) {
        return fail(
            "gene_range",
            format!("must be [low, high] within [-10, 10] with low < high, got [{low}, {high}]"),
        );
    }
    if params.post_evaluation_samples == 0 {
        return fail("post_evaluation_samples", "must be at least 1".into());
    }
    // What the algorithm itself asks of its settings (CMA-ES: a step size above 0).
    params
        .strategy_settings()
        .check()
        .map_err(|error| match error {
            StrategyError::Settings { key, message } => (key.to_string(), message),
            other => ("algorithm".to_string(), other.to_string()),
        })
}

/// The node's task configuration: the paper's defaults, the node's `task_config` overrides
/// (checked key by key against sim-core's schema), then `cycles`.
fn task_config(scenario: Arc<Scenario>, node: &NodeDecl) -> Result<TaskConfig, (String, String)> {
    let overrides = match &node.task_config {
        Some(overrides) => serde_json::to_value(overrides)
            .map_err(|e| ("task_config".to_string(), e.to_string()))?,
        None => serde_json::Value::Object(Default::default()),
    };
    let mut task = with_task_overrides(TaskConfig::from_scenario(scenario), overrides).map_err(
        |(key, message)| {
            let path = if key.is_empty() {
                "task_config".to_string()
            } else {
                format!("task_config.{key}")
            };
            (path, message)
        },
    )?;
    if let Some(cycles) = node.cycles {
        task.max_cycles = Some(cycles);
        task.validate()
            .map_err(|error| (format!("task_config.{}", error.key), error.message))?;
    }
    Ok(task)
}

/// `task` with some of its numbers replaced: `overrides` is an object shaped like a node's
/// `task_config` table (`{"robot": {"v_max": 0.1}, "max_cycles": 500}`), merged key by key
/// into the task and checked against sim-core's schema, then validated. The error is (key
/// path, what is wrong), the key path relative to the task (`robot.v_max`). Experiment files
/// and the Python module's `Task` take overrides through it, so both refuse the same values
/// with the same words.
pub fn with_task_overrides(
    task: TaskConfig,
    overrides: serde_json::Value,
) -> Result<TaskConfig, (String, String)> {
    let mut value = serde_json::to_value(&task).map_err(|e| ("task".to_string(), e.to_string()))?;
    for key in ["kind", "scenario"] {
        if overrides.get(key).is_some() {
            return Err((
                key.to_string(),
                "set the task with the node's `task` key".into(),
            ));
        }
    }
    merge(&mut value, overrides);
    let mut overridden: TaskConfig = serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        // serde_path_to_error names the root `.`; the caller prefixes its own key.
        let path = if path == "." { String::new() } else { path };
        (path, one_line(&e.inner().to_string()))
    })?;
    // The overrides cannot touch the scenario (refused above), so the one compiled from the
    // same text is the task's own, which knows the file it came from for later refusals.
    overridden.scenario = task.scenario;
    let task = overridden;
    task.validate()
        .map_err(|error| (error.key.clone(), error.message))?;
    Ok(task)
}

/// A node's scenario: a shipped one by name, or a scenario file (a path ending in `.toml`,
/// relative to the experiment file).
fn node_scenario(task: &str, files: &dyn ExternalFiles) -> Result<Arc<Scenario>, String> {
    if task.ends_with(".toml") {
        let text = files
            .read(task)
            .map_err(|e| format!("{}: cannot read the scenario file ({e})", cut(task, 200)))?;
        let read_controller = |written: &str| {
            let path = controller_beside(task, written);
            files
                .read(&path)
                .map_err(|e| format!("cannot read {}: {e}", cut(&path, 200)))
        };
        return Scenario::parse_with(&text, task, &read_controller)
            .map(Arc::new)
            .map_err(|e| e.to_string());
    }
    Scenario::shipped(task).ok_or_else(|| {
        format!(
            "unknown task '{}', expected a scenario file (a path ending in .toml) or one of {}",
            cut(task, 80),
            Scenario::shipped_names().join(", ")
        )
    })
}

/// Where the controller file a scenario file at `scenario` runs as `written`
/// (`robots[i].controller.file`) lies: relative to the scenario file's folder, as `scenario`
/// itself is given (relative to an experiment, or to the working directory).
pub fn controller_beside(scenario: &str, written: &str) -> String {
    Path::new(scenario)
        .parent()
        .unwrap_or(Path::new(""))
        .join(written)
        .to_string_lossy()
        .into_owned()
}

/// Deep-merges `overrides` into `base` (tables merge key by key, anything else replaces).
fn merge(base: &mut serde_json::Value, overrides: serde_json::Value) {
    match (base, overrides) {
        (serde_json::Value::Object(base), serde_json::Value::Object(overrides)) => {
            for (key, value) in overrides {
                match base.get_mut(&key) {
                    Some(slot) => merge(slot, value),
                    None => {
                        base.insert(key, value);
                    }
                }
            }
        }
        (slot, value) => *slot = value,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
[experiment]
name = "t"
seed = 3

[evolution]
population = 20
elites = 4

[[node]]
name = "maze"
kind = "arbitrator"
inputs = ["ir", "light"]
hidden = 10
children = ["fw", "tl"]
task = "solve_maze"
samples = 8
generations = 2
runs = 1

[[node]]
name = "fw"
kind = "primitive"
inputs = ["ir"]
hidden = 3
task = "follow_wall"
samples = 4
cycles = 300
generations = 3
runs = 2
[node.task_config]
robot = { v_max = 0.12 }

[[node]]
name = "tl"
kind = "primitive"
inputs = ["ir"]
hidden = 3
task = "turn_left"
samples = 4
generations = 3
runs = 2
[node.evolution]
mutation_sigma = 0.5
"#;

    fn parse(text: &str) -> Result<Experiment, ExperimentError> {
        Experiment::parse(text, Path::new("exp.toml"))
    }

    #[test]
    fn a_good_file_resolves_in_dependency_order() {
        let experiment = parse(GOOD).unwrap();
        let names: Vec<&str> = experiment
            .nodes
            .iter()
            .map(|n| n.decl.name.as_str())
            .collect();
        assert_eq!(names, ["fw", "tl", "maze"]);
        let fw = experiment.node("fw").unwrap();
        assert_eq!(fw.task.params.robot.v_max, 0.12);
        assert_eq!(fw.task.max_cycles(), 300);
        assert_eq!(fw.evolution.population, 20);
        assert_eq!(experiment.node("tl").unwrap().evolution.mutation_sigma, 0.5);
        assert_eq!(experiment.subtree("maze"), ["fw", "tl", "maze"]);
        assert_eq!(experiment.subtree("tl"), ["tl"]);
    }

    fn error_of(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    const FIXED_CHILDREN: &str = r#"
[experiment]
name = "fixed"

[[node]]
name = "maze"
kind = "arbitrator"
inputs = ["ir", "light"]
hidden = 4
children = [{ file = "controllers/fw.json" }, { runs = "main", node = "tl" }, "tr"]
task = "solve_maze"
samples = 2
generations = 1
runs = 1

[[node]]
name = "tr"
kind = "primitive"
inputs = ["ir"]
hidden = 3
task = "turn_right"
samples = 2
generations = 1
runs = 1
"#;

    fn finished_primitive(name: &str) -> String {
        let spec = NodeSpec::primitive(name, vec![InputGroup::IR], 3);
        let genes = vec![0.5; spec.topology().n_genes()];
        ControllerFile::new(spec.with_genome(genes))
            .to_json_pretty()
            .unwrap()
    }

    use hevo_sim_core::NodeSpec;

    #[test]
    fn children_may_come_from_controller_files_and_other_run_directories() {
        let files: BTreeMap<String, String> = [
            ("controllers/fw.json".to_string(), finished_primitive("fw")),
            ("main/tl/best.json".to_string(), finished_primitive("tl")),
            ("main/tl/summary.json".to_string(), "{}".to_string()),
        ]
        .into();
        let experiment =
            Experiment::parse_with(FIXED_CHILDREN, Path::new("x.toml"), &files).unwrap();
        // Only the experiment's own nodes are evolved.
        assert_eq!(experiment.nodes_to_run(None).unwrap(), ["tr", "maze"]);
        let maze = experiment.node("maze").unwrap();
        assert_eq!(
            maze.fixed_children.keys().copied().collect::<Vec<_>>(),
            [0, 1]
        );
        assert_eq!(maze.fixed_children[&1].root.name, "tl");
        assert_eq!(
            external_files(&experiment),
            [
                "controllers/fw.json",
                "main/tl/best.json",
                "main/tl/summary.json"
            ]
        );
        // The declaration round-trips as it was written.
        let json = serde_json::to_value(&maze.decl.children).unwrap();
        assert_eq!(
            json,
            serde_json::json!([{"file": "controllers/fw.json"}, {"runs": "main", "node": "tl"}, "tr"])
        );
    }

    #[test]
    fn a_node_may_name_its_scenario_under_either_key_to_the_same_experiment() {
        let t_maze = include_str!("../../../scenarios/examples/t_maze.toml").to_string();
        let files: BTreeMap<String, String> = [("t_maze.toml".to_string(), t_maze)].into();
        let with_key = |key: &str| {
            let text = format!(
                "[experiment]\nname = \"t\"\n\n[[node]]\nname = \"t\"\nkind = \"primitive\"\n\
                 inputs = [\"ir\", \"light\"]\nhidden = 3\n{key} = \"t_maze.toml\"\nsamples = 2\n\
                 generations = 1\nruns = 1\n"
            );
            Experiment::parse_with(&text, Path::new("x.toml"), &files)
                .unwrap_or_else(|e| panic!("{key}: {e}"))
        };
        let (task, scenario) = (with_key("task"), with_key("scenario"));
        assert_eq!(
            serde_json::to_string(&task.nodes[0].decl).unwrap(),
            serde_json::to_string(&scenario.nodes[0].decl).unwrap()
        );
        assert_eq!(scenario.nodes[0].task.name(), "t_maze");
    }

    #[test]
    fn a_node_scenario_reads_its_groups_controller_files_beside_it_from_the_same_files() {
        let mixed = include_str!("../../../scenarios/swarm/mixed_aggregation.toml").to_string();
        let pilot = include_str!("../../../controllers/aggregation.json").to_string();
        let text = "[experiment]\nname = \"t\"\n\n[[node]]\nname = \"t\"\nkind = \"primitive\"\n\
                    inputs = [\"ir\", \"rab\"]\nhidden = 3\ntask = \"scenarios/swarm/mixed.toml\"\n\
                    samples = 2\ngenerations = 1\nruns = 1\n";
        // Relative to the scenario file: `scenarios/swarm/../../controllers/aggregation.json`.
        let beside = controller_beside(
            "scenarios/swarm/mixed.toml",
            "../../controllers/aggregation.json",
        );
        assert_eq!(beside, "scenarios/swarm/../../controllers/aggregation.json");
        let mut files: BTreeMap<String, String> =
            [("scenarios/swarm/mixed.toml".to_string(), mixed)].into();
        let error = Experiment::parse_with(text, Path::new("x.toml"), &files)
            .unwrap_err()
            .to_string();
        assert!(error.contains("robots[1].controller.file"), "{error}");
        assert!(error.contains("not among the files sent"), "{error}");
        files.insert(beside.clone(), pilot.clone());
        let experiment = Experiment::parse_with(text, Path::new("x.toml"), &files).unwrap();
        let scenario = &experiment.nodes[0].task.scenario;
        assert_eq!(
            scenario
                .controller_files
                .get("../../controllers/aggregation.json"),
            Some(&pilot)
        );
    }

    #[test]
    fn a_node_and_its_children_read_only_the_sensors_of_its_scenario() {
        let blind = include_str!("../../../scenarios/examples/t_maze.toml")
            .replacen("name = \"t_maze\"", "name = \"ir_only\"", 1)
            .replacen(
                "max_cycles = 500",
                "sensors = [\"ir\"]\nmax_cycles = 500",
                1,
            );
        let files: BTreeMap<String, String> = [("ir_only.toml".to_string(), blind)].into();
        let experiment = |top_inputs: &str, leaf_inputs: &str| {
            let text = format!(
                r#"
[experiment]
name = "blind"

[[node]]
name = "top"
kind = "arbitrator"
inputs = {top_inputs}
hidden = 3
children = ["leaf"]
task = "ir_only.toml"
samples = 2
generations = 1
runs = 1

[[node]]
name = "leaf"
kind = "primitive"
inputs = {leaf_inputs}
hidden = 3
task = "solve_maze"
samples = 2
generations = 1
runs = 1
"#
            );
            Experiment::parse_with(&text, Path::new("x.toml"), &files).map_err(|e| e.to_string())
        };
        experiment(r#"["ir"]"#, r#"["ir"]"#).expect("every node reads what its robot has");
        let err = experiment(r#"["ir", "light"]"#, r#"["ir"]"#).unwrap_err();
        assert!(
            err.contains("node[0].inputs")
                && err.contains("reads 'light'")
                && err.contains("'ir_only'")
                && err.contains("it has ir"),
            "{err}"
        );
        // The leaf is evolved in solve_maze, which has lights, but drives in the arbitrator's
        // scenario once composed.
        let err = experiment(r#"["ir"]"#, r#"["ir", "near_robot"]"#).unwrap_err();
        assert!(
            err.contains("node[0].children[0]") && err.contains("the child reads 'near_robot'"),
            "{err}"
        );
    }

    /// An experiment over the example room-to-yard scenario, whose phases ask for the
    /// children `exit_room` and `cross_yard`, with the arbitrator's children named `children`.
    fn room_to_yard(children: &str) -> Result<Experiment, String> {
        let scenario = include_str!("../../../scenarios/examples/room_to_yard.toml").to_string();
        let files: BTreeMap<String, String> = [("yard.toml".to_string(), scenario)].into();
        let leaf = |name: &str| {
            format!(
                "[[node]]\nname = \"{name}\"\nkind = \"primitive\"\ninputs = [\"ir\"]\nhidden = 3\n\
                 task = \"follow_wall\"\nsamples = 2\ngenerations = 1\nruns = 1\n"
            )
        };
        let text = format!(
            "[experiment]\nname = \"yard\"\n\n[[node]]\nname = \"top\"\nkind = \"arbitrator\"\n\
             inputs = [\"ir\", \"light\"]\nhidden = 3\nchildren = {children}\ntask = \"yard.toml\"\n\
             samples = 2\ngenerations = 1\nruns = 1\n\n{}\n{}\n{}",
            leaf("exit_room"),
            leaf("cross_yard"),
            leaf("cross_the_yard"),
        );
        Experiment::parse_with(&text, Path::new("x.toml"), &files).map_err(|e| e.to_string())
    }

    #[test]
    fn a_phase_asking_for_a_child_the_arbitrator_lacks_is_refused_at_both_keys() {
        room_to_yard(r#"["exit_room", "cross_yard"]"#).expect("the phases' children");
        let err = room_to_yard(r#"["exit_room", "cross_the_yard"]"#).unwrap_err();
        assert!(
            err.starts_with("x.toml: at `node[0].children`: yard.toml:")
                && err.contains(": at `phase[1].child`: phase 'cross the yard' asks for the child 'cross_yard', the arbitrator's children are exit_room, cross_the_yard"),
            "{err}"
        );
    }

    #[test]
    fn a_start_touching_a_solid_is_refused_when_the_experiment_loads() {
        // The example T-maze with its start moved 0.2 m back, into the wall below the stem.
        let in_the_wall = include_str!("../../../scenarios/examples/t_maze.toml").replacen(
            "[place]\n",
            "[place]\nahead_m = -0.2\n",
            1,
        );
        let files: BTreeMap<String, String> = [("mine.toml".to_string(), in_the_wall)].into();
        let text = "[experiment]\nname = \"wall\"\n\n[[node]]\nname = \"t\"\nkind = \"primitive\"\n\
                    inputs = [\"ir\", \"light\"]\nhidden = 3\ntask = \"mine.toml\"\nsamples = 2\n\
                    generations = 1\nruns = 1\n";
        let err = Experiment::parse_with(text, Path::new("x.toml"), &files)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("x.toml: at `node[0].task`: mine.toml:")
                && err.contains(": at `place`: the robot starts touching a solid"),
            "{err}"
        );
    }

    #[test]
    fn a_child_from_elsewhere_must_be_there_finished_and_complete() {
        let mut files: BTreeMap<String, String> = [
            ("controllers/fw.json".to_string(), finished_primitive("fw")),
            ("main/tl/best.json".to_string(), finished_primitive("tl")),
        ]
        .into();
        let error = |files: &BTreeMap<String, String>| {
            Experiment::parse_with(FIXED_CHILDREN, Path::new("x.toml"), files)
                .unwrap_err()
                .to_string()
        };
        let err = error(&files);
        assert!(
            err.contains("node[0].children[1]")
                && err.contains("main/tl/summary.json")
                && err.contains("finished"),
            "{err}"
        );
        files.insert("main/tl/summary.json".into(), "{}".into());
        let free = ControllerFile::new(NodeSpec::primitive("fw", vec![InputGroup::IR], 3));
        files.insert("controllers/fw.json".into(), free.to_json_pretty().unwrap());
        let err = error(&files);
        assert!(
            err.contains("node[0].children[0]") && err.contains("has no genome"),
            "{err}"
        );
        files.insert("controllers/fw.json".into(), "{ not json".into());
        let err = error(&files);
        assert!(err.contains("not a controller file"), "{err}");
        files.remove("controllers/fw.json");
        let err = error(&files);
        assert!(err.contains("controllers/fw.json: cannot read"), "{err}");
        let bad =
            FIXED_CHILDREN.replace(r#"{ file = "controllers/fw.json" }"#, r#"{ flie = "x" }"#);
        let err = Experiment::parse_with(&bad, Path::new("x.toml"), &files)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("node[0].children[0]") && err.contains("flie"),
            "{err}"
        );
    }

    #[test]
    fn every_shipped_experiment_file_is_valid() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
        let mut n_files = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "toml") {
                Experiment::load(&path).unwrap_or_else(|e| panic!("{e}"));
                n_files += 1;
            }
        }
        assert!(
            n_files >= 3,
            "{n_files} experiment files in {}",
            dir.display()
        );
    }

    #[test]
    fn training_variants_are_balanced_unless_asked_and_absent_from_old_fingerprints() {
        let experiment = parse(GOOD).unwrap();
        let maze = experiment.node("maze").unwrap();
        assert_eq!(maze.evolution.training_variants, TrainingVariants::Balanced);
        // The runner's fingerprint hashes this JSON: balanced must serialize as before the
        // choice existed, or every finished run would be refused.
        let json = serde_json::to_string(&maze.evolution).unwrap();
        assert!(!json.contains("training_variants"), "{json}");

        let random = parse(&GOOD.replace(
            "mutation_sigma = 0.5",
            "mutation_sigma = 0.5\ntraining_variants = \"random\"",
        ))
        .unwrap();
        let tl = random.node("tl").unwrap();
        assert_eq!(tl.evolution.training_variants, TrainingVariants::Random);
        assert!(
            serde_json::to_string(&tl.evolution)
                .unwrap()
                .contains("\"random\"")
        );
        assert_eq!(
            random.node("maze").unwrap().evolution.training_variants,
            TrainingVariants::Balanced
        );

        let err =
            error_of(&GOOD.replace("mutation_sigma = 0.5", "training_variants = \"shuffled\""));
        assert!(
            err.contains("training_variants") && err.contains("shuffled"),
            "{err}"
        );
    }

    #[test]
    fn an_algorithm_is_chosen_per_experiment_or_node_with_its_own_keys() {
        // The GA is the default, and absent from the fingerprinted JSON as before the choice.
        let experiment = parse(GOOD).unwrap();
        let maze = experiment.node("maze").unwrap();
        assert_eq!(maze.evolution.algorithm, Algorithm::Ga);
        assert!(matches!(
            maze.evolution.strategy_settings(),
            StrategySettings::Ga(GaSettings {
                population: 20,
                elites: 4,
                ..
            })
        ));
        let json = serde_json::to_string(&maze.evolution).unwrap();
        assert!(!json.contains("algorithm"), "{json}");

        // CMA-ES for one node: its population need not be a multiple of the GA's elites, and
        // the choice is part of the fingerprinted JSON.
        let cmaes = GOOD.replace(
            "mutation_sigma = 0.5",
            "algorithm = \"cmaes\"\npopulation = 18\ninitial_sigma = 0.5",
        );
        let experiment = parse(&cmaes).unwrap();
        let tl = experiment.node("tl").unwrap();
        assert_eq!(tl.evolution.algorithm, Algorithm::Cmaes);
        assert_eq!(
            tl.evolution.strategy_settings(),
            StrategySettings::Cmaes(CmaesSettings {
                population: 18,
                initial_sigma: 0.5,
                gene_range: [-10.0, 10.0],
                variant: CmaesVariant::Full,
                restarts: 0,
                restart_population_factor: 2,
            })
        );
        let json = serde_json::to_string(&tl.evolution).unwrap();
        assert!(json.starts_with("{\"algorithm\":\"cmaes\","), "{json}");
        assert_eq!(
            experiment.node("fw").unwrap().evolution.algorithm,
            Algorithm::Ga
        );

        // For the whole experiment: the GA's keys are refused in a table of a CMA-ES node, and
        // in the experiment's own table (a GA node may set them for itself).
        let everywhere = GOOD
            .replace(
                "[evolution]\npopulation = 20\nelites = 4",
                "[evolution]\nalgorithm = \"cmaes\"\npopulation = 20",
            )
            .replace("mutation_sigma = 0.5", "population = 10");
        assert!(parse(&everywhere).is_ok());
        let err = error_of(&GOOD.replace(
            "[evolution]\npopulation = 20",
            "[evolution]\nalgorithm = \"cmaes\"\npopulation = 20",
        ));
        assert!(
            err.contains("at `evolution.elites`")
                && err
                    .contains("is a setting of algorithm \"ga\"; the algorithm here is \"cmaes\""),
            "{err}"
        );
        let err = error_of(&everywhere.replace("population = 10", "mutation_sigma = 0.5"));
        assert!(err.contains("node[2].evolution.mutation_sigma"), "{err}");
        let ga_node = parse(&everywhere.replace(
            "population = 10",
            "algorithm = \"ga\"\nelites = 5\nmutation_sigma = 0.5",
        ))
        .unwrap();
        assert_eq!(ga_node.node("tl").unwrap().evolution.elites, 5);
        assert_eq!(
            ga_node.node("fw").unwrap().evolution.algorithm,
            Algorithm::Cmaes
        );

        // CMA-ES's own domain: a step size above 0, a gene range that holds its start at 0.
        let err = error_of(&everywhere.replace("population = 10", "initial_sigma = 0.0"));
        assert!(
            err.contains("node[2].evolution.initial_sigma") && err.contains("must be > 0"),
            "{err}"
        );
        let err = error_of(&everywhere.replace("population = 10", "gene_range = [1.0, 5.0]"));
        assert!(
            err.contains("node[2].evolution.gene_range") && err.contains("low <= 0 <= high"),
            "{err}"
        );
        let err = error_of(&everywhere.replace("population = 10", "population = 1"));
        assert!(err.contains("node[2].evolution.population"), "{err}");
        let err = error_of(&GOOD.replace("mutation_sigma = 0.5", "algorithm = \"nsga2\""));
        assert!(
            err.contains("algorithm") && err.contains("nsga2") && err.contains("map_elites"),
            "{err}"
        );
    }

    #[test]
    fn novelty_search_has_the_ga_s_keys_and_its_own_checked_and_fingerprinted() {
        let novelty = |keys: &str| {
            GOOD.replace(
                "mutation_sigma = 0.5",
                &format!("algorithm = \"novelty\"\npopulation = 20\nelites = 4\n{keys}"),
            )
        };
        let experiment = parse(&novelty(
            "mutation_sigma = 0.5\nnovelty_neighbours = 7\nnovelty_fitness_weight = 0.5",
        ))
        .unwrap();
        let tl = &experiment.node("tl").unwrap().evolution;
        let StrategySettings::Novelty(settings) = tl.strategy_settings() else {
            panic!("{tl:?}");
        };
        assert_eq!((settings.ga.population, settings.ga.elites), (20, 4));
        assert_eq!(settings.ga.mutation_sigma, 0.5);
        assert_eq!((settings.neighbours, settings.fitness_weight), (7, 0.5));
        assert_eq!(settings.archive_per_generation, 5, "the default");
        // Its settings join the fingerprint whole; the other algorithms' have no trace of them.
        let json = serde_json::to_string(tl).unwrap();
        assert!(
            json.contains("\"algorithm\":\"novelty\"")
                && json.contains("\"novelty\":{\"neighbours\":7,"),
            "{json}"
        );
        let plain = parse(&novelty("")).unwrap();
        assert_ne!(
            serde_json::to_string(&plain.node("tl").unwrap().evolution).unwrap(),
            json
        );
        let ga = parse(GOOD).unwrap();
        let json = serde_json::to_string(&ga.node("tl").unwrap().evolution).unwrap();
        assert!(!json.contains("novelty"), "{json}");

        // Its keys elsewhere, and out of their domain, are refused naming them.
        let err = error_of(&GOOD.replace("mutation_sigma = 0.5", "novelty_neighbours = 3"));
        assert!(
            err.contains("node[2].evolution.novelty_neighbours")
                && err.contains("is a setting of algorithm \"novelty\""),
            "{err}"
        );
        let err = error_of(&novelty("restarts = 2"));
        assert!(err.contains("is a setting of algorithm \"cmaes\""), "{err}");
        let err = error_of(&novelty("novelty_fitness_weight = 2.0"));
        assert!(
            err.contains("node[2].evolution.novelty_fitness_weight") && err.contains("[0, 1]"),
            "{err}"
        );
        let err = error_of(&novelty("novelty_neighbours = 0"));
        assert!(err.contains("novelty_neighbours"), "{err}");
        // The GA's rule on the population holds for it too.
        let err = error_of(&novelty("elites = 3").replace("elites = 4\n", ""));
        assert!(
            err.contains("node[2].evolution.population") && err.contains("multiple of elites (3)"),
            "{err}"
        );
    }

    #[test]
    fn map_elites_keys_are_checked_and_fingerprinted_and_its_grid_ranges_required() {
        let map_elites = |keys: &str| {
            GOOD.replace(
                "mutation_sigma = 0.5",
                &format!("algorithm = \"map_elites\"\npopulation = 16\n{keys}"),
            )
            .replace("elites = 4\n", "")
            .replace("population = 20\n", "")
        };
        // Bins left out: 10 per descriptor value; one batch random.
        const RANGES: &str = "map_elites_ranges = [[-1.0, 1.0], [0.0, 2.0]]";
        let experiment = parse(&map_elites(RANGES)).unwrap();
        let tl = experiment.node("tl").unwrap();
        let StrategySettings::MapElites(settings) = tl.evolution.strategy_settings() else {
            panic!("{:?}", tl.evolution);
        };
        assert_eq!(tl.task.scenario.descriptor_names(), ["final.x", "final.y"]);
        assert_eq!(settings.bins, [10, 10]);
        assert_eq!(settings.ranges, [[-1.0, 1.0], [0.0, 2.0]]);
        assert_eq!((settings.population, settings.initial), (16, 16));
        assert_eq!(settings.variation, Variation::Gaussian);
        let err = error_of(&map_elites(""));
        assert!(
            err.contains("node[2].evolution.map_elites_ranges")
                && err.contains(
                    "required: the range [lo, hi] of each descriptor value (final.x, final.y)"
                ),
            "{err}"
        );

        let experiment = parse(&map_elites(
            "map_elites_bins = [20, 5]\nmap_elites_ranges = [[-1.0, 1.0], [0.0, 2.0]]\n\
             map_elites_variation = \"iso_line\"\nmap_elites_sigma = 0.1\n\
             map_elites_line_sigma = 0.3\nmap_elites_initial = 40",
        ))
        .unwrap();
        let tl = &experiment.node("tl").unwrap().evolution;
        let StrategySettings::MapElites(settings) = tl.strategy_settings() else {
            panic!("{tl:?}");
        };
        assert_eq!(settings.bins, [20, 5]);
        assert_eq!(settings.ranges, [[-1.0, 1.0], [0.0, 2.0]]);
        assert_eq!(settings.variation, Variation::IsoLine);
        assert_eq!((settings.sigma, settings.line_sigma), (0.1, 0.3));
        assert_eq!(settings.initial, 40);
        // Its settings, the filled-in grid too, join the fingerprint; the others have none.
        let json = serde_json::to_string(tl).unwrap();
        assert!(
            json.contains("\"algorithm\":\"map_elites\"")
                && json.contains("\"map_elites\":{\"bins\":[20,5],\"ranges\":[[-1.0,1.0],[0.0,2.0]],\"variation\":\"iso_line\""),
            "{json}"
        );
        let plain = parse(&map_elites(RANGES)).unwrap();
        let plain_json = serde_json::to_string(&plain.node("tl").unwrap().evolution).unwrap();
        assert!(plain_json.contains("\"bins\":[10,10]"), "{plain_json}");
        let ga = parse(GOOD).unwrap();
        let json = serde_json::to_string(&ga.node("tl").unwrap().evolution).unwrap();
        assert!(!json.contains("map_elites"), "{json}");

        // Each key out of its domain, or elsewhere, is refused naming it.
        for (keys, key, says) in [
            (
                "map_elites_bins = [0, 5]",
                "map_elites_bins",
                "between 1 and 1000",
            ),
            (
                "map_elites_bins = [10]",
                "map_elites_bins",
                "descriptor has 2 values (final.x, final.y)",
            ),
            (
                "map_elites_ranges = [[0.0, 1.0]]",
                "map_elites_ranges",
                "descriptor has 2 values",
            ),
            (
                "map_elites_ranges = [[1.0, 1.0], [0.0, 1.0]]",
                "map_elites_ranges",
                "lo < hi",
            ),
            ("map_elites_sigma = -0.5", "map_elites_sigma", ">= 0"),
            (
                "map_elites_line_sigma = -1.0",
                "map_elites_line_sigma",
                ">= 0",
            ),
        ] {
            let keys = if keys.starts_with("map_elites_ranges") {
                keys.to_string()
            } else {
                format!("{keys}\n{RANGES}")
            };
            let err = error_of(&map_elites(&keys));
            assert!(
                err.contains(&format!("node[2].evolution.{key}")) && err.contains(says),
                "{keys}: {err}"
            );
        }
        // A grid too large for the node's genomes is refused before anything runs.
        let wide = map_elites(&format!("map_elites_bins = [1000, 1000]\n{RANGES}"));
        assert!(parse(&wide).is_ok());
        let err = error_of(&wide.replace(
            "hidden = 3\ntask = \"turn_left\"",
            "hidden = 200\ntask = \"turn_left\"",
        ));
        assert!(
            err.contains("node[2].evolution.map_elites_bins")
                && err.contains("a full archive of 1000000 cells"),
            "{err}"
        );
        let err = error_of(&map_elites("map_elites_variation = \"line\""));
        assert!(err.contains("map_elites_variation"), "{err}");
        let err = error_of(&map_elites("elites = 2"));
        assert!(err.contains("is a setting of algorithm \"ga\""), "{err}");
        let err = error_of(&GOOD.replace("mutation_sigma = 0.5", "map_elites_sigma = 0.5"));
        assert!(
            err.contains("node[2].evolution.map_elites_sigma")
                && err.contains("is a setting of algorithm \"map_elites\""),
            "{err}"
        );
    }

    #[test]
    fn cmaes_variant_and_restarts_are_cmaes_keys_checked_and_fingerprinted_when_set() {
        let cmaes = |keys: &str| {
            GOOD.replace(
                "mutation_sigma = 0.5",
                &format!("algorithm = \"cmaes\"\npopulation = 18\n{keys}"),
            )
        };
        let experiment = parse(&cmaes(
            "cmaes_variant = \"separable\"\nrestarts = 4\nrestart_population_factor = 3",
        ))
        .unwrap();
        let tl = &experiment.node("tl").unwrap().evolution;
        assert_eq!(
            tl.strategy_settings(),
            StrategySettings::Cmaes(CmaesSettings {
                population: 18,
                initial_sigma: 2.0,
                gene_range: [-10.0, 10.0],
                variant: CmaesVariant::Separable,
                restarts: 4,
                restart_population_factor: 3,
            })
        );
        // Each joins the fingerprint only when set away from its default.
        let json = serde_json::to_string(tl).unwrap();
        for key in [
            "\"cmaes_variant\":\"separable\"",
            "\"restarts\":4",
            "\"restart_population_factor\":3",
        ] {
            assert!(json.contains(key), "{key} in {json}");
        }
        let defaults = parse(&cmaes(
            "cmaes_variant = \"full\"\nrestarts = 0\nrestart_population_factor = 2",
        ))
        .unwrap();
        let plain = parse(&cmaes("")).unwrap();
        let json = serde_json::to_string(&defaults.node("tl").unwrap().evolution).unwrap();
        assert_eq!(
            json,
            serde_json::to_string(&plain.node("tl").unwrap().evolution).unwrap()
        );
        for key in ["cmaes_variant", "restarts", "restart_population_factor"] {
            assert!(!json.contains(key), "{key} in {json}");
        }

        // A GA node may not set them; a wrong value is refused naming its key.
        let err = error_of(&GOOD.replace("mutation_sigma = 0.5", "restarts = 2"));
        assert!(
            err.contains("node[2].evolution.restarts")
                && err
                    .contains("is a setting of algorithm \"cmaes\"; the algorithm here is \"ga\""),
            "{err}"
        );
        let err = error_of(&cmaes("cmaes_variant = \"diagonal\""));
        assert!(
            err.contains("cmaes_variant") && err.contains("diagonal"),
            "{err}"
        );
        let err = error_of(&cmaes("restarts = 2\nrestart_population_factor = 1"));
        assert!(
            err.contains("node[2].evolution.restart_population_factor") && err.contains("2..=16"),
            "{err}"
        );
        // The last restart's population is bounded before any work: 18 x 2^13 > 100,000.
        let err = error_of(&cmaes("restarts = 13"));
        assert!(
            err.contains("node[2].evolution.restarts") && err.contains("18 x 2^13"),
            "{err}"
        );
        assert!(parse(&cmaes("restarts = 12")).is_ok());
    }

    #[test]
    fn a_lone_evolution_table_reads_as_an_experiment_file_s() {
        let file = Path::new("settings");
        let table =
            |text: &str| evolution_from_table(evolution_table_from_toml(text, file).unwrap(), file);
        // The same settings as the file's `[evolution]` table gives, with or without its line.
        let keys = "algorithm = \"cmaes\"\npopulation = 18\ninitial_sigma = 2\ncmaes_variant = \"separable\"";
        let in_file = parse(&format!(
            "[experiment]\nname = \"t\"\n[evolution]\n{keys}\n[[node]]\nname = \"fw\"\n\
             kind = \"primitive\"\ninputs = [\"ir\"]\nhidden = 3\ntask = \"follow_wall\"\n\
             samples = 4\ngenerations = 3\nruns = 2"
        ))
        .unwrap()
        .node("fw")
        .unwrap()
        .evolution
        .clone();
        assert_eq!(in_file.algorithm, Algorithm::Cmaes);
        assert_eq!(table(keys).unwrap(), in_file);
        assert_eq!(table(&format!("[evolution]\n{keys}")).unwrap(), in_file);
        assert_eq!(table("").unwrap(), EvolutionParams::default());
        let json = serde_json::json!({"algorithm": "cmaes", "population": 18,
            "initial_sigma": 2.0, "cmaes_variant": "separable"});
        assert_eq!(evolution_from_table(json, file).unwrap(), in_file);

        // The file's messages, each naming its key.
        let err = table("populaton = 3").unwrap_err().to_string();
        assert!(
            err.starts_with("settings: at `evolution") && err.contains("populaton"),
            "{err}"
        );
        let err = table("population = \"many\"").unwrap_err().to_string();
        assert!(err.contains("evolution.population"), "{err}");
        assert_eq!(
            table("restarts = 2").unwrap_err().to_string(),
            "settings: at `evolution.restarts`: is a setting of algorithm \"cmaes\"; the algorithm here is \"ga\""
        );
        assert_eq!(
            table("population = 30\nelites = 4")
                .unwrap_err()
                .to_string(),
            "settings: at `evolution.population`: population (30) must be a multiple of elites (4) and larger, so each elite gets the same number of mutated copies"
        );
        let err = table("algorithm = \"annealing\"").unwrap_err().to_string();
        assert!(
            err.contains("evolution.algorithm") && err.contains("annealing"),
            "{err}"
        );
        let err = evolution_table_from_toml("population = [", file)
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("settings:") && err.contains("unclosed array"),
            "{err}"
        );
    }

    #[test]
    fn unknown_keys_are_errors_with_their_path() {
        let err = error_of(&GOOD.replace(
            "hidden = 3\ntask = \"follow_wall\"",
            "hiden = 3\ntask = \"follow_wall\"",
        ));
        assert!(
            err.contains("exp.toml") && err.contains("node[1]") && err.contains("hiden"),
            "{err}"
        );
        let err = error_of(&GOOD.replace("robot = { v_max = 0.12 }", "robot = { vmax = 0.12 }"));
        assert!(
            err.contains("node[1].task_config.robot") && err.contains("vmax"),
            "{err}"
        );
    }

    #[test]
    fn only_arbitrators_keep_children_on() {
        let held = GOOD.replace(
            "children = [\"fw\", \"tl\"]",
            "children = [\"fw\", \"tl\"]\nmin_active_cycles = 10",
        );
        let experiment = parse(&held).unwrap();
        assert_eq!(experiment.node("maze").unwrap().decl.min_active_cycles, 10);
        assert_eq!(experiment.node("fw").unwrap().decl.min_active_cycles, 0);
        let err = error_of(&GOOD.replace("cycles = 300", "cycles = 300\nmin_active_cycles = 4"));
        assert!(
            err.contains("node[1].min_active_cycles") && err.contains("only an arbitrator"),
            "{err}"
        );
    }

    #[test]
    fn wrong_types_and_values_name_the_key() {
        let err = error_of(&GOOD.replace("hidden = 10", "hidden = \"ten\""));
        assert!(err.contains("node[0].hidden"), "{err}");
        let err = error_of(&GOOD.replace("task = \"turn_left\"", "task = \"turn_up\""));
        assert!(
            err.contains("node[2].task") && err.contains("turn_up"),
            "{err}"
        );
        let err = error_of(&GOOD.replace(
            "children = [\"fw\", \"tl\"]",
            "children = [\"fw\", \"nope\"]",
        ));
        assert!(
            err.contains("node[0].children[1]") && err.contains("nope"),
            "{err}"
        );
        let err = error_of(&GOOD.replace("elites = 4", "elites = 3"));
        assert!(err.contains("evolution.population"), "{err}");
        let err = error_of(&GOOD.replace("robot = { v_max = 0.12 }", "robot = { v_max = -1.0 }"));
        assert!(
            err.contains("node[1].task_config") && err.contains("v_max"),
            "{err}"
        );
        let err = error_of(&GOOD.replace(
            "inputs = [\"ir\", \"light\"]",
            "inputs = [\"ir\", \"lidar\"]",
        ));
        assert!(err.contains("node[0].inputs"), "{err}");
    }

    /// The job that crashed a master (issue 48): within every other limit, a generation of
    /// 100,000 genomes of a million genes each.
    const HUGE_GENERATION: &str = r#"
[experiment]
name = "huge"

[evolution]
population = 100000
elites = 1

[[node]]
name = "big"
kind = "primitive"
inputs = ["ir", "light", "near_robot"]
hidden = 1000
task = "exit_room"
samples = 1
generations = 1
runs = 1
"#;

    #[test]
    fn a_generation_too_large_for_memory_is_refused_naming_the_key() {
        let err = error_of(HUGE_GENERATION);
        assert!(err.contains("node[0].evolution.population"), "{err}");
        assert!(err.contains("100000 genomes of 1011002 genes"), "{err}");
        assert!(err.contains("at most 1024 MiB"), "{err}");
        // The same network in a population the memory bound allows is accepted.
        let fits = HUGE_GENERATION
            .replace("population = 100000", "population = 10")
            .replace("elites = 1", "elites = 5");
        parse(&fits).unwrap();
        assert!(
            generation_bytes(10, 1_011_002, 1) <= limits::GENERATION_BYTES,
            "the estimate of a population of ten"
        );
        assert_eq!(
            declared_genes(&parse(&fits).unwrap().nodes[0].decl),
            1_011_002
        );
    }

    #[test]
    fn a_huge_unknown_key_is_quoted_only_in_part() {
        let key = "k".repeat(16_000);
        let err = error_of(&GOOD.replace("hidden = 10", &format!("hidden = 10\n{key} = 1")));
        assert!(err.contains("kkkk"), "{err}");
        assert!(err.len() < 2_000, "{} characters", err.len());
    }

    #[test]
    fn cycles_are_refused() {
        let text = GOOD.replace(
            "name = \"tl\"\nkind = \"primitive\"",
            "name = \"tl\"\nkind = \"arbitrator\"\nchildren = [\"maze\"]",
        );
        let err = error_of(&text);
        assert!(err.contains("cycle"), "{err}");
    }

    #[test]
    fn malformed_toml_is_a_syntax_error() {
        let err = error_of("[experiment\nname = 1");
        assert!(err.starts_with("exp.toml"), "{err}");
    }

    #[test]
    fn a_remote_evaluation_is_held_to_a_generations_bounds() {
        assert_eq!(check_evaluation_cost(10_000, 100, 25, 4), Ok(()));
        fn field(result: Result<(), (&'static str, String)>) -> &'static str {
            result.unwrap_err().0
        }
        assert_eq!(field(check_evaluation_cost(100_001, 1, 1, 1)), "genomes");
        assert_eq!(field(check_evaluation_cost(1, 1, 100_001, 1)), "samples");
        // 10,000 x 26 x 4 = 1,040,000 evaluations.
        let (key, message) = check_evaluation_cost(10_000, 1, 26, 4).unwrap_err();
        assert_eq!(key, "genomes");
        assert!(
            message.starts_with("1040000 evaluations at once"),
            "{message}"
        );
        // 100,000 genomes of 1,000 genes on one sample: 2.8 GB of genes.
        let (key, message) = check_evaluation_cost(100_000, 1_000, 1, 1).unwrap_err();
        assert_eq!(key, "genomes");
        assert!(message.contains("MiB, at most 1024 MiB"), "{message}");
    }
}
