//! hevo's evaluation engine and its remote worker. [`exec`] evaluates batches of genomes with
//! sim-core, over one or several threads, with evaluators cached by content hash; local mode's
//! in-process workers (`hevo run`) and the remote `hevo-worker` both use it, so they compute
//! exactly the same numbers. [`remote`] is the worker loop: it connects out to a master, leases
//! batches with a long poll, heartbeats while it evaluates, returns the results, reconnects with
//! backoff when the master goes away, and on SIGTERM finishes or hands back its batch. A worker
//! keeps no state between batches but its evaluator cache.

pub mod cli;
pub mod exec;
pub mod remote;
