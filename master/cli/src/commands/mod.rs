//! One module per `hevo` subcommand: its arguments (clap) and the function that runs it.
//! `cli.rs` lists them and dispatches; shared flags are in `args.rs`, the runtime in
//! `runtime.rs`.

pub mod archive;
pub mod bench;
pub mod cancel;
pub mod dashboard;
pub mod delete;
pub mod eval;
pub mod export;
pub mod fetch;
pub mod jobs;
pub mod plot;
pub mod replay;
pub mod report;
pub mod run;
pub mod scenario;
pub mod serve;
pub mod submit;
pub mod watch;
