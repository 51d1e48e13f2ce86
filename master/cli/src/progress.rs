//! How a run shows its progress: a progress bar per node on a terminal (run, generation, best
//! and mean fitness, or for MAP-Elites the archive's coverage, QD-score and best elite,
//! simulated cycles per second, the node's ETA), structured tracing lines
//! otherwise (CI, log files, a service's job log); and the line an interruption prints.

use hevo_engine::runner::{ArchiveProgress, Progress, ProgressEvent};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Instant;

/// A run's progress display, which can also say where the run stood when it was stopped.
pub trait RunProgress: Progress {
    /// Clears the display and returns the line saying where the run was interrupted and how
    /// to continue.
    fn interrupted(&self) -> String;
}

/// Chooses the terminal bar or log lines.
pub fn for_stderr() -> Box<dyn RunProgress> {
    if std::io::stderr().is_terminal() {
        Box::new(BarProgress::default())
    } else {
        Box::new(LogProgress::default())
    }
}

/// Where a node's evolution stands, as the events so far tell: the bar's position and label,
/// and what an interruption reports. Runs are numbered from 0 as everywhere else (run
/// directories `run-0`, "best run 0"); the count beside them ("1 of 5") is ordinal.
#[derive(Debug, Default, Clone, PartialEq)]
struct Position {
    node: String,
    runs: u32,
    generations: u32,
    run: u32,
    /// Generations of `run` done so far (this session's or a resumed checkpoint's).
    generations_done: u32,
}

impl Position {
    fn update(&mut self, event: &ProgressEvent) {
        match event {
            ProgressEvent::NodeStarted {
                node,
                runs,
                generations,
            } => {
                *self = Position {
                    node: node.clone(),
                    runs: *runs,
                    generations: *generations,
                    run: 0,
                    generations_done: 0,
                }
            }
            ProgressEvent::Generation {
                node,
                run,
                generation,
                generations,
                ..
            } => {
                if *node != self.node {
                    *self = Position {
                        node: node.clone(),
                        ..Position::default()
                    };
                }
                self.runs = self.runs.max(run + 1);
                self.generations = *generations;
                self.run = *run;
                self.generations_done = generation + 1;
            }
            ProgressEvent::RunFinished { run, .. } => {
                self.run = run + 1;
                self.generations_done = 0;
            }
            ProgressEvent::NodeFinished { .. } | ProgressEvent::Note { .. } => {}
        }
    }

    /// Generations of the whole node done, over all its runs.
    fn node_done(&self) -> u64 {
        u64::from(self.run) * u64::from(self.generations) + u64::from(self.generations_done)
    }

    /// Generations of the whole node.
    fn node_total(&self) -> u64 {
        u64::from(self.runs) * u64::from(self.generations)
    }

    /// `follow_wall run 2 (3 of 5)`.
    fn label(&self) -> String {
        format!(
            "{} run {} ({} of {})",
            self.node,
            self.run,
            self.run + 1,
            self.runs.max(self.run + 1)
        )
    }

    /// The line printed when the user stops the run.
    fn interrupted(&self) -> String {
        let continue_hint =
            "run the same command again to continue from the last finished generation";
        if self.node.is_empty() {
            return format!("interrupted before the first generation; {continue_hint}");
        }
        let at = if self.run >= self.runs {
            format!("after {}'s last run", self.node)
        } else if self.generations_done == 0 {
            format!("at the start of {}", self.label())
        } else {
            format!(
                "in {} after generation {} of {}",
                self.label(),
                self.generations_done,
                self.generations
            )
        };
        format!("interrupted {at}; {continue_hint}")
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
    position: Mutex<Position>,
}

impl Default for LogProgress {
    fn default() -> Self {
        LogProgress {
            clock: EventClock::new(),
            position: Mutex::new(Position::default()),
        }
    }
}

impl RunProgress for LogProgress {
    fn interrupted(&self) -> String {
        lock(&self.position).interrupted()
    }
}

impl Progress for LogProgress {
    fn event(&self, event: &ProgressEvent) {
        let (previous, now) = self.clock.lap();
        lock(&self.position).update(event);
        match event {
            ProgressEvent::Generation {
                node,
                run,
                generation,
                generations,
                best,
                mean,
                cycles,
                archive,
            } => {
                let rate = *cycles as f64 / now.duration_since(previous).as_secs_f64().max(1e-3);
                if let Some(archive) = archive {
                    tracing::info!(
                        node,
                        run,
                        generation,
                        generations,
                        coverage = format!("{:.1}%", 100.0 * archive.coverage()),
                        filled = format!("{}/{}", archive.filled, archive.cells),
                        qd_score = format!("{:.4}", archive.qd_score),
                        best_elite = format!("{:.4}", archive.best_elite),
                        best = format!("{best:.4}"),
                        cycles_per_second = format!("{rate:.0}"),
                        "generation"
                    );
                    return;
                }
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

/// A lock whose holder panicked still holds a usable position.
fn lock<T>(mutex: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(|p| p.into_inner())
}

/// An indicatif bar per node, over all its runs, so its ETA covers the node.
#[derive(Debug)]
pub struct BarProgress {
    clock: EventClock,
    draw_target: fn() -> ProgressDrawTarget,
    state: Mutex<BarState>,
}

#[derive(Debug, Default)]
struct BarState {
    position: Position,
    bar: Option<NodeBar>,
}

/// The node's bar, when its work in this process began, and the cycles and generations done
/// since (a resumed run's earlier generations took no time here, so they do not set the pace).
#[derive(Debug)]
struct NodeBar {
    bar: ProgressBar,
    started: Instant,
    cycles: u64,
    generations_here: u64,
    /// Whether the bar has been placed and moved to its real draw target.
    shown: bool,
}

impl Default for BarProgress {
    fn default() -> Self {
        BarProgress::with_target(ProgressDrawTarget::stderr)
    }
}

impl BarProgress {
    fn with_target(draw_target: fn() -> ProgressDrawTarget) -> Self {
        BarProgress {
            clock: EventClock::new(),
            draw_target,
            state: Mutex::new(BarState::default()),
        }
    }
}

/// What a generation's line says of the search: the generation's best and mean fitness, or,
/// for a grid archive (MAP-Elites), what it optimises: coverage, QD-score and the best elite.
fn fitness_message(best: f64, mean: f64, archive: Option<&ArchiveProgress>) -> String {
    match archive {
        None => format!("best {best:.3}  mean {mean:.3}"),
        Some(archive) => format!(
            "coverage {:.1}% ({}/{})  QD-score {:.3}  best elite {:.3}",
            100.0 * archive.coverage(),
            archive.filled,
            archive.cells,
            archive.qd_score,
            archive.best_elite
        ),
    }
}

/// Seconds left for `remaining` generations at the pace of `done_here` generations in
/// `elapsed` seconds.
fn eta_seconds(elapsed: f64, done_here: u64, remaining: u64) -> f64 {
    remaining as f64 * elapsed / done_here.max(1) as f64
}

impl RunProgress for BarProgress {
    fn interrupted(&self) -> String {
        let mut state = lock(&self.state);
        if let Some(node_bar) = state.bar.take() {
            node_bar.bar.finish_and_clear();
        }
        state.position.interrupted()
    }
}

impl Progress for BarProgress {
    fn event(&self, event: &ProgressEvent) {
        let (previous, _) = self.clock.lap();
        let mut state = lock(&self.state);
        state.position.update(event);
        let BarState { position, bar } = &mut *state;
        match event {
            ProgressEvent::Generation {
                best,
                mean,
                cycles,
                archive,
                ..
            } => {
                let node_bar = bar.get_or_insert_with(|| {
                    // Drawn only once placed, so a resumed run never shows 0/N first.
                    let bar = ProgressBar::with_draw_target(
                        Some(position.node_total()),
                        ProgressDrawTarget::hidden(),
                    );
                    bar.set_style(
                        ProgressStyle::with_template(
                            "{prefix:>24} [{bar:30}] {pos}/{len} gen  {msg}",
                        )
                        .unwrap_or_else(|_| ProgressStyle::default_bar())
                        .progress_chars("=> "),
                    );
                    NodeBar {
                        bar,
                        started: previous,
                        cycles: 0,
                        generations_here: 0,
                        shown: false,
                    }
                });
                node_bar.cycles += cycles;
                node_bar.generations_here += 1;
                let elapsed = node_bar.started.elapsed().as_secs_f64().max(1e-3);
                let rate = node_bar.cycles as f64 / elapsed;
                let eta = eta_seconds(
                    elapsed,
                    node_bar.generations_here,
                    position.node_total().saturating_sub(position.node_done()),
                );
                let bar = &node_bar.bar;
                bar.set_prefix(position.label());
                bar.set_length(position.node_total());
                bar.set_position(position.node_done());
                bar.set_message(format!(
                    "{}  {:.2}M cycles/s  node eta {}",
                    fitness_message(*best, *mean, archive.as_ref()),
                    rate / 1e6,
                    indicatif::HumanDuration(std::time::Duration::from_secs_f64(eta))
                ));
                if !node_bar.shown {
                    bar.set_draw_target((self.draw_target)());
                    node_bar.shown = true;
                }
            }
            ProgressEvent::RunFinished {
                node,
                run,
                solve_rate,
            } => {
                let line = format!(
                    "{node} run {run}: post-evaluation solve rate {:.1}%",
                    100.0 * solve_rate
                );
                match bar {
                    Some(node_bar) => node_bar.bar.println(line),
                    None => eprintln!("{line}"),
                }
            }
            ProgressEvent::NodeStarted {
                node,
                runs,
                generations,
            } => {
                if let Some(node_bar) = bar.take() {
                    node_bar.bar.finish_and_clear();
                }
                eprintln!("evolving {node}: {runs} runs x {generations} generations")
            }
            ProgressEvent::NodeFinished {
                node,
                best_run,
                best_solve_rate,
                mean_solve_rate,
            } => {
                if let Some(node_bar) = bar.take() {
                    node_bar.bar.finish_and_clear();
                }
                eprintln!(
                    "{node}: best run {best_run} solves {:.1}%, mean over runs {:.1}%",
                    100.0 * best_solve_rate,
                    100.0 * mean_solve_rate
                )
            }
            ProgressEvent::Note { message } => match bar {
                Some(node_bar) => node_bar.bar.println(message),
                None => eprintln!("{message}"),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn generation(run: u32, generation: u32) -> ProgressEvent {
        ProgressEvent::Generation {
            node: "follow_wall".into(),
            run,
            generation,
            generations: 100,
            best: 0.5,
            mean: 0.25,
            cycles: 1000,
            archive: None,
        }
    }

    fn started() -> ProgressEvent {
        ProgressEvent::NodeStarted {
            node: "follow_wall".into(),
            runs: 5,
            generations: 100,
        }
    }

    fn hidden_bar() -> BarProgress {
        BarProgress::with_target(ProgressDrawTarget::hidden)
    }

    fn bar_of(progress: &BarProgress) -> (u64, Option<u64>, String) {
        let state = lock(&progress.state);
        let bar = &state.bar.as_ref().expect("a bar").bar;
        (bar.position(), bar.length(), bar.prefix())
    }

    #[test]
    fn the_bar_spans_the_node_and_names_the_run_among_its_runs() {
        let progress = hidden_bar();
        progress.event(&started());
        progress.event(&generation(0, 0));
        assert_eq!(
            bar_of(&progress),
            (1, Some(500), "follow_wall run 0 (1 of 5)".into())
        );
        progress.event(&ProgressEvent::RunFinished {
            node: "follow_wall".into(),
            run: 0,
            solve_rate: 1.0,
        });
        progress.event(&generation(1, 0));
        assert_eq!(
            bar_of(&progress),
            (101, Some(500), "follow_wall run 1 (2 of 5)".into())
        );
    }

    #[test]
    fn a_resumed_run_starts_the_bar_where_it_stands() {
        let progress = hidden_bar();
        progress.event(&started());
        progress.event(&ProgressEvent::Note {
            message: "follow_wall run 2: resuming at generation 37".into(),
        });
        progress.event(&generation(2, 37));
        assert_eq!(
            bar_of(&progress),
            (238, Some(500), "follow_wall run 2 (3 of 5)".into())
        );
    }

    #[test]
    fn a_map_elites_generation_says_what_the_archive_gained() {
        assert_eq!(fitness_message(0.5, 0.25, None), "best 0.500  mean 0.250");
        let archive = ArchiveProgress {
            filled: 37,
            cells: 400,
            qd_score: 12.3456,
            best_elite: 0.875,
        };
        assert_eq!(
            fitness_message(0.5, 0.25, Some(&archive)),
            "coverage 9.2% (37/400)  QD-score 12.346  best elite 0.875"
        );
    }

    #[test]
    fn the_eta_covers_the_remaining_generations_of_every_run() {
        // 10 generations in 20 s: 2 s each; 490 left in the node.
        assert_eq!(eta_seconds(20.0, 10, 490), 980.0);
        assert_eq!(eta_seconds(20.0, 0, 490), 9800.0);
    }

    #[test]
    fn an_interruption_clears_the_bar_and_says_where_and_how_to_continue() {
        let progress = hidden_bar();
        assert_eq!(
            progress.interrupted(),
            "interrupted before the first generation; run the same command again to continue from the last finished generation"
        );
        progress.event(&started());
        progress.event(&generation(1, 36));
        let line = progress.interrupted();
        assert!(lock(&progress.state).bar.is_none());
        assert_eq!(
            line,
            "interrupted in follow_wall run 1 (2 of 5) after generation 37 of 100; run the same command again to continue from the last finished generation"
        );
        progress.event(&ProgressEvent::RunFinished {
            node: "follow_wall".into(),
            run: 1,
            solve_rate: 1.0,
        });
        assert!(
            progress
                .interrupted()
                .starts_with("interrupted at the start of follow_wall run 2 (3 of 5);")
        );
        let log = LogProgress::default();
        log.event(&started());
        log.event(&generation(4, 99));
        assert!(
            log.interrupted().starts_with(
                "interrupted in follow_wall run 4 (5 of 5) after generation 100 of 100;"
            )
        );
    }
}
