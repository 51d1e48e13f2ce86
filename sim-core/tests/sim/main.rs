//! The simulator's integration tests, one binary: each module is one behaviour (the fitness
//! functions, the golden trajectories, the scenario files, the lockstep evaluator, ...), and
//! `support` holds what they share. Run one module with `cargo test -p hevo-sim-core --test
//! sim MODULE::`.

mod bodies;
mod fitness;
mod floors;
mod fuzz_controller;
mod golden;
mod group_files;
mod lockstep;
mod objects;
mod scenario_files;
mod schedules;
mod scripted;
mod stepping;
mod support;
mod team;
mod wanderer;
mod world_properties;
