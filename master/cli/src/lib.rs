//! The `hevo` command: clap definitions, progress bars and printing, and the client side of the
//! service (`submit`, `watch`, `jobs`, `fetch`, `cancel`). Everything it does is a call into
//! the engine, the service or the pictures; this crate only parses, prints and connects.

pub mod cli;
pub mod client;
pub mod export_command;
pub mod output;
pub mod progress;
pub mod scenario_command;
pub mod service_commands;
