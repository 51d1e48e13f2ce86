//! The run-directory format, in one place, for every crate that writes or reads run output:
//! where a run output directory keeps each node and run and what its files are called
//! ([`layout`]), the run and node summaries, the fitness logs ([`fitness_log`]), a MAP-Elites
//! run's archive and its measures per generation ([`archive`]), the
//! post-evaluation reports the summaries hold ([`eval_report`]), and the atomic writes and
//! named-error reads of those files ([`store`]). Plain data and files: the engine writes this
//! format (its checkpoints, which hold a search strategy's state, are its own), and the
//! pictures, the report and the dashboard read it without the engine.

pub mod archive;
pub mod eval_report;
pub mod fitness_log;
pub mod layout;
pub mod store;

pub use fitness_log::*;
pub use layout::*;
