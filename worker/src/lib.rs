//! hevo's remote worker. [`remote`] is the worker loop: it connects out to a master, leases
//! batches with a long poll, evaluates them on the engine's executor (the code local mode
//! runs, so both compute exactly the same numbers) while it heartbeats, returns the results,
//! reconnects with backoff when the master goes away, and on SIGTERM finishes or hands back its
//! batch. A worker keeps no state between batches but its evaluator cache. [`cli`] holds the
//! `hevo-worker` command's flags.

pub mod cli;
pub mod remote;
