//! hevo's live dashboard: HTML pages and a Server-Sent Events stream per job, over anything
//! that implements [`Source`]: the master's jobs (`hevo serve --http-listen`, implemented in
//! hevo-service) or local run directories (`hevo dashboard RUNS_DIR...`, [`rundirs`]). The
//! pages show the jobs, each job's nodes and runs with their fitness curves (hevo-viz's plot,
//! redrawn as generations finish), the post-evaluation table of each finished node and the
//! best controller's replay per variant with a cycle slider; a job can be cancelled.
//!
//! Everything the browser needs is in the binary (hand-written CSS and JavaScript, SVG drawn
//! by hevo-viz); the pages read without JavaScript, which only adds the live updates, the
//! slider and the robot marker. Every page and stream but the login page asks for a token
//! ([`auth`]). Bad requests get a plain page with a 400 or 404 naming what was wrong.

pub mod auth;
pub mod connections;
pub mod html;
pub mod pages;
pub mod replay;
pub mod rundirs;
pub mod server;
pub mod stream;

use hevo_rundir::archive::{ArchiveFile, QdRow};
use hevo_rundir::eval_report::EvalReport;
use hevo_rundir::{FitnessRow, NodeSummary, RunSummary};
use hevo_sim_core::ControllerFile;
use hevo_sim_core::TaskConfig;
use std::future::Future;
use std::pin::Pin;

pub use auth::Access;
pub use connections::ConnectionLimits;
pub use server::{Dashboard, serve};

/// What the pages say about one job (for run directories: one directory).
#[derive(Debug, Clone, PartialEq)]
pub struct JobOverview {
    /// The id in the job's URL.
    pub id: String,
    /// The experiment's name (or the directory's).
    pub name: String,
    /// Its state in words: `running`, `succeeded`, `cancelled`, `finished`, ...
    pub state: String,
    /// Whether it will not change any more.
    pub finished: bool,
    /// Generations evaluated so far.
    pub generations_done: u64,
    /// Generations the whole job evaluates, when known.
    pub generations_total: Option<u64>,
    /// Submission time, ms since the Unix epoch, when known.
    pub created_unix_ms: Option<i64>,
    /// When it reached a final state.
    pub finished_unix_ms: Option<i64>,
    /// Why it failed.
    pub error: Option<String>,
    /// Its nodes, in the order they run.
    pub nodes: Vec<String>,
    /// Whether the dashboard can cancel it.
    pub cancellable: bool,
    /// Where its files are, for the page's header.
    pub location: String,
}

/// One node of a job as the run directory holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeView {
    /// The node's name.
    pub name: String,
    /// Its runs, in run order.
    pub runs: Vec<RunView>,
    /// The node's summary, once every run has finished.
    pub summary: Option<NodeSummary>,
    /// (runs, generations) the job plans for it, when known.
    pub planned: Option<(u32, u32)>,
}

impl NodeView {
    /// Whether every run has finished and the node's best controller is chosen. A summary
    /// that covers fewer runs than the directory holds (or the job plans) is an earlier one,
    /// left by a `--runs` extension that has not finished.
    pub fn finished(&self) -> bool {
        self.summary.as_ref().is_some_and(|summary| {
            let planned_runs = self.planned.map_or(0, |(runs, _)| runs as usize);
            summary.runs.len() >= self.runs.len().max(planned_runs)
        })
    }

    /// Generations with a fitness row, over all runs.
    pub fn generations_done(&self) -> usize {
        self.runs.iter().map(|r| r.rows.len()).sum()
    }
}

/// One run of a node.
#[derive(Debug, Clone, PartialEq)]
pub struct RunView {
    /// The run's index.
    pub run: u32,
    /// Its fitness log so far.
    pub rows: Vec<FitnessRow>,
    /// Its summary, once finished.
    pub summary: Option<RunSummary>,
    /// A MAP-Elites run's archive as last written; `None` for the other algorithms.
    pub archive: Option<ArchiveFile>,
    /// A MAP-Elites run's QD-score and coverage per generation; empty for the others.
    pub qd: Vec<QdRow>,
}

impl RunView {
    /// The run's post-evaluation report, once finished.
    pub fn post_evaluation(&self) -> Option<&EvalReport> {
        self.summary.as_ref().map(|s| &s.post_evaluation)
    }
}

/// A node's best controller and the task it was evolved on.
#[derive(Debug, Clone)]
pub struct BestController {
    /// The controller file (`best.json`).
    pub file: ControllerFile,
    /// The task to replay it on.
    pub task: TaskConfig,
}

/// A worker the master sees, for the jobs page.
#[derive(Debug, Clone, PartialEq)]
pub struct WorkersView {
    /// Workers seen lately.
    pub active_workers: usize,
    /// Their threads.
    pub active_threads: usize,
    /// Batches out on lease.
    pub leased_batches: usize,
    /// Batches waiting for a worker.
    pub queued_batches: usize,
    /// (genome, sample) evaluations accepted since the master started.
    pub evaluations: u64,
    /// Batches completed since the master started.
    pub batches_completed: u64,
    /// The spot checks, when the master re-evaluates a share of batches (`--verify-share`).
    pub spot_checks: Option<SpotChecksView>,
}

/// What the master's spot checks found, for the jobs page.
#[derive(Debug, Clone, PartialEq)]
pub struct SpotChecksView {
    /// The share of batches re-evaluated by the master (every worker's first result is too).
    pub share: f64,
    /// Results compared with the master's own evaluation.
    pub checked: u64,
    /// Workers whose results differed: refused from then on, in name order.
    pub refused_workers: Vec<String>,
}

/// Why a source could not answer.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SourceError {
    /// No job with this id.
    #[error("no job {0}")]
    NotFound(String),
    /// The request cannot be done here (cancelling a local run directory).
    #[error("{0}")]
    Unsupported(String),
    /// The request is malformed; the message names what is wrong.
    #[error("{0}")]
    Invalid(String),
    /// Reading failed.
    #[error("{0}")]
    Failed(String),
}

/// A boxed future, so [`Source`] stays object-safe.
pub type BoxFuture<'a, T> = Pin<Box<dyn Future<Output = T> + Send + 'a>>;

/// What the pages read from. Methods that read files are called off the async threads.
pub trait Source: Send + Sync + 'static {
    /// What the dashboard shows, for the pages' title (`hevo master`, `run directories`).
    fn title(&self) -> String;
    /// Every job, newest first.
    fn jobs(&self) -> Vec<JobOverview>;
    /// One job.
    fn job(&self, id: &str) -> Result<JobOverview, SourceError>;
    /// A job's nodes with their runs and fitness logs, in the job's order.
    fn nodes(&self, id: &str) -> Result<Vec<NodeView>, SourceError>;
    /// A finished node's best controller; `None` before the node finished.
    fn best_controller(&self, id: &str, node: &str) -> Result<Option<BestController>, SourceError>;
    /// Cancels a job.
    fn cancel<'a>(&'a self, id: &'a str) -> BoxFuture<'a, Result<(), SourceError>>;
    /// The master's workers, when there are any.
    fn workers(&self) -> Option<WorkersView> {
        None
    }
    /// A counter that moves whenever any job may have changed: streams wait on it instead of
    /// polling.
    fn changes(&self) -> tokio::sync::watch::Receiver<u64>;
}
