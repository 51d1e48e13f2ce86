//! The `hevo` command: clap definitions ([`cli`]), one module per subcommand ([`commands`]),
//! progress bars and printing, and the client commands' output (`watch`, `jobs`). Everything
//! it does is a call into the engine, the service, hevo-client or the pictures; this crate only
//! parses, prints and connects. Modules import downwards only: `cli` -> `commands` -> `args`,
//! `inputs`, `runtime`, `client`, `progress`, `output`.

pub mod args;
pub mod cli;
pub mod client;
pub mod commands;
pub mod inputs;
pub mod output;
pub mod progress;
pub mod runtime;
