//! The run driver behind `hevo run` and every service job: evolves an experiment's controller
//! tree bottom-up. For each node: its independent runs, each checkpointed after every
//! generation; post-evaluation of each run's best controller; then the best run's controller
//! becomes the fixed child of the parent nodes. Rerunning the same command resumes where it
//! stopped and gives exactly the result an uninterrupted run would, because every random draw
//! derives from (experiment seed, node, run, generation, genome, sample) and checkpoints store
//! the search strategy's whole state exactly. The runner knows no algorithm: it asks the
//! node's [`hevo_evolve::Strategy`] for genomes, has them evaluated, and tells it their fitness.
//!
//! What it writes, and where, is the run-directory format of [`crate::rundir`].

use crate::dispatch::{DispatchError, Dispatcher, EvaluationRequest, RequestShared};
use crate::experiment::{Experiment, NodePlan};
use crate::post_evaluation;
use crate::rundir::{
    self, BEST, CHECKPOINT, CHECKPOINT_FORMAT, Checkpoint, CheckpointHeader, FITNESS_CSV,
    FitnessRow, NodeSummary, RunSummary, SUMMARY, TASK, parse_checkpoint, run_dir,
};
use crate::store::{
    read_json, read_json_with, remove_leftover_temporaries, write_atomic, write_json_atomic,
};
use hevo_evolve::map_elites::{GridArchive, QdPoint};
use hevo_evolve::{Evaluation, seeds};
use hevo_rundir::archive::{
    ARCHIVE_FORMAT, ARCHIVE_JSON, ArchiveElite, ArchiveFile, QD_CSV, QdRow, qd_csv,
};
use hevo_sim_core::{ControllerFile, NodeSpec};
use hevo_sim_core::{Sample, SampleSummary};
use hevo_sim_core::{TaskConfig, task_content_hash};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a run changes of an experiment file's settings: `hevo run`'s and `hevo submit`'s
/// flags, and a service job's settings.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Overrides {
    /// Only this node (after its children, which are reused when already finished).
    pub node: Option<String>,
    /// Every node's number of runs.
    pub runs: Option<u32>,
    /// Every node's number of generations.
    pub generations: Option<u32>,
    /// The experiment's seed.
    pub seed: Option<u64>,
}

impl Overrides {
    /// Refuses overrides out of the experiment limits (no runs, runs of no generations, more
    /// than [`crate::experiment::limits`] allow) and node names that name no node.
    pub fn validate(&self) -> Result<(), OverrideError> {
        use crate::experiment::limits;
        for (field, value, max) in [
            ("runs", self.runs, limits::RUNS),
            ("generations", self.generations, limits::GENERATIONS),
        ] {
            if let Some(value) = value
                && !(1..=max).contains(&value)
            {
                return Err(OverrideError {
                    field,
                    message: format!("must be between 1 and {max}, got {value}"),
                });
            }
        }
        if let Some(node) = &self.node {
            crate::experiment::check_node_name(node).map_err(|message| OverrideError {
                field: "node",
                message,
            })?;
        }
        Ok(())
    }

    /// The runs a node gets.
    pub fn runs_of(&self, plan: &NodePlan) -> u32 {
        self.runs.unwrap_or(plan.decl.runs)
    }

    /// The generations each of a node's runs gets.
    pub fn generations_of(&self, plan: &NodePlan) -> u32 {
        self.generations.unwrap_or(plan.decl.generations)
    }

    /// The experiment's seed in force.
    pub fn seed_of(&self, experiment: &Experiment) -> u64 {
        self.seed.unwrap_or(experiment.header.seed)
    }
}

/// An override out of range.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--{field} {message}")]
pub struct OverrideError {
    /// The flag (and service field): `runs`, `generations`, `node`.
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

/// What to run, and where.
#[derive(Debug, Clone)]
pub struct RunSettings {
    /// Output directory.
    pub out_dir: PathBuf,
    /// What the run changes of the experiment file.
    pub overrides: Overrides,
    /// The dispatcher's job key (fair sharing between concurrent jobs).
    pub job: String,
}

/// What the driver reports as it goes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum ProgressEvent {
    /// A node starts (or is found finished).
    NodeStarted {
        /// Node.
        node: String,
        /// Runs.
        runs: u32,
        /// Generations per run.
        generations: u32,
    },
    /// A generation was evaluated.
    Generation {
        /// Node.
        node: String,
        /// Run.
        run: u32,
        /// Generation just evaluated (0-based).
        generation: u32,
        /// Generations per run.
        generations: u32,
        /// Best fitness of the generation.
        best: f64,
        /// Mean fitness of the generation.
        mean: f64,
        /// Control cycles simulated for this generation.
        cycles: u64,
        /// A grid archive's measures once the generation was told (MAP-Elites runs), which is
        /// what such a run optimises; absent for the other algorithms.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        archive: Option<ArchiveProgress>,
    },
    /// A run finished post-evaluation.
    RunFinished {
        /// Node.
        node: String,
        /// Run.
        run: u32,
        /// Post-evaluation solve rate.
        solve_rate: f64,
    },
    /// A node finished.
    NodeFinished {
        /// Node.
        node: String,
        /// Best run.
        best_run: u32,
        /// Its solve rate.
        best_solve_rate: f64,
        /// Mean solve rate over runs.
        mean_solve_rate: f64,
    },
    /// A log line for the user.
    Note {
        /// Text.
        message: String,
    },
}

/// A grid archive's measures after a generation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ArchiveProgress {
    /// Cells filled.
    pub filled: u64,
    /// The grid's cells.
    pub cells: u64,
    /// QD-score: the sum of the elites' fitness.
    pub qd_score: f64,
    /// The best elite's fitness.
    pub best_elite: f64,
}

impl ArchiveProgress {
    /// The share of cells filled.
    pub fn coverage(&self) -> f64 {
        self.filled as f64 / self.cells.max(1) as f64
    }
}

/// Receives progress events.
pub trait Progress: Send + Sync {
    /// Called for each event, in order.
    fn event(&self, event: &ProgressEvent);
}

/// Why a run stopped.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Reading or writing an output failed.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The output directory holds results of a different experiment.
    #[error(
        "{path} was produced by a different experiment setup (fingerprint {found}, this one is {expected}): \
         the node's settings, seed, overrides or children changed. Use another --out directory, or delete {path} to start it again."
    )]
    Fingerprint {
        /// The file.
        path: PathBuf,
        /// Found.
        found: String,
        /// Expected.
        expected: String,
    },
    /// The node's recorded task is not the one being run.
    #[error(
        "{path} records another task than this node's (the scenario, its controller files or the task settings changed). \
         Use another --out directory, or delete {node_dir} to start the node again."
    )]
    TaskChanged {
        /// The node's task file.
        path: PathBuf,
        /// The node's directory.
        node_dir: PathBuf,
    },
    /// A result file exists but cannot be read.
    #[error(transparent)]
    Read(#[from] crate::store::ReadJsonError),
    /// The experiment has no node of the name asked for.
    #[error(transparent)]
    Experiment(#[from] crate::experiment::ExperimentError),
    /// An override is out of range.
    #[error(transparent)]
    Override(#[from] OverrideError),
    /// The dispatcher could not evaluate.
    #[error(transparent)]
    Dispatch(#[from] DispatchError),
    /// Inconsistent experiment (a node named with --node does not exist, a child has no result).
    #[error("{0}")]
    Invalid(String),
}

/// Runs an experiment (or one node of it, after its children) to completion.
pub async fn run_experiment(
    experiment: &Experiment,
    settings: &RunSettings,
    dispatcher: &Dispatcher,
    progress: &dyn Progress,
) -> Result<Vec<NodeSummary>, RunError> {
    settings.overrides.validate()?;
    let names = experiment.nodes_to_run(settings.overrides.node.as_deref())?;
    let mut summaries = Vec::new();
    for name in names {
        let plan = experiment
            .node(&name)
            .expect("names come from the experiment");
        summaries.push(run_node(experiment, plan, settings, dispatcher, progress).await?);
    }
    Ok(summaries)
}

fn io_error(path: &Path, error: impl std::fmt::Display) -> RunError {
    RunError::Io {
        path: path.to_path_buf(),
        message: error.to_string(),
    }
}

/// Where a node of a run stands in an output directory, and what is left to do: what
/// `hevo run --dry-run` prints. Read from the files alone (fingerprints are checked when the
/// run itself starts).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeStatus {
    /// Node.
    pub node: String,
    /// Its task.
    pub task: String,
    /// Runs asked for.
    pub runs: u32,
    /// Generations per run.
    pub generations: u32,
    /// Genomes x samples per generation.
    pub evaluations_per_generation: u64,
    /// Samples of one run's post-evaluation.
    pub post_evaluation_samples: u64,
    /// The task's cycle limit per sample.
    pub max_cycles: u32,
    /// Runs with a summary.
    pub finished_runs: u32,
    /// A run under way: (run, next generation).
    pub in_progress: Option<(u32, u32)>,
    /// Whether the node's own summary is there with at least the runs asked for.
    pub finished: bool,
    /// Sample evaluations still to do.
    pub remaining_evaluations: u64,
}

impl NodeStatus {
    /// At most how many control cycles the rest takes (every sample to its limit).
    pub fn remaining_cycles_bound(&self) -> u64 {
        self.remaining_evaluations * u64::from(self.max_cycles)
    }
}

/// The status of every node a run would evolve, in order.
pub fn node_statuses(
    experiment: &Experiment,
    settings: &RunSettings,
) -> Result<Vec<NodeStatus>, RunError> {
    settings.overrides.validate()?;
    let names = experiment.nodes_to_run(settings.overrides.node.as_deref())?;
    let mut statuses = Vec::new();
    for name in names {
        let plan = experiment
            .node(&name)
            .expect("names come from the experiment");
        let runs = settings.overrides.runs_of(plan);
        let generations = settings.overrides.generations_of(plan);
        let node_dir = rundir::node_dir(&settings.out_dir, &name);
        let summary_path = node_dir.join(SUMMARY);
        let node_summary = read_json::<NodeSummary>(&summary_path)?;
        let n_variants = u64::from(plan.task.scenario.n_variants());
        let evaluations_per_generation =
            u64::from(plan.evolution.population) * u64::from(plan.decl.samples);
        let post_evaluation_samples =
            u64::from(plan.evolution.post_evaluation_samples) * n_variants;
        let mut finished_runs = 0;
        let mut in_progress = None;
        let mut remaining = 0u64;
        for run in 0..runs {
            let dir = run_dir(&node_dir, run);
            let summary = dir.join(SUMMARY);
            if summary.is_file() {
                finished_runs += 1;
                continue;
            }
            let checkpoint = dir.join(CHECKPOINT);
            let done_generations = read_json::<rundir::CheckpointHeader>(&checkpoint)?
                .map_or(0, |header| header.generation.min(generations));
            if done_generations > 0 && in_progress.is_none() {
                in_progress = Some((run, done_generations));
            }
            remaining += u64::from(generations - done_generations) * evaluations_per_generation
                + post_evaluation_samples;
        }
        let finished = node_summary.is_some_and(|summary| summary.runs.len() >= runs as usize);
        statuses.push(NodeStatus {
            node: name.clone(),
            task: plan.task.name().to_string(),
            runs,
            generations,
            evaluations_per_generation,
            post_evaluation_samples,
            max_cycles: plan.task.max_cycles(),
            finished_runs,
            in_progress,
            finished,
            remaining_evaluations: if finished { 0 } else { remaining },
        });
    }
    Ok(statuses)
}

/// The controller template of a node: the node itself free, its children the fixed best
/// controllers of their nodes.
pub fn node_template(plan: &NodePlan, out_dir: &Path) -> Result<ControllerFile, RunError> {
    let mut children = Vec::new();
    for (child_idx, child) in plan.decl.children.iter().enumerate() {
        if let Some(fixed) = plan.fixed_children.get(&child_idx) {
            children.push(fixed.root.clone());
            continue;
        }
        let path = rundir::node_dir(out_dir, &child.to_string()).join(BEST);
        let text = std::fs::read_to_string(&path).map_err(|e| {
            RunError::Invalid(format!(
                "{}: the child '{child}' of '{}' has no result yet ({e}); run it first",
                path.display(),
                plan.decl.name
            ))
        })?;
        let file = ControllerFile::from_json_str(&text).map_err(|e| io_error(&path, e))?;
        children.push(file.root);
    }
    Ok(ControllerFile::new(NodeSpec {
        name: plan.decl.name.clone(),
        kind: plan.decl.kind,
        inputs: plan.decl.inputs.clone(),
        hidden: plan.decl.hidden,
        genome: None,
        children,
        min_active_cycles: plan.decl.min_active_cycles,
    }))
}

/// Everything that determines a node's results, hashed: changing any of it under existing
/// checkpoints is refused.
fn fingerprint(plan: &NodePlan, template: &ControllerFile, seed: u64, generations: u32) -> String {
    let material = serde_json::json!({
        "format": 1,
        "model": hevo_sim_core::MODEL_VERSION,
        "seed": seed,
        "generations": generations,
        "samples": plan.decl.samples,
        "evolution": plan.evolution,
        "task": task_content_hash(&plan.task),
        "template": template.content_hash(),
    });
    hevo_sim_core::fnv1a_hex(material.to_string().as_bytes())
}

async fn run_node(
    experiment: &Experiment,
    plan: &NodePlan,
    settings: &RunSettings,
    dispatcher: &Dispatcher,
    progress: &dyn Progress,
) -> Result<NodeSummary, RunError> {
    let name = &plan.decl.name;
    let node_dir = settings.out_dir.join(name);
    // The node's own files (best.json, summary.json) are written atomically too.
    remove_leftover_temporaries(&node_dir).map_err(|e| io_error(&node_dir, e))?;
    let seed = settings.overrides.seed_of(experiment);
    let runs = settings.overrides.runs_of(plan);
    let generations = settings.overrides.generations_of(plan);
    let template = node_template(plan, &settings.out_dir)?;
    let fingerprint_for = |generations| fingerprint(plan, &template, seed, generations);
    let fingerprint = fingerprint_for(generations);
    let recorded_task = read_recorded_task(&node_dir, &plan.task)?;

    // A finished node is reused when it has at least the runs asked for: finished runs are
    // never thrown away, and throwing them away would change the node's best controller under
    // its parents' checkpoints. Below the node named by --node, a finished result is reused
    // whatever its number of runs and generations (everything else must match), so
    // `--node solve_maze --runs 5 --generations 300` changes solve_maze alone.
    let below_named_node = settings
        .overrides
        .node
        .as_ref()
        .is_some_and(|named| named != name);
    let summary_path = node_dir.join(SUMMARY);
    let reusable = |summary: &NodeSummary| {
        if below_named_node {
            summary
                .runs
                .first()
                .is_some_and(|run| summary.fingerprint == fingerprint_for(run.generations))
        } else {
            summary.fingerprint == fingerprint && summary.runs.len() >= runs as usize
        }
    };
    if let Some(summary) = read_json::<NodeSummary>(&summary_path)?
        && reusable(&summary)
    {
        if !recorded_task {
            // Finished before nodes recorded their task: its fingerprint, which holds the
            // task's hash, just matched, so this is the task it was evolved on.
            write_task(&node_dir, &plan.task)?;
        }
        // A `--runs` extension stopped after some of its runs finished leaves finished runs the
        // summary does not list. They are results, and may hold the node's best controller, so
        // they are folded in before any parent composes from `best.json`.
        let unlisted = finished_runs_after(&node_dir, &summary)?;
        if !unlisted.is_empty() {
            progress.event(&ProgressEvent::Note {
                message: format!(
                    "{name}: {} finished run(s) were missing from its summary (an interrupted --runs extension); summary and best controller refreshed",
                    unlisted.len()
                ),
            });
            let fingerprint = summary.fingerprint.clone();
            let mut run_summaries = summary.runs;
            run_summaries.extend(unlisted);
            return summarize_node(plan, &node_dir, fingerprint, run_summaries, progress);
        }
        progress.event(&ProgressEvent::Note {
            message: format!(
                "{name}: already finished, {} runs (skipped)",
                summary.runs.len()
            ),
        });
        return Ok(summary);
    }
    if !recorded_task {
        // Only over results of this setup: a task file written beside another setup's results
        // (refused below) would name the wrong task for them.
        check_first_run_fingerprint(&node_dir, &fingerprint)?;
        write_task(&node_dir, &plan.task)?;
    }
    progress.event(&ProgressEvent::NodeStarted {
        node: name.clone(),
        runs,
        generations,
    });

    let mut run_summaries = Vec::new();
    for run in 0..runs {
        let run_dir = run_dir(&node_dir, run);
        run_summaries.push(
            run_one(
                plan,
                &template,
                &fingerprint,
                seed,
                run,
                generations,
                &run_dir,
                settings,
                dispatcher,
                progress,
            )
            .await?,
        );
    }

    summarize_node(plan, &node_dir, fingerprint, run_summaries, progress)
}

/// Whether the node directory records its task ([`TASK`]); a recorded task other than `task`
/// (by content hash) is refused, as a changed fingerprint is.
fn read_recorded_task(node_dir: &Path, task: &TaskConfig) -> Result<bool, RunError> {
    let path = node_dir.join(TASK);
    match read_json::<TaskConfig>(&path)? {
        None => Ok(false),
        Some(found) if task_content_hash(&found) == task_content_hash(task) => Ok(true),
        Some(_) => Err(RunError::TaskChanged {
            path,
            node_dir: node_dir.to_path_buf(),
        }),
    }
}

/// Records the node's task ([`TASK`]) atomically, as the other run-directory files are.
fn write_task(node_dir: &Path, task: &TaskConfig) -> Result<(), RunError> {
    let path = node_dir.join(TASK);
    write_json_atomic(&path, task).map_err(|e| io_error(&path, e))
}

/// Refuses a node whose first run holds another setup's summary or checkpoint: the check
/// `run_one` makes, made before the node's task is recorded beside them. Runs are evolved in
/// order, so a node with results has a first run.
fn check_first_run_fingerprint(node_dir: &Path, fingerprint: &str) -> Result<(), RunError> {
    let first = run_dir(node_dir, 0);
    let summary_path = first.join(SUMMARY);
    if let Some(found) = read_json::<RunSummary>(&summary_path)? {
        return check_fingerprint(&summary_path, &found.fingerprint, fingerprint);
    }
    let checkpoint_path = first.join(CHECKPOINT);
    if let Some(found) = read_json::<CheckpointHeader>(&checkpoint_path)? {
        return check_fingerprint(&checkpoint_path, &found.fingerprint, fingerprint);
    }
    Ok(())
}

/// Refuses a file written under another setup than the one being run: resuming or reusing it
/// would mix two experiments' results.
fn check_fingerprint(path: &Path, found: &str, expected: &str) -> Result<(), RunError> {
    if found == expected {
        Ok(())
    } else {
        Err(RunError::Fingerprint {
            path: path.to_path_buf(),
            found: found.to_string(),
            expected: expected.to_string(),
        })
    }
}

/// The finished runs of a node numbered after the ones its summary lists, in order, up to the
/// first run that is missing or unfinished (runs are evolved in order, so later ones cannot be
/// finished). A finished run of another setup is an error, as it is when resuming.
fn finished_runs_after(
    node_dir: &Path,
    summary: &NodeSummary,
) -> Result<Vec<RunSummary>, RunError> {
    let mut unlisted = Vec::new();
    for run in summary.runs.len().. {
        let path = run_dir(node_dir, run as u32).join(SUMMARY);
        let Some(found) = read_json::<RunSummary>(&path)? else {
            break;
        };
        check_fingerprint(&path, &found.fingerprint, &summary.fingerprint)?;
        unlisted.push(found);
    }
    Ok(unlisted)
}

/// Chooses a node's best run, copies its controller to `<node>/best.json` and writes the node
/// summary. The best run has the highest post-evaluation solve rate, then mean fitness; a tie
/// keeps the earlier run, so adding runs changes the node's controller only for a better one.
fn summarize_node(
    plan: &NodePlan,
    node_dir: &Path,
    fingerprint: String,
    run_summaries: Vec<RunSummary>,
    progress: &dyn Progress,
) -> Result<NodeSummary, RunError> {
    let name = &plan.decl.name;
    let summary_path = node_dir.join(SUMMARY);
    let best = run_summaries
        .iter()
        .enumerate()
        .max_by(|(ia, a), (ib, b)| {
            a.post_evaluation
                .solve_rate
                .total_cmp(&b.post_evaluation.solve_rate)
                .then(
                    a.post_evaluation
                        .mean_fitness
                        .total_cmp(&b.post_evaluation.mean_fitness),
                )
                .then(ib.cmp(ia))
        })
        .map(|(i, _)| i)
        .expect("at least one run");
    let best_controller_path = run_dir(node_dir, best as u32).join(BEST);
    let best_controller =
        std::fs::read(&best_controller_path).map_err(|e| io_error(&best_controller_path, e))?;
    write_atomic(&node_dir.join(BEST), &best_controller)
        .map_err(|e| io_error(&node_dir.join(BEST), e))?;
    let mean_solve_rate = run_summaries
        .iter()
        .map(|r| r.post_evaluation.solve_rate)
        .sum::<f64>()
        / run_summaries.len() as f64;
    let summary = NodeSummary {
        node: name.clone(),
        task: plan.task.name().to_string(),
        fingerprint,
        best_run: best as u32,
        best_solve_rate: run_summaries[best].post_evaluation.solve_rate,
        mean_solve_rate,
        runs: run_summaries,
    };
    write_json_atomic(&summary_path, &summary).map_err(|e| io_error(&summary_path, e))?;
    progress.event(&ProgressEvent::NodeFinished {
        node: name.clone(),
        best_run: summary.best_run,
        best_solve_rate: summary.best_solve_rate,
        mean_solve_rate,
    });
    Ok(summary)
}

#[allow(clippy::too_many_arguments)]
async fn run_one(
    plan: &NodePlan,
    template: &ControllerFile,
    fingerprint: &str,
    seed: u64,
    run: u32,
    generations: u32,
    run_dir: &Path,
    settings: &RunSettings,
    dispatcher: &Dispatcher,
    progress: &dyn Progress,
) -> Result<RunSummary, RunError> {
    let name = &plan.decl.name;
    // A run killed in the middle of an atomic write left its temporary file here.
    remove_leftover_temporaries(run_dir).map_err(|e| io_error(run_dir, e))?;
    let summary_path = run_dir.join(SUMMARY);
    let checkpoint_path = run_dir.join(CHECKPOINT);
    if let Some(summary) = read_json::<RunSummary>(&summary_path)? {
        check_fingerprint(&summary_path, &summary.fingerprint, fingerprint)?;
        // Killed between writing the summary and removing the checkpoint.
        remove_if_present(&checkpoint_path)?;
        return Ok(summary);
    }
    let run_seed = seeds::run_seed(seed, name, run);
    let n_genes = template
        .free_node_topology()
        .map(|(_, t)| t.n_genes())
        .unwrap_or(0);
    let strategy_settings = plan.evolution.strategy_settings();
    let unusable = |why: String| {
        io_error(
            &checkpoint_path,
            format!(
                "checkpoint is not in the expected format ({why}); delete it to restart the run"
            ),
        )
    };
    let (mut strategy, mut log) =
        match read_json_with(&checkpoint_path, |text| parse_checkpoint(text, run_seed))? {
            Some(found) => {
                check_fingerprint(&checkpoint_path, &found.fingerprint, fingerprint)?;
                if found.format != CHECKPOINT_FORMAT {
                    return Err(unusable(format!("format {}", found.format)));
                }
                let strategy = strategy_settings
                    .resume(n_genes, found.strategy)
                    .map_err(|e| unusable(e.to_string()))?;
                if strategy.generation() != found.generation
                    || found.log.len() != found.generation as usize
                {
                    return Err(unusable(format!(
                        "generation {} with a strategy at {} and {} log rows",
                        found.generation,
                        strategy.generation(),
                        found.log.len()
                    )));
                }
                progress.event(&ProgressEvent::Note {
                    message: format!(
                        "{name} run {run}: resuming at generation {}",
                        found.generation
                    ),
                });
                (strategy, found.log)
            }
            None => (
                strategy_settings
                    .start(n_genes, run_seed)
                    .map_err(|e| RunError::Invalid(format!("{name}: {e}")))?,
                Vec::new(),
            ),
        };
    std::fs::create_dir_all(run_dir).map_err(|e| io_error(run_dir, e))?;

    let shared = Arc::new(RequestShared::new(template.clone(), plan.task.clone()));
    let n_variants = plan.task.scenario.n_variants();
    while strategy.generation() < generations {
        let generation = strategy.generation();
        // Every genome of a generation meets the same samples; tasks with light
        // configurations get them in equal shares unless the experiment asks for random ones.
        let variants = seeds::generation_variants(
            plan.evolution.variant_draw(),
            run_seed,
            generation,
            plan.decl.samples,
            n_variants,
        );
        let samples: Arc<[Sample]> =
            seeds::generation_seeds(run_seed, generation, plan.decl.samples)
                .into_iter()
                .zip(variants)
                .map(|(seed, variant)| Sample { seed, variant })
                .collect();
        let request = EvaluationRequest {
            job: settings.job.clone(),
            shared: shared.clone(),
            genomes: strategy
                .ask()
                .iter()
                .map(|g| Arc::from(g.as_slice()))
                .collect(),
            samples,
        };
        let results = dispatcher.evaluate(request).await?;
        let fitness: Vec<f64> = results
            .iter()
            .map(|genome| {
                genome.iter().map(|s| f64::from(s.fitness)).sum::<f64>()
                    / genome.len().max(1) as f64
            })
            .collect();
        let cycles: u64 = results.iter().flatten().map(|s| u64::from(s.cycles)).sum();
        let row = log_row(generation, &fitness);
        log.push(row);
        let evaluations: Vec<Evaluation> = fitness
            .into_iter()
            .zip(&results)
            .map(|(fitness, samples)| {
                Evaluation::with_descriptor(fitness, mean_descriptor(samples))
            })
            .collect();
        strategy
            .tell(&evaluations)
            .map_err(|e| RunError::Invalid(format!("{name} run {run}: {e}")))?;
        let archive = match strategy.grid() {
            Some(grid) => Some(write_archive(run_dir, grid, plan, generation + 1)?),
            None => None,
        };
        progress.event(&ProgressEvent::Generation {
            node: name.clone(),
            run,
            generation,
            generations,
            best: row.best,
            mean: row.mean,
            cycles,
            archive,
        });
        write_fitness_csv(&run_dir.join(FITNESS_CSV), &log)?;
        let checkpoint = Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            fingerprint: fingerprint.to_string(),
            generation: strategy.generation(),
            strategy: strategy.state(),
            log: log.clone(),
        };
        write_json_atomic(&checkpoint_path, &checkpoint)
            .map_err(|e| io_error(&checkpoint_path, e))?;
    }

    let best_genes = strategy.best().map(<[f32]>::to_vec).ok_or_else(|| {
        io_error(
            &checkpoint_path,
            "finished checkpoint without a best genome",
        )
    })?;
    let controller = template
        .with_free_genome(&best_genes)
        .map_err(|e| io_error(&checkpoint_path, e))?;
    let best_path = run_dir.join(BEST);
    let json = controller
        .to_json_pretty()
        .map_err(|e| io_error(&best_path, e))?;
    write_atomic(&best_path, json.as_bytes()).map_err(|e| io_error(&best_path, e))?;
    let samples = post_evaluation::post_evaluation_samples(
        &plan.task,
        plan.evolution.post_evaluation_samples,
        seeds::post_evaluation_seeds(run_seed, 1)[0],
    );
    let post_evaluation = post_evaluation::evaluate_controller(
        dispatcher,
        &settings.job,
        controller,
        plan.task.clone(),
        samples,
    )
    .await?;
    let summary = RunSummary {
        node: name.clone(),
        run,
        fingerprint: fingerprint.to_string(),
        run_seed,
        generations,
        final_best_fitness: log.last().map_or(0.0, |r| r.best),
        post_evaluation,
    };
    write_json_atomic(&summary_path, &summary).map_err(|e| io_error(&summary_path, e))?;
    // A finished run is its summary, best controller and fitness log; the checkpoint served
    // only to continue it.
    remove_if_present(&checkpoint_path)?;
    progress.event(&ProgressEvent::RunFinished {
        node: name.clone(),
        run,
        solve_rate: summary.post_evaluation.solve_rate,
    });
    Ok(summary)
}

/// A genome's behaviour descriptor: each value the mean over its samples (empty when the
/// samples carry none). What a strategy is told, and what `hevo.evaluate` reports.
pub fn mean_descriptor(samples: &[SampleSummary]) -> Vec<f64> {
    let Some(first) = samples.first() else {
        return Vec::new();
    };
    (0..first.descriptor.len())
        .map(|idx| {
            samples
                .iter()
                .map(|s| f64::from(s.descriptor.get(idx).copied().unwrap_or(0.0)))
                .sum::<f64>()
                / samples.len() as f64
        })
        .collect()
}

/// Writes a grid archive's `archive.json` and `qd.csv` (the format of
/// [`hevo_rundir::archive`]) after `generation` generations; its latest measures.
fn write_archive(
    run_dir: &Path,
    grid: &GridArchive,
    plan: &NodePlan,
    generation: u32,
) -> Result<ArchiveProgress, RunError> {
    let cells = grid.n_cells();
    let file = ArchiveFile {
        format: ARCHIVE_FORMAT.into(),
        generation,
        descriptor: plan
            .task
            .scenario
            .descriptor_names()
            .into_iter()
            .map(String::from)
            .collect(),
        bins: grid.bins().to_vec(),
        ranges: grid.ranges().to_vec(),
        elites: grid
            .elites()
            .map(|elite| ArchiveElite {
                cell: elite.cell,
                bins: grid.bins_of(elite.cell),
                fitness: elite.fitness,
                descriptor: elite.descriptor.clone(),
                genes: elite.genes.clone(),
            })
            .collect(),
    };
    let path = run_dir.join(ARCHIVE_JSON);
    write_json_atomic(&path, &file).map_err(|e| io_error(&path, e))?;
    let rows: Vec<QdRow> = (0u32..)
        .zip(grid.history())
        .map(|(generation, point)| QdRow {
            generation,
            filled: point.filled,
            cells,
            qd_score: point.qd_score,
            best: point.best,
        })
        .collect();
    let path = run_dir.join(QD_CSV);
    write_atomic(&path, qd_csv(&rows).as_bytes()).map_err(|e| io_error(&path, e))?;
    let last = grid.history().last().copied().unwrap_or(QdPoint {
        filled: 0,
        qd_score: 0.0,
        best: f64::NEG_INFINITY,
    });
    Ok(ArchiveProgress {
        filled: last.filled,
        cells,
        qd_score: last.qd_score,
        best_elite: last.best,
    })
}

fn remove_if_present(path: &Path) -> Result<(), RunError> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(io_error(path, e)),
    }
}

fn log_row(generation: u32, fitness: &[f64]) -> FitnessRow {
    let n = fitness.len().max(1) as f64;
    let mean = fitness.iter().sum::<f64>() / n;
    let var = fitness.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / n;
    FitnessRow {
        generation,
        best: fitness.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        mean,
        min: fitness.iter().copied().fold(f64::INFINITY, f64::min),
        max: fitness.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        std: var.sqrt(),
    }
}

fn write_fitness_csv(path: &Path, log: &[FitnessRow]) -> Result<(), RunError> {
    write_atomic(path, rundir::fitness_csv(log).as_bytes()).map_err(|e| io_error(path, e))
}

#[cfg(test)]
mod tests {
    //! The run-level selection invariant, with a fake evaluation whose fitness is computed from
    //! the genes. Elites are re-evaluated on each generation's fresh samples, so a generation's
    //! best fitness may be lower than the previous one's; what must hold is that the elites of
    //! generation g (its five fittest, by the fitness evaluated in g) appear unchanged in
    //! generation g+1's population, first in rank order, and that the best fitness reported for
    //! g is the best of the fitness evaluated in g.

    use super::*;
    use crate::dispatch::{Batch, DispatchConfig};
    use hevo_evolve::ga::{GaState, initial_population};
    use hevo_evolve::{StrategySettings, StrategyState};
    use hevo_sim_core::SampleSummary;
    use std::collections::HashMap;
    use std::sync::Mutex;
    use std::time::Duration;

    const EXPERIMENT: &str = r#"
[experiment]
name = "planted"
seed = 3

[evolution]
post_evaluation_samples = 2

[[node]]
name = "exit_room"
kind = "primitive"
inputs = ["ir"]
hidden = 2
task = "exit_room"
samples = 4
generations = 6
runs = 1
"#;

    const GENERATIONS: u32 = 6;
    const SAMPLES: u32 = 4;
    /// Every gene of the planted genome: far from the initial genes, drawn from N(0, 2^2).
    const PLANTED_GENE: f32 = 7.5;
    /// Where it is planted in the first population.
    const PLANTED_AT: usize = 37;

    /// A uniform draw in [0, 1) from a sample's seed and a genome's genes.
    fn unit(seed: u64, genes: &[f32]) -> f32 {
        let mut bytes = seed.to_le_bytes().to_vec();
        bytes.extend(genes.iter().flat_map(|g| g.to_le_bytes()));
        (hevo_sim_core::fnv1a(&bytes) % 1000) as f32 / 1000.0
    }

    /// A sample's fake fitness, inside exit_room's range [0, 6] (the dispatcher refuses any
    /// other): an offset in [0, 3) from the sample's seed alone, plus 3 exp(-d s) for the
    /// squared distance d to the planted genome scaled by a factor s in (0.5, 1] drawn from the
    /// sample and the genes. The planted genome (d = 0) scores the offset plus 3, strictly more
    /// than any other genome on the same sample; the others' order changes from sample to
    /// sample.
    fn fake_fitness(genes: &[f32], seed: u64) -> f32 {
        let distance: f32 = genes.iter().map(|g| (g - PLANTED_GENE).powi(2)).sum();
        let offset = (seed % 1000) as f32 * 0.003;
        offset + 3.0 * (-distance * (1.0 - 0.5 * unit(seed, genes))).exp()
    }

    /// A genome's fitness as the runner computes it: the mean of its sample fitness.
    fn fitness_of(genes: &[f32], seeds: &[u64]) -> f64 {
        seeds
            .iter()
            .map(|&seed| f64::from(fake_fitness(genes, seed)))
            .sum::<f64>()
            / seeds.len() as f64
    }

    fn fake_results(batch: &Batch) -> Vec<Vec<SampleSummary>> {
        batch
            .genomes
            .iter()
            .map(|(_, genes)| {
                batch
                    .samples
                    .iter()
                    .map(|sample| SampleSummary {
                        fitness: fake_fitness(genes, sample.seed),
                        cycles: 1,
                        // A behaviour: where the first two genes point.
                        descriptor: vec![
                            genes.first().copied().unwrap_or(0.0),
                            genes.get(1).copied().unwrap_or(0.0),
                        ],
                        ..SampleSummary::default()
                    })
                    .collect()
            })
            .collect()
    }

    /// The genomes (index, genes) a worker was given, by the seed of the sample.
    type GenomesBySample = HashMap<u64, Vec<(u32, Vec<f32>)>>;

    /// A fake worker on the dispatcher, recording every genome it is given, by sample.
    fn spawn_fake_worker(
        dispatcher: Arc<Dispatcher>,
        seen: Arc<Mutex<GenomesBySample>>,
    ) -> tokio::task::JoinHandle<()> {
        tokio::spawn(async move {
            loop {
                let Some(batch) = dispatcher
                    .lease("fake", 1, Duration::from_millis(200))
                    .await
                else {
                    continue;
                };
                {
                    let mut seen = seen.lock().unwrap();
                    for sample in batch.samples.iter() {
                        for (idx, genes) in &batch.genomes {
                            seen.entry(sample.seed)
                                .or_default()
                                .push((*idx, genes.to_vec()));
                        }
                    }
                }
                let results = fake_results(&batch);
                dispatcher
                    .complete(batch.lease_id, batch.batch_id, "fake", results)
                    .expect("the dispatcher takes the fake results");
            }
        })
    }

    /// Awaits `run` while the fake `worker` serves it: a panic in the worker (its results
    /// refused, say) fails the test with the worker's message instead of leaving the run
    /// waiting for ever, and the run is bounded in time.
    async fn served<T>(
        run: impl std::future::Future<Output = T>,
        worker: &mut tokio::task::JoinHandle<()>,
    ) -> T {
        tokio::select! {
            outcome = tokio::time::timeout(Duration::from_secs(300), run) => {
                outcome.expect("the run finished within 300 s")
            }
            ended = worker => panic!("the fake worker stopped: {ended:?}"),
        }
    }

    #[derive(Default)]
    struct Recorder(Mutex<Vec<ProgressEvent>>);

    impl Progress for Recorder {
        fn event(&self, event: &ProgressEvent) {
            self.0.lock().unwrap().push(event.clone());
        }
    }

    #[tokio::test]
    async fn a_planted_best_genome_survives_every_generation_and_elites_are_kept_unchanged() {
        let dir = tempfile::tempdir().unwrap();
        let out_dir = dir.path().to_path_buf();
        let experiment = Experiment::parse(EXPERIMENT, &out_dir.join("planted.toml")).unwrap();
        let plan = experiment.node("exit_room").unwrap();
        let template = node_template(plan, &out_dir).unwrap();
        let n_genes = template.free_node_topology().unwrap().1.n_genes();
        let run_seed = seeds::run_seed(3, "exit_room", 0);

        // Plant: the first population is the run's own, with one genome replaced, written as
        // the checkpoint of a run that has not evaluated anything yet.
        let planted = vec![PLANTED_GENE; n_genes];
        let StrategySettings::Ga(ga_settings) = plan.evolution.strategy_settings() else {
            panic!("the experiment's nodes use the GA");
        };
        let mut first = initial_population(n_genes, &ga_settings, run_seed);
        assert!(!first.contains(&planted));
        first[PLANTED_AT] = planted.clone();
        let run_dir = run_dir(&rundir::node_dir(&out_dir, "exit_room"), 0);
        std::fs::create_dir_all(&run_dir).unwrap();
        let checkpoint = Checkpoint {
            format: CHECKPOINT_FORMAT.into(),
            fingerprint: fingerprint(plan, &template, 3, GENERATIONS),
            generation: 0,
            strategy: StrategyState::Ga(GaState {
                run_seed,
                generation: 0,
                population: first.clone(),
                best: None,
            }),
            log: Vec::new(),
        };
        write_json_atomic(&run_dir.join(CHECKPOINT), &checkpoint).unwrap();

        // A fake worker on the dispatcher, recording every genome it is given, by sample.
        let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
        let seen: Arc<Mutex<GenomesBySample>> = Arc::default();
        let mut worker = spawn_fake_worker(dispatcher.clone(), seen.clone());
        let settings = RunSettings {
            out_dir: out_dir.clone(),
            overrides: Overrides::default(),
            job: "planted".into(),
        };
        let recorder = Recorder::default();
        let summaries = served(
            run_experiment(&experiment, &settings, &dispatcher, &recorder),
            &mut worker,
        )
        .await
        .unwrap();
        worker.abort();

        // Each generation's population, as it was sent out, and its fitness.
        let seen = seen.lock().unwrap();
        let mut populations = Vec::new();
        let mut fitness = Vec::new();
        for generation in 0..GENERATIONS {
            let seeds = seeds::generation_seeds(run_seed, generation, SAMPLES);
            let mut population = vec![None; 100];
            for (idx, genes) in &seen[&seeds[0]] {
                assert!(population[*idx as usize].replace(genes.clone()).is_none());
            }
            let population: Vec<Vec<f32>> = population.into_iter().map(Option::unwrap).collect();
            fitness.push(
                population
                    .iter()
                    .map(|genes| fitness_of(genes, &seeds))
                    .collect::<Vec<f64>>(),
            );
            populations.push(population);
        }
        assert_eq!(
            populations[0], first,
            "the run started from the planted checkpoint"
        );

        for generation in 0..GENERATIONS as usize {
            let f = &fitness[generation];
            // The five fittest of this generation, best first, ties to the lower index.
            let mut order: Vec<usize> = (0..f.len()).collect();
            order.sort_by(|&a, &b| f[b].partial_cmp(&f[a]).unwrap().then(a.cmp(&b)));
            let planted_at = if generation == 0 { PLANTED_AT } else { 0 };
            assert_eq!(
                order[0], planted_at,
                "generation {generation}: the planted genome is the fittest"
            );
            assert_eq!(populations[generation][planted_at], planted);
            if let Some(next) = populations.get(generation + 1) {
                for (rank, &elite) in order.iter().take(5).enumerate() {
                    assert_eq!(
                        next[20 * rank],
                        populations[generation][elite],
                        "generation {generation}'s elite {rank} (genome {elite}) is kept unchanged"
                    );
                }
            }
        }

        // The reported best is the best of the evaluated fitness, in the log and the events.
        let best: Vec<f64> = fitness
            .iter()
            .map(|f| f.iter().copied().fold(f64::NEG_INFINITY, f64::max))
            .collect();
        let mean: Vec<f64> = fitness
            .iter()
            .map(|f| f.iter().sum::<f64>() / f.len() as f64)
            .collect();
        let csv = std::fs::read_to_string(run_dir.join(FITNESS_CSV)).unwrap();
        let log = rundir::parse_fitness_csv(&csv).unwrap();
        assert_eq!(log.iter().map(|r| r.best).collect::<Vec<_>>(), best);
        assert_eq!(log.iter().map(|r| r.mean).collect::<Vec<_>>(), mean);
        let events = recorder.0.lock().unwrap();
        let reported: Vec<(f64, f64)> = events
            .iter()
            .filter_map(|event| match event {
                ProgressEvent::Generation { best, mean, .. } => Some((*best, *mean)),
                _ => None,
            })
            .collect();
        assert_eq!(
            reported,
            best.iter()
                .copied()
                .zip(mean.iter().copied())
                .collect::<Vec<_>>()
        );
        // The same elite scores differently on fresh samples: the best is not monotone.
        assert!(
            best.windows(2).any(|pair| pair[1] < pair[0]),
            "the test's samples should make the best go down once: {best:?}"
        );

        // The run's best controller is the planted genome, and its summary says so.
        let summary = &summaries[0].runs[0];
        assert_eq!(summary.final_best_fitness, best[GENERATIONS as usize - 1]);
        let text = std::fs::read_to_string(run_dir.join(BEST)).unwrap();
        let controller = ControllerFile::from_json_str(&text).unwrap();
        assert_eq!(controller.root.genome.as_deref(), Some(&planted[..]));
        assert!(!run_dir.join(CHECKPOINT).exists());
    }

    /// Signals once a given generation has been evaluated (the runner writes its checkpoint
    /// before it next waits).
    struct PauseAfter {
        generation: u32,
        evaluated: tokio::sync::Notify,
    }

    impl Progress for PauseAfter {
        fn event(&self, event: &ProgressEvent) {
            if let ProgressEvent::Generation { generation, .. } = event
                && *generation == self.generation
            {
                self.evaluated.notify_one();
            }
        }
    }

    /// Every file under a directory, by path relative to it, with its bytes.
    fn tree(dir: &Path) -> std::collections::BTreeMap<PathBuf, Vec<u8>> {
        let mut files = std::collections::BTreeMap::new();
        let mut stack = vec![dir.to_path_buf()];
        while let Some(at) = stack.pop() {
            for entry in std::fs::read_dir(&at).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else {
                    let bytes = std::fs::read(&path).unwrap();
                    files.insert(path.strip_prefix(dir).unwrap().to_path_buf(), bytes);
                }
            }
        }
        files
    }

    /// Runs the experiment `text` straight, and again stopped once generation 2 is evaluated
    /// and checkpointed (as a kill would leave it), then, after `meanwhile` has seen (or
    /// rewritten) the checkpoint, resumed; both must end with the same files, byte for byte.
    async fn paused_and_resumed_ends_as_straight(text: &str, meanwhile: impl FnOnce(&Path)) {
        let dir = tempfile::tempdir().unwrap();
        let experiment = Experiment::parse(text, &dir.path().join("e.toml")).unwrap();
        let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
        let mut worker = spawn_fake_worker(dispatcher.clone(), Arc::default());
        let settings_for = |out_dir: PathBuf| RunSettings {
            out_dir,
            overrides: Overrides::default(),
            job: "paused".into(),
        };

        let straight = settings_for(dir.path().join("straight"));
        served(
            run_experiment(&experiment, &straight, &dispatcher, &Recorder::default()),
            &mut worker,
        )
        .await
        .unwrap();

        let paused = settings_for(dir.path().join("paused"));
        let pause = PauseAfter {
            generation: 2,
            evaluated: tokio::sync::Notify::new(),
        };
        let paused_run = async {
            tokio::select! {
                biased;
                _ = run_experiment(&experiment, &paused, &dispatcher, &pause) => {
                    panic!("the run should have been stopped after generation 2")
                }
                () = pause.evaluated.notified() => {}
            }
        };
        served(paused_run, &mut worker).await;
        meanwhile(&run_dir(&paused.out_dir.join("exit_room"), 0).join(CHECKPOINT));

        let recorder = Recorder::default();
        served(
            run_experiment(&experiment, &paused, &dispatcher, &recorder),
            &mut worker,
        )
        .await
        .unwrap();
        worker.abort();
        assert!(recorder.0.lock().unwrap().contains(&ProgressEvent::Note {
            message: "exit_room run 0: resuming at generation 3".into()
        }));
        assert_eq!(tree(&paused.out_dir), tree(&straight.out_dir));
    }

    fn read_checkpoint(path: &Path) -> Checkpoint {
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    #[tokio::test]
    async fn a_run_paused_under_a_population_only_checkpoint_ends_as_an_uninterrupted_one() {
        paused_and_resumed_ends_as_straight(EXPERIMENT, |checkpoint_path| {
            // Rewritten as the runner wrote it before strategies had their own state: format
            // 1, the population alone.
            let checkpoint = read_checkpoint(checkpoint_path);
            assert_eq!(checkpoint.generation, 3);
            let StrategyState::Ga(ga_state) = checkpoint.strategy else {
                panic!("the run uses the GA");
            };
            let population_only = serde_json::json!({
                "format": rundir::CHECKPOINT_FORMAT_POPULATION,
                "fingerprint": checkpoint.fingerprint,
                "generation": checkpoint.generation,
                "population": ga_state.population,
                "best": null,
                "log": checkpoint.log,
            });
            write_json_atomic(checkpoint_path, &population_only).unwrap();
        })
        .await;
    }

    #[tokio::test]
    async fn a_cmaes_run_paused_and_resumed_ends_as_an_uninterrupted_one() {
        let cmaes = EXPERIMENT.replace(
            "post_evaluation_samples = 2",
            "post_evaluation_samples = 2\nalgorithm = \"cmaes\"\npopulation = 12",
        );
        paused_and_resumed_ends_as_straight(&cmaes, |checkpoint_path| {
            let checkpoint = read_checkpoint(checkpoint_path);
            assert_eq!(checkpoint.generation, 3);
            let StrategyState::Cmaes(state) = checkpoint.strategy else {
                panic!("the run uses CMA-ES");
            };
            assert_eq!((state.generation, state.population.len()), (3, 12));
        })
        .await;
    }

    /// CMA-ES's settings of `EXPERIMENT`'s node, with extra keys.
    fn cmaes_experiment(keys: &str) -> String {
        EXPERIMENT.replace(
            "post_evaluation_samples = 2",
            &format!("post_evaluation_samples = 2\nalgorithm = \"cmaes\"\n{keys}"),
        )
    }

    #[tokio::test]
    async fn a_separable_cmaes_run_with_restarts_paused_and_resumed_ends_as_an_uninterrupted_one() {
        // The fake fitness of a genome far from the planted one is its sample's offset alone,
        // the same for every genome: each search ends after its first generation (pycma's
        // TolFun), so the population doubles from 4 to 32 over generations 0-2, and the pause
        // after generation 2 saves the state the last restart made.
        let cmaes = cmaes_experiment("population = 4\ncmaes_variant = \"separable\"\nrestarts = 3");
        paused_and_resumed_ends_as_straight(&cmaes, |checkpoint_path| {
            let checkpoint = read_checkpoint(checkpoint_path);
            let StrategyState::Cmaes(state) = checkpoint.strategy else {
                panic!("the run uses CMA-ES");
            };
            assert_eq!((state.generation, state.population.len()), (3, 32));
            assert!(state.covariance.is_empty(), "separable: no full matrix");
            assert!(state.covariance_diagonal.is_some());
            let restarts = state.restarts.expect("restarts are on");
            assert_eq!((restarts.restarts_done, restarts.started_at), (3, 3));
        })
        .await;
    }

    #[tokio::test]
    async fn a_novelty_run_paused_and_resumed_ends_as_an_uninterrupted_one() {
        // The fake behaviour is the first two genes: the archive fills with genomes' positions.
        let novelty = EXPERIMENT.replace(
            "post_evaluation_samples = 2",
            "post_evaluation_samples = 2\nalgorithm = \"novelty\"\npopulation = 12\nelites = 3\n\
             novelty_neighbours = 4\nnovelty_archive_per_generation = 3\nnovelty_fitness_weight = 0.25",
        );
        paused_and_resumed_ends_as_straight(&novelty, |checkpoint_path| {
            let checkpoint = read_checkpoint(checkpoint_path);
            let StrategyState::Novelty(state) = checkpoint.strategy else {
                panic!("the run uses novelty search");
            };
            assert_eq!((state.generation, state.population.len()), (3, 12));
            assert_eq!(state.archive.len(), 9);
            assert!(state.archive.iter().all(|behaviour| behaviour.len() == 2));
        })
        .await;
    }

    fn map_elites_experiment(keys: &str) -> String {
        EXPERIMENT.replace(
            "post_evaluation_samples = 2",
            &format!(
                "post_evaluation_samples = 2\nalgorithm = \"map_elites\"\npopulation = 10\n\
                 map_elites_bins = [5, 4]\nmap_elites_ranges = [[-4.0, 4.0], [-4.0, 4.0]]\n{keys}"
            ),
        )
    }

    #[tokio::test]
    async fn a_map_elites_run_paused_and_resumed_ends_as_an_uninterrupted_one() {
        // The fake behaviour is the first two genes: the grid fills with genomes' positions.
        let map_elites =
            map_elites_experiment("map_elites_variation = \"iso_line\"\nmap_elites_initial = 15");
        paused_and_resumed_ends_as_straight(&map_elites, |checkpoint_path| {
            let checkpoint = read_checkpoint(checkpoint_path);
            let StrategyState::MapElites(state) = checkpoint.strategy else {
                panic!("the run uses MAP-Elites");
            };
            assert_eq!((state.generation, state.batch.len()), (3, 10));
            assert_eq!(state.history.len(), 3);
            // The archive beside the checkpoint is the state's, with the grid's shape.
            let run_dir = checkpoint_path.parent().unwrap();
            let archive = ArchiveFile::read(&run_dir.join(ARCHIVE_JSON)).unwrap();
            assert_eq!(archive.generation, 3);
            assert_eq!(archive.descriptor, ["final.x", "final.y"]);
            assert_eq!(
                (archive.bins.as_slice(), archive.n_cells()),
                (&[5, 4][..], 20)
            );
            let cells: Vec<u64> = state.elites.iter().map(|e| e.cell).collect();
            let saved: Vec<u64> = archive.elites.iter().map(|e| e.cell).collect();
            assert_eq!(saved, cells);
            assert!(cells.len() > 3, "{cells:?}");
            let qd = std::fs::read_to_string(run_dir.join(QD_CSV)).unwrap();
            let rows = hevo_rundir::archive::parse_qd_csv(&qd).unwrap();
            assert_eq!(rows.len(), 3);
            assert_eq!(rows[2].filled, cells.len() as u64);
            let qd_score: f64 = archive.elites.iter().map(|e| e.fitness).sum();
            assert_eq!(rows[2].qd_score, qd_score);
        })
        .await;
    }

    /// Runs the experiment `experiment(first)` to its end and lets `check` look at its output
    /// directory; runs it again (a finished run is taken as it is); then asserts that each of
    /// `changed` is refused by the fingerprint.
    async fn changed_settings_are_refused(
        experiment: impl Fn(&str) -> String,
        first: &str,
        changed: &[&str],
        check: impl FnOnce(&Path),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
        let mut worker = spawn_fake_worker(dispatcher.clone(), Arc::default());
        let settings = RunSettings {
            out_dir: dir.path().join("out"),
            overrides: Overrides::default(),
            job: "changed".into(),
        };
        let run = async |keys: &str| {
            let experiment =
                Experiment::parse(&experiment(keys), &dir.path().join("e.toml")).unwrap();
            run_experiment(&experiment, &settings, &dispatcher, &Recorder::default()).await
        };
        served(run(first), &mut worker).await.unwrap();
        check(&settings.out_dir);
        served(run(first), &mut worker).await.unwrap();
        for changed in changed {
            let error = served(run(changed), &mut worker).await.unwrap_err();
            assert!(
                matches!(error, RunError::Fingerprint { .. }),
                "{changed}: {error}"
            );
        }
        worker.abort();
    }

    #[tokio::test]
    async fn a_changed_map_elites_setting_is_refused_by_the_fingerprint() {
        let changed = [
            "map_elites_sigma = 0.5",
            "map_elites_sigma = 0.25\nmap_elites_variation = \"iso_line\"",
            "map_elites_sigma = 0.25\nmap_elites_initial = 20",
            "map_elites_sigma = 0.25\nmap_elites_line_sigma = 0.3",
        ];
        changed_settings_are_refused(
            map_elites_experiment,
            "map_elites_sigma = 0.25",
            &changed,
            |out_dir| {
                let run_dir = run_dir(&out_dir.join("exit_room"), 0);
                let archive = ArchiveFile::read(&run_dir.join(ARCHIVE_JSON)).unwrap();
                assert_eq!(archive.generation, GENERATIONS);
                // The node's controller is the best elite's genome.
                let best = archive.elites.iter().fold(&archive.elites[0], |b, e| {
                    if e.fitness > b.fitness { e } else { b }
                });
                let controller = ControllerFile::from_json_str(
                    &std::fs::read_to_string(run_dir.join(BEST)).unwrap(),
                )
                .unwrap();
                assert_eq!(
                    controller.root.genome.as_deref(),
                    Some(best.genes.as_slice())
                );
            },
        )
        .await;
    }

    #[tokio::test]
    async fn a_changed_cmaes_variant_or_restart_setting_is_refused_by_the_fingerprint() {
        let changed = [
            "population = 4\nrestarts = 2",
            "population = 4\nrestarts = 1\nrestart_population_factor = 3",
            "population = 4\nrestarts = 1\ncmaes_variant = \"separable\"",
            "population = 4",
        ];
        changed_settings_are_refused(
            cmaes_experiment,
            "population = 4\nrestarts = 1",
            &changed,
            |_| {},
        )
        .await;
    }

    /// The run paused on purpose under `experiments/runs/` (exit room's run 4, stopped at
    /// generation 79 with a population-only checkpoint) must stay resumable: its fingerprint is
    /// still the one its experiment gives, and its checkpoint is read as the GA's state.
    #[test]
    fn the_paused_run_under_experiments_still_resumes() {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let experiment = Experiment::load(&repo.join("experiments/rescue.toml")).unwrap();
        let plan = experiment.node("exit_room").unwrap();
        let out_dir = repo.join("experiments/runs");
        let template = node_template(plan, &out_dir).unwrap();
        let n_genes = template.free_node_topology().unwrap().1.n_genes();
        let path = run_dir(&out_dir.join("exit_room"), 4).join(CHECKPOINT);
        let run_seed = seeds::run_seed(experiment.header.seed, "exit_room", 4);
        let checkpoint = read_json_with(&path, |text| parse_checkpoint(text, run_seed))
            .unwrap()
            .expect("the paused run's checkpoint is kept");
        assert_eq!(
            checkpoint.fingerprint,
            fingerprint(
                plan,
                &template,
                experiment.header.seed,
                plan.decl.generations
            )
        );
        assert_eq!(checkpoint.format, CHECKPOINT_FORMAT);
        assert_eq!((checkpoint.generation, checkpoint.log.len()), (79, 79));
        let strategy = plan
            .evolution
            .strategy_settings()
            .resume(n_genes, checkpoint.strategy)
            .unwrap();
        assert_eq!(strategy.generation(), 79);
        assert_eq!(strategy.ask().len(), 100);
        assert_eq!(strategy.best(), None);
    }
}
