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

/// Log lines through `tracing`.
#[derive(Debug, Default)]
pub struct LogProgress {
    last: Mutex<Option<Instant>>,
}

impl Progress for LogProgress {
    fn event(&self, event: &ProgressEvent) {
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
                let now = Instant::now();
                let mut last = self.last.lock().unwrap_or_else(|p| p.into_inner());
                let rate = last
                    .map(|t| *cycles as f64 / now.duration_since(t).as_secs_f64().max(1e-9))
                    .unwrap_or(0.0);
                *last = Some(now);
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
#[derive(Debug, Default)]
pub struct BarProgress {
    state: Mutex<Option<(ProgressBar, Instant, u64)>>,
}

impl Progress for BarProgress {
    fn event(&self, event: &ProgressEvent) {
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
                let (bar, started, total_cycles) = state.get_or_insert_with(|| {
                    let bar = ProgressBar::new(u64::from(*generations));
                    bar.set_style(
                        ProgressStyle::with_template(
                            "{prefix:>16} [{bar:30}] {pos}/{len} gen  {msg}  eta {eta}",
                        )
                        .unwrap_or_else(|_| ProgressStyle::default_bar())
                        .progress_chars("=> "),
                    );
                    (bar, Instant::now(), 0)
                });
                *total_cycles += cycles;
                let rate = *total_cycles as f64 / started.elapsed().as_secs_f64().max(1e-9);
                bar.set_prefix(format!("{node} run {run}"));
                bar.set_length(u64::from(*generations));
                bar.set_position(u64::from(generation + 1));
                bar.set_message(format!(
                    "best {best:.3}  mean {mean:.3}  {:.2}M cycles/s",
                    rate / 1e6
                ));
            }
            ProgressEvent::RunFinished {
                node,
                run,
                solve_rate,
            } => {
                if let Some((bar, _, _)) = state.take() {
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
                if let Some((bar, _, _)) = state.as_ref() {
                    bar.println(message);
                } else {
                    eprintln!("{message}");
                }
            }
        }
    }
}
