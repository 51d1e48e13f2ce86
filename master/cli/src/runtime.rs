//! The async runtime the commands run on, built in one place, and the in-process workers of
//! local mode (`run`, `eval`).

use anyhow::{Context, Result};
use hevo_engine::dispatch::Dispatcher;

/// A multi-threaded runtime with I/O and timers, for a command's async work.
pub fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
}

/// Runs `work` on a new runtime against a dispatcher served by `threads` in-process workers
/// (local mode), and stops the workers once it is done.
pub fn with_local_workers<T, E>(
    threads: usize,
    work: impl AsyncFnOnce(&Dispatcher) -> Result<T, E>,
) -> Result<T>
where
    E: std::error::Error + Send + Sync + 'static,
{
    let dispatcher = hevo_engine::local::local_dispatcher(threads);
    Ok(hevo_engine::local::run_local(dispatcher, threads, work)
        .context("cannot start the async runtime")??)
}

/// Threads to use: the flag, else every core.
pub fn default_threads(flag: Option<usize>) -> usize {
    flag.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}
