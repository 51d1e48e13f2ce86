//! The engine's integration tests, one binary: each module is one behaviour (the experiment
//! parser under fuzzing, the science pinned to the paper, the shipped controllers' counts), and
//! `support` holds what they share. Run one module with `cargo test -p hevo-engine --test
//! engine MODULE::`.

mod fuzz_experiment;
mod science;
mod shipped_controllers;
mod support;
