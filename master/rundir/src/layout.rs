//! Where a run output directory keeps each node and run, and what its files are called and
//! hold: the names and paths, the run and node summaries, and the reading of every run's
//! fitness log under a node.
//!
//! ```text
//! <out>/<node>/best.json            the node's chosen controller (its best run's)
//! <out>/<node>/summary.json         NodeSummary: every run's post-evaluation, the best run
//! <out>/<node>/task.json            the task the node is evolved on (TaskConfig's wire form)
//! <out>/<node>/run-<k>/fitness.csv  one FitnessRow per generation
//! <out>/<node>/run-<k>/checkpoint.json   the runner's checkpoint, while the run is in progress
//! <out>/<node>/run-<k>/best.json    the run's best controller
//! <out>/<node>/run-<k>/summary.json RunSummary, once the run is finished
//! <out>/<node>/run-<k>/archive.json MAP-Elites runs: the grid archive (crate::archive)
//! <out>/<node>/run-<k>/qd.csv       MAP-Elites runs: coverage and QD-score per generation
//! ```

use crate::eval_report::EvalReport;
use crate::fitness_log::{FitnessLogError, FitnessRow, parse_fitness_csv};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A controller file: a node's chosen controller, or a run's best.
pub const BEST: &str = "best.json";
/// A node's [`NodeSummary`] or a run's [`RunSummary`].
pub const SUMMARY: &str = "summary.json";
/// A node's task: `hevo_sim_core::TaskConfig` in its wire form (the scenario's text and the
/// controller files its groups run, or a paper task's name, with every number in force),
/// written when the node starts, so a replay needs neither the experiment nor its files.
/// Run directories written before it existed lack it.
pub const TASK: &str = "task.json";
/// A run's checkpoint (the runner's format; [`CheckpointHeader`] is its head); removed once
/// the run is finished.
pub const CHECKPOINT: &str = "checkpoint.json";
/// A run's fitness log, one [`FitnessRow`] per generation.
pub const FITNESS_CSV: &str = "fitness.csv";
/// A MAP-Elites run's archive: [`crate::archive::ArchiveFile`] as JSON.
pub const ARCHIVE_JSON: &str = "archive.json";
/// A MAP-Elites run's archive measures per generation, one [`crate::archive::QdRow`] a line.
pub const QD_CSV: &str = "qd.csv";

/// The files a finished run keeps, and a fetch or a copy of a run directory carries (the
/// archive's two only for MAP-Elites runs).
pub const FINISHED_RUN_FILES: [&str; 5] = [FITNESS_CSV, BEST, SUMMARY, ARCHIVE_JSON, QD_CSV];
/// The files a finished node keeps beside its runs.
pub const FINISHED_NODE_FILES: [&str; 3] = [BEST, SUMMARY, TASK];

/// The directory of a node under a run output directory.
pub fn node_dir(out_dir: &Path, node: &str) -> PathBuf {
    out_dir.join(node)
}

/// The name of run `run`'s directory: the one place the `run-<k>` name is written.
pub fn run_dir_name(run: u32) -> String {
    format!("run-{run}")
}

/// The directory of run `run` of a node.
pub fn run_dir(node_dir: &Path, run: u32) -> PathBuf {
    node_dir.join(run_dir_name(run))
}

/// A node directory's run directories (`run-<k>`, see [`run_dir`]), in run order (run 10
/// after run 9), each with its run index. Other entries are left out.
pub fn run_dirs(node_dir: &Path) -> std::io::Result<Vec<(u32, PathBuf)>> {
    let mut runs: Vec<(u32, PathBuf)> = std::fs::read_dir(node_dir)?
        .filter_map(Result::ok)
        .filter_map(|entry| {
            let run = entry
                .file_name()
                .to_str()?
                .strip_prefix("run-")?
                .parse::<u32>()
                .ok()?;
            Some((run, entry.path()))
        })
        .collect();
    runs.sort();
    Ok(runs)
}

/// The head of a run's checkpoint, for readers that need to know whose a checkpoint is and how
/// far it got without loading its population.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct CheckpointHeader {
    /// The node's fingerprint when it was written.
    pub fingerprint: String,
    /// The next generation to evaluate.
    pub generation: u32,
}

/// A finished run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    /// Node.
    pub node: String,
    /// Run index.
    pub run: u32,
    /// Fingerprint of the node setup.
    pub fingerprint: String,
    /// The run's seed.
    pub run_seed: u64,
    /// Generations evolved.
    pub generations: u32,
    /// Training fitness of the best genome in the final generation.
    pub final_best_fitness: f64,
    /// Post-evaluation of that genome.
    pub post_evaluation: EvalReport,
}

/// A finished node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeSummary {
    /// Node.
    pub node: String,
    /// Task.
    pub task: String,
    /// Fingerprint.
    pub fingerprint: String,
    /// Every run.
    pub runs: Vec<RunSummary>,
    /// The run whose controller the node keeps.
    pub best_run: u32,
    /// Mean post-evaluation solve rate over runs (the paper's "avg").
    pub mean_solve_rate: f64,
    /// The best run's solve rate (the paper's "best").
    pub best_solve_rate: f64,
}

/// A run directory that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// A directory or file could not be read.
    #[error("cannot read {path}: {cause}")]
    Io {
        /// What was being read.
        path: PathBuf,
        /// Why not.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
    /// A fitness log does not parse.
    #[error("{path}: {cause}")]
    FitnessLog {
        /// The log.
        path: PathBuf,
        /// Where and what.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: FitnessLogError,
    },
}

/// Every run's fitness log under a node directory: the `run-<k>/fitness.csv` files, in run
/// order (run 10 after run 9), each with its run index. A run without a log yet is left out;
/// a log that does not parse is an error naming its file.
pub fn fitness_logs(node_dir: &Path) -> Result<Vec<(u32, Vec<FitnessRow>)>, RunDirError> {
    let runs = run_dirs(node_dir).map_err(|cause| RunDirError::Io {
        path: node_dir.to_path_buf(),
        cause,
    })?;
    let mut logs = Vec::new();
    for (run, dir) in runs {
        let path = dir.join(FITNESS_CSV);
        let Ok(text) = std::fs::read_to_string(&path) else {
            continue;
        };
        let rows =
            parse_fitness_csv(&text).map_err(|cause| RunDirError::FitnessLog { path, cause })?;
        logs.push((run, rows));
    }
    Ok(logs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fitness_log::FITNESS_CSV_HEADER;

    /// The message with its chain of causes, as `{:#}` (anyhow) prints it.
    fn with_chain(error: &dyn std::error::Error) -> String {
        let mut text = error.to_string();
        let mut cause = error.source();
        while let Some(next) = cause {
            text.push_str(&format!(": {next}"));
            cause = next.source();
        }
        text
    }

    #[test]
    fn a_missing_node_directory_names_its_cause_once() {
        let dir = tempfile::tempdir().unwrap();
        let error = fitness_logs(&dir.path().join("nowhere")).unwrap_err();
        let text = with_chain(&error);
        assert!(text.starts_with("cannot read "), "{text}");
        assert_eq!(text.matches("os error 2").count(), 1, "{text}");
    }

    #[test]
    fn fitness_logs_are_read_in_run_order_and_a_broken_log_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let log = format!("{FITNESS_CSV_HEADER}\n0,1,0.5,0,1,0.1\n");
        for run in [10, 2, 9] {
            let run_dir = run_dir(dir.path(), run);
            std::fs::create_dir_all(&run_dir).unwrap();
            std::fs::write(run_dir.join(FITNESS_CSV), &log).unwrap();
        }
        // A run that has not logged a generation yet, and a directory that is not a run.
        std::fs::create_dir_all(dir.path().join("run-11")).unwrap();
        std::fs::create_dir_all(dir.path().join("plots")).unwrap();
        let runs: Vec<u32> = fitness_logs(dir.path())
            .unwrap()
            .into_iter()
            .map(|(run, _)| run)
            .collect();
        assert_eq!(runs, [2, 9, 10]);

        std::fs::write(dir.path().join("run-9/fitness.csv"), "generation,best\n").unwrap();
        let err = fitness_logs(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("run-9") && err.contains("fitness.csv"),
            "{err}"
        );
        assert!(fitness_logs(&dir.path().join("missing")).is_err());
    }
}
