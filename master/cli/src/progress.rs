//! How a run shows its progress: a progress bar per run on a terminal (generation, best and
//! mean fitness, simulated cycles per second, ETA), structured tracing lines otherwise (CI, log
//! files, a service's job log).

use hevo_engine::runner::{Progress, ProgressEvent};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

/// Chooses the terminal bar or log lines.
pub fn for_stderr() -> Box<dyn Progress> {
    if std::io::stderr().is_terminal() {
        Box::new(BarProgress::default())
    } else {
        Box::new(LogProgress::default())
    }
}

/// When the work behind a generation event began: at the previous event, whatever it was (the
/// node starting, a run resuming or finishing, the previous generation), since the runner
/// sends one as soon as it turns to the next piece of work. Timing from the first generation
/// event instead would divide its cycles by almost no time.
#[derive(Debug)]
struct EventClock(Mutex<Instant>);

impl EventClock {
    fn new() -> Self {
        EventClock(Mutex::new(Instant::now()))
    }

    /// The previous event's instant; now becomes it.
    fn lap(&self) -> (Instant, Instant) {
        let now = Instant::now();
        let mut last = self.0.lock().unwrap_or_else(|p| p.into_inner());
        let previous = std::mem::replace(&mut *last, now);
        (previous, now)
    }
}

/// Log lines through `tracing`.
#[derive(Debug)]
pub struct LogProgress {
    clock: EventClock,
}

impl Default for LogProgress {
    fn default() -> Self {
        LogProgress {
            clock: EventClock::new(),
        }
    }
}

impl Progress for LogProgress {
    fn event(&self, event: &ProgressEvent) {
        let (previous, now) = self.clock.lap();
        match event {
            ProgressEvent::Generation {
                node,
                run,
                generation,
                generations,
                best,
                mean,
                cycles,
            } => {
                let rate = *cycles as f64 / now.duration_since(previous).as_secs_f64().max(1e-3);
                tracing::info!(
                    node,
                    run,
                    generation,
                    generations,
                    best = format!("{best:.4}"),
                    mean = format!("{mean:.4}"),
                    cycles_per_second = format!("{rate:.0}"),
                    "generation"
                );
            }
            ProgressEvent::NodeStarted {
                node,
                runs,
                generations,
            } => tracing::info!(node, runs, generations, "node started"),
            ProgressEvent::RunFinished {
                node,
                run,
                solve_rate,
            } => {
                tracing::info!(
                    node,
                    run,
                    solve_rate = format!("{:.1}%", 100.0 * solve_rate),
                    "run finished"
                )
            }
            ProgressEvent::NodeFinished {
                node,
                best_run,
                best_solve_rate,
                mean_solve_rate,
            } => tracing::info!(
                node,
                best_run,
                best = format!("{:.1}%", 100.0 * best_solve_rate),
                avg = format!("{:.1}%", 100.0 * mean_solve_rate),
                "node finished"
            ),
            ProgressEvent::Note { message } => tracing::info!("{message}"),
        }
    }
}

/// An indicatif bar per run.
#[derive(Debug)]
pub struct BarProgress {
    clock: EventClock,
    /// The run's bar, when its work began, the cycles it has done since, and the generation
    /// it began at.
    state: Mutex<Option<(ProgressBar, Instant, u64, u32)>>,
}

impl Default for BarProgress {
    fn default() -> Self {
        BarProgress {
            clock: EventClock::new(),
            state: Mutex::new(None),
        }
    }
}

impl Progress for BarProgress {
    fn event(&self, event: &ProgressEvent) {
        let (previous, _) = self.clock.lap();
        let mut state = self.state.lock().unwrap_or_else(|p| p.into_inner());
        match event {
            ProgressEvent::Generation {
                node,
                run,
                generation,
                generations,
                best,
                mean,
                cycles,
            } => {
                let (bar, started, total_cycles, first_generation) =
                    state.get_or_insert_with(|| {
                        let bar = ProgressBar::new(u64::from(*generations));
                        bar.set_style(
                            ProgressStyle::with_template(
                                "{prefix:>16} [{bar:30}] {pos}/{len} gen  {msg}",
                            )
                            .unwrap_or_else(|_| ProgressStyle::default_bar())
                            .progress_chars("=> "),
                        );
                        (bar, previous, 0, *generation)
                    });
                *total_cycles += cycles;
                let elapsed = started.elapsed().as_secs_f64().max(1e-3);
                let rate = *total_cycles as f64 / elapsed;
                // This session's pace: a resumed run's earlier generations took no time here.
                let done_here = f64::from(generation + 1 - *first_generation);
                let eta =
                    f64::from(generations.saturating_sub(generation + 1)) * elapsed / done_here;
                bar.set_prefix(format!("{node} run {run}"));
                bar.set_length(u64::from(*generations));
                bar.set_position(u64::from(generation + 1));
                bar.set_message(format!(
                    "best {best:.3}  mean {mean:.3}  {:.2}M cycles/s  eta {}",
                    rate / 1e6,
                    indicatif::HumanDuration(std::time::Duration::from_secs_f64(eta))
                ));
            }
            ProgressEvent::RunFinished {
                node,
                run,
                solve_rate,
            } => {
                if let Some((bar, ..)) = state.take() {
                    bar.finish_and_clear();
                }
                eprintln!(
                    "{node} run {run}: post-evaluation solve rate {:.1}%",
                    100.0 * solve_rate
                );
            }
            ProgressEvent::NodeStarted {
                node,
                runs,
                generations,
            } => {
                eprintln!("evolving {node}: {runs} runs x {generations} generations")
            }
            ProgressEvent::NodeFinished {
                node,
                best_run,
                best_solve_rate,
                mean_solve_rate,
            } => eprintln!(
                "{node}: best run {best_run} solves {:.1}%, mean over runs {:.1}%",
                100.0 * best_solve_rate,
                100.0 * mean_solve_rate
            ),
            ProgressEvent::Note { message } => {
                if let Some((bar, ..)) = state.as_ref() {
                    bar.println(message);
                } else {
                    eprintln!("{message}");
                }
            }
        }
    }
}
