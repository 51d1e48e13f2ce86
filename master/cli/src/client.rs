//! The client commands' output: `hevo watch` shows a job's events as a progress bar on a
//! terminal and as lines elsewhere, and `hevo jobs` prints the master's jobs as a table. The
//! calls themselves are hevo-client's.

use anyhow::Result;
use hevo_client::{follow_job, format_utc, list_jobs, state_name};
use hevo_proto::client::ClientOptions;
use hevo_proto::is_final;
use hevo_proto::v1;
use hevo_proto::v1::job_event::Event;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{IsTerminal, Write};

/// Shows a job's progress until it ends: a bar on a terminal, one line per event otherwise.
/// Returns the final status.
pub async fn watch(options: &ClientOptions, job: &str) -> Result<v1::JobInfo> {
    let view = std::sync::Mutex::new(View::new(job));
    let view_of = || view.lock().unwrap_or_else(|p| p.into_inner());
    let result = follow_job(
        options,
        job,
        |event| {
            view_of().show(event);
        },
        |note| view_of().note(note),
    )
    .await;
    view_of().finish();
    result
}

/// How `watch` shows events.
struct View {
    job: String,
    bar: Option<ProgressBar>,
}

impl View {
    fn new(job: &str) -> View {
        let bar = std::io::stdout().is_terminal().then(|| {
            let bar = ProgressBar::new(0);
            bar.set_style(
                ProgressStyle::with_template(
                    "{prefix} [{bar:30}] {pos}/{len} gen  {msg}  eta {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            bar.set_prefix(job.to_string());
            bar
        });
        View {
            job: job.to_string(),
            bar,
        }
    }

    fn line(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None => {
                let mut stdout = std::io::stdout().lock();
                let _ = writeln!(stdout, "{text}");
                let _ = stdout.flush();
            }
        }
    }

    fn note(&self, text: &str) {
        self.line(&format!("{}: {text}", self.job));
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }

    /// Shows one event; returns the status when it is final.
    fn show(&mut self, event: &v1::JobEvent) -> Option<v1::JobInfo> {
        let job = &self.job;
        match event.event.as_ref()? {
            Event::Status(info) => {
                if let Some(bar) = &self.bar {
                    bar.set_length(info.generations_total);
                    bar.set_position(info.generations_done);
                }
                let mut text = format!(
                    "{job}: {} ({}/{} generations)",
                    state_name(info.state),
                    info.generations_done,
                    info.generations_total
                );
                if !info.error.is_empty() {
                    text.push_str(&format!(": {}", info.error));
                }
                self.line(&text);
                if is_final(info.state) {
                    return Some(info.as_ref().clone());
                }
            }
            Event::Generation(g) => {
                let text = format!(
                    "{} run {} generation {}/{}: best {:.4} mean {:.4}",
                    g.node,
                    g.run,
                    g.generation + 1,
                    g.generations,
                    g.best,
                    g.mean
                );
                match &self.bar {
                    Some(bar) => {
                        bar.set_length(g.job_generations_total);
                        bar.set_position(g.job_generations_done);
                        bar.set_message(text);
                    }
                    None => self.line(&format!(
                        "{job} {text} ({}/{})",
                        g.job_generations_done, g.job_generations_total
                    )),
                }
            }
            Event::NodeStarted(n) => self.line(&format!(
                "{job} {}: {} runs x {} generations",
                n.node, n.runs, n.generations
            )),
            Event::RunFinished(r) => self.line(&format!(
                "{job} {} run {}: post-evaluation solve rate {:.1}%",
                r.node,
                r.run,
                100.0 * r.solve_rate
            )),
            Event::NodeFinished(n) => self.line(&format!(
                "{job} {}: best run {} solves {:.1}%, mean over runs {:.1}%",
                n.node,
                n.best_run,
                100.0 * n.best_solve_rate,
                100.0 * n.mean_solve_rate
            )),
            Event::Note(message) => self.line(&format!("{job}: {message}")),
        }
        None
    }
}

/// The jobs as a table.
pub async fn jobs(options: &ClientOptions) -> Result<String> {
    let jobs = list_jobs(options).await?;
    let mut text = format!(
        "{:<12} {:<10} {:>15}  {:<20} {:<20} {}\n",
        "JOB", "STATE", "GENERATIONS", "EXPERIMENT", "SUBMITTED (UTC)", "FILE"
    );
    for job in jobs {
        text.push_str(&format!(
            "{:<12} {:<10} {:>15}  {:<20} {:<20} {}\n",
            job.job_id,
            state_name(job.state),
            format!("{}/{}", job.generations_done, job.generations_total),
            job.experiment_name,
            format_utc(job.created_unix_ms),
            job.file_name
        ));
        if !job.error.is_empty() {
            text.push_str(&format!("{:<12} error: {}\n", "", job.error));
        }
    }
    Ok(text)
}
