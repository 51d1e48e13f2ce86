//! hevo's master: the experiment files, the evolutionary algorithm, the scheduler that hands
//! batches of genome evaluations to workers (in-process threads or remote gRPC workers), the
//! resumable run driver, the distributed evaluation service (`hevo serve` and its client
//! commands), and the library behind every `hevo` subcommand.

pub mod bench;
pub mod cli;
pub mod dispatch;
pub mod ea;
pub mod evaluation;
pub mod experiment;
pub mod local;
pub mod output;
pub mod progress;
pub mod report;
pub mod runner;
pub mod sampling;
pub mod service;
pub mod store;
pub mod viz;
