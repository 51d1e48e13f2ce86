//! The command line's integration tests, one binary: each module is one behaviour (`hevo run`
//! end to end, `hevo scenario`, the tutorial as written, the checks of bad values), and
//! `support` holds what they share. Run one module with `cargo test -p hevo-cli --test cli
//! MODULE::`.

mod run_cli;
mod scenario_cli;
mod support;
mod tutorial;
mod validation;
