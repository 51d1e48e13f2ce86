//! hevo's engine: everything that evolves and evaluates controller trees, and nothing that
//! talks to a network, parses a command line or draws. It reads experiment files
//! ([`experiment`]), drives each node's search strategy (`hevo_evolve`; the paper's GA by
//! default) node by node with checkpoints ([`runner`]), hands batches of genome evaluations
//! to workers through the [`dispatch`]er, evaluates them on the [`executor`] (in-process
//! workers: [`local`]; remote workers run the same executor), post-evaluates the results
//! ([`post_evaluation`]), and writes run directories in `hevo_rundir`'s format (re-exported
//! as [`rundir`], with the runner's checkpoints, and [`store`], the atomic writes). [`inputs`]
//! reads the task and controller of a one-off evaluation.
//!
//! The service, the worker, the pictures and the `hevo` command are built on it; it depends on
//! none of them.

pub mod bench;
pub mod dispatch;
pub mod executor;
pub mod experiment;
pub mod inputs;
pub mod local;
pub mod post_evaluation;
pub mod rundir;
pub mod runner;

pub use hevo_rundir::store;

pub use dispatch::{DispatchConfig, Dispatcher, EvaluationRequest};
pub use experiment::Experiment;
pub use runner::{Progress, ProgressEvent, RunSettings, run_experiment};
