//! The command line's integration tests, one binary: each module is one behaviour (`hevo run`
//! end to end, a MAP-Elites run's archive, `hevo scenario`, the tutorial as written, the checks of bad values), and
//! `support` holds what they share. Run one module with `cargo test -p hevo-cli --test cli
//! MODULE::`.

mod map_elites_cli;
mod run_cli;
mod scenario_cli;
mod support;
mod tutorial;
mod validation;
