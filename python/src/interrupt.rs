//! Long work off the Python thread: the work runs on a thread of its own while the caller's
//! thread waits with the GIL released, waking every tenth of a second to pass on the work's
//! events (progress callbacks run on the caller's thread, with the GIL) and to check for
//! signals. Ctrl-C (or an exception in a callback) cancels the work, waits for it to stop
//! and raises; the work's own thread never needs the GIL, so this cannot deadlock.

use pyo3::prelude::*;
use std::collections::VecDeque;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::time::Duration;

/// How often the waiting thread looks for signals.
pub const SIGNAL_POLL: Duration = Duration::from_millis(100);

/// What the work hands to the waiting thread: events as they happen, then its result.
#[derive(Debug)]
pub struct Mailbox<E, T> {
    state: Mutex<(VecDeque<E>, Option<T>)>,
    changed: Condvar,
}

impl<E, T> Default for Mailbox<E, T> {
    fn default() -> Self {
        Mailbox {
            state: Mutex::new((VecDeque::new(), None)),
            changed: Condvar::new(),
        }
    }
}

impl<E, T> Mailbox<E, T> {
    fn lock(&self) -> MutexGuard<'_, (VecDeque<E>, Option<T>)> {
        // Values are pushed whole, so a poisoned lock still holds consistent state.
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Posts an event.
    pub fn post(&self, event: E) {
        self.lock().0.push_back(event);
        self.changed.notify_all();
    }

    /// Posts the work's result.
    pub fn finish(&self, result: T) {
        self.lock().1 = Some(result);
        self.changed.notify_all();
    }

    /// Waits up to `timeout` for something new; returns the events so far and the result if
    /// it is in.
    pub fn wait(&self, timeout: Duration) -> (Vec<E>, Option<T>) {
        let mut state = self.lock();
        if state.0.is_empty() && state.1.is_none() {
            state = self
                .changed
                .wait_timeout(state, timeout)
                .map(|(guard, _)| guard)
                .unwrap_or_else(|p| p.into_inner().0);
        }
        (state.0.drain(..).collect(), state.1.take())
    }
}

/// Runs `work` on its own thread, handing it the mailbox for its events; passes each event to
/// `on_event` on this thread. On Ctrl-C, or when `on_event` fails, calls `cancel`, waits for
/// the work to end and returns that error; otherwise returns the work's result.
pub fn run_interruptibly<E, T>(
    py: Python<'_>,
    work: impl FnOnce(&Mailbox<E, std::thread::Result<T>>) -> T + Send,
    cancel: impl Fn(),
    mut on_event: impl FnMut(Python<'_>, E) -> PyResult<()>,
) -> PyResult<T>
where
    E: Send,
    T: Send,
{
    let mailbox = Mailbox::<E, std::thread::Result<T>>::default();
    std::thread::scope(|scope| {
        let mailbox = &mailbox;
        scope.spawn(move || {
            // A panic is a bug, but it must not leave this thread waiting for ever.
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| work(mailbox)));
            mailbox.finish(result);
        });
        let mut failure: Option<PyErr> = None;
        loop {
            let (events, result) = py.detach(|| mailbox.wait(SIGNAL_POLL));
            if failure.is_none() {
                for event in events {
                    if let Err(error) = on_event(py, event) {
                        cancel();
                        failure = Some(error);
                        break;
                    }
                }
            }
            if let Some(result) = result {
                return match (failure, result) {
                    (Some(error), _) => Err(error),
                    (None, Ok(result)) => Ok(result),
                    (None, Err(panic)) => {
                        let what = panic
                            .downcast_ref::<&str>()
                            .map(|text| text.to_string())
                            .or_else(|| panic.downcast_ref::<String>().cloned())
                            .unwrap_or_default();
                        Err(crate::RunError::new_err(format!("internal error: {what}")))
                    }
                };
            }
            if failure.is_none()
                && let Err(error) = py.check_signals()
            {
                cancel();
                failure = Some(error);
            }
        }
    })
}
