//! The client commands: `hevo submit`, `watch`, `jobs`, `fetch`, `cancel` and `delete`. Each connects to
//! a master with the shared token (and TLS when the URL is https://), makes its calls and turns
//! a refusal into one clear line (`INVALID_ARGUMENT: experiment_toml: ...`). `watch` outlives
//! master restarts: when the stream breaks it reconnects with backoff and carries on.

use anyhow::{Context, Result, anyhow, bail};
use hevo_engine::experiment::{DiskFiles, Experiment};
use hevo_engine::runner::Overrides;
use hevo_proto::client::{ClientOptions, describe_status, job_client};
use hevo_proto::v1;
use hevo_proto::v1::job_event::Event;
use hevo_service::grpc::is_final;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::path::{Component, Path};
use std::time::Duration;

fn refused(status: tonic::Status) -> anyhow::Error {
    anyhow!(describe_status(&status))
}

/// Submits an experiment file, with the files it reads from elsewhere (its fixed children);
/// returns the job id.
pub async fn submit(options: &ClientOptions, file: &Path, settings: Overrides) -> Result<String> {
    let text =
        std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let files = DiskFiles::beside(file);
    // Parsing here only gathers the files the experiment reads; the master judges the file,
    // so a broken one is refused with the service's message whichever client sent it.
    let _ = Experiment::parse_with(&text, file, &files);
    let file_name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let request = v1::SubmitJobRequest {
        experiment_toml: text,
        file_name,
        node: settings.node,
        runs: settings.runs,
        generations: settings.generations,
        seed: settings.seed,
        files: files.files_read().into_iter().collect(),
        // The same id on every attempt: a submission whose answer was lost (the master died
        // after storing it) is not stored twice when it is sent again.
        request_id: uuid::Uuid::new_v4().to_string(),
    };
    let mut delay = Duration::from_millis(500);
    for attempt in 1.. {
        let outcome = async {
            let mut client = job_client(options.connect().await?);
            Ok::<_, anyhow::Error>(client.submit_job(request.clone()).await)
        }
        .await;
        let lost = match outcome {
            Ok(Ok(response)) => return Ok(response.into_inner().job_id),
            Ok(Err(status)) if !connection_lost(&status) => return Err(refused(status)),
            Ok(Err(status)) => describe_status(&status),
            Err(error) => format!("{error:#}"),
        };
        if attempt >= SUBMIT_ATTEMPTS {
            bail!("{lost} (gave up after {attempt} attempts)");
        }
        eprintln!("submit: {lost}; retrying in {delay:?} with the same request id");
        tokio::time::sleep(delay).await;
        delay = (delay * 2).min(Duration::from_secs(8));
    }
    unreachable!("the loop returns")
}

/// How often `hevo submit` sends a submission whose connection was lost.
const SUBMIT_ATTEMPTS: u32 = 6;

/// Whether a call failed because the connection went, not because the master refused it.
fn connection_lost(status: &tonic::Status) -> bool {
    matches!(
        status.code(),
        tonic::Code::Unavailable | tonic::Code::Unknown | tonic::Code::Cancelled
    )
}

/// The wire state's lowercase name.
pub fn state_name(state: i32) -> &'static str {
    match v1::JobState::try_from(state) {
        Ok(v1::JobState::Queued) => "queued",
        Ok(v1::JobState::Running) => "running",
        Ok(v1::JobState::Succeeded) => "succeeded",
        Ok(v1::JobState::Failed) => "failed",
        Ok(v1::JobState::Cancelled) => "cancelled",
        _ => "unknown",
    }
}

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

/// Follows a job's events until it reaches a final state, calling `on_event` for each, and
/// returns that final status. When the stream breaks (the master restarts) it reconnects with
/// backoff, telling `on_note` why, and carries on; a refusal (unknown job, bad token) is an
/// error. `hevo watch` and the Python module's `Client.watch` both follow jobs through it.
pub async fn follow_job(
    options: &ClientOptions,
    job: &str,
    mut on_event: impl FnMut(&v1::JobEvent),
    mut on_note: impl FnMut(&str),
) -> Result<v1::JobInfo> {
    let channel = options.lazy_channel()?;
    let mut client = job_client(channel);
    let mut delay = Duration::from_millis(200);
    loop {
        let outcome = async {
            let mut stream = client
                .watch_job(v1::WatchJobRequest {
                    job_id: job.to_string(),
                })
                .await?
                .into_inner();
            while let Some(event) = stream.message().await? {
                on_event(&event);
                if let Some(Event::Status(info)) = &event.event
                    && is_final(info.state)
                {
                    return Ok(Some(info.as_ref().clone()));
                }
            }
            Ok::<_, tonic::Status>(None)
        }
        .await;
        match outcome {
            Ok(Some(info)) => return Ok(info),
            // The stream ended without a final state: the master is restarting.
            Ok(None) => on_note("the master closed the stream; reconnecting"),
            Err(status)
                if matches!(
                    status.code(),
                    tonic::Code::Unavailable
                        | tonic::Code::Unknown
                        | tonic::Code::Cancelled
                        | tonic::Code::Internal
                ) =>
            {
                on_note(&format!(
                    "lost the master ({}); reconnecting",
                    describe_status(&status)
                ));
            }
            Err(status) => return Err(refused(status)),
        }
        tokio::time::sleep(delay).await;
        delay = (delay * 2).min(Duration::from_secs(5));
    }
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

/// The master's jobs.
pub async fn list_jobs(options: &ClientOptions) -> Result<Vec<v1::JobInfo>> {
    let mut client = job_client(options.connect().await?);
    Ok(client
        .list_jobs(v1::ListJobsRequest {})
        .await
        .map_err(refused)?
        .into_inner()
        .jobs)
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

/// Writes a job's result files under `out` (the layout `hevo run --out` writes); returns the
/// job's status and the number of files.
pub async fn fetch(options: &ClientOptions, job: &str, out: &Path) -> Result<(v1::JobInfo, usize)> {
    let mut client = job_client(options.connect().await?);
    let response = client
        .get_job(v1::GetJobRequest {
            job_id: job.to_string(),
            include_files: true,
        })
        .await
        .map_err(refused)?
        .into_inner();
    let info = response
        .job
        .ok_or_else(|| anyhow!("the master sent no job status"))?;
    for file in &response.files {
        // Paths come from the network: only plain relative paths below `out` are written.
        let relative = Path::new(&file.path);
        if file.path.is_empty()
            || !relative
                .components()
                .all(|c| matches!(c, Component::Normal(_)))
        {
            bail!("the master sent an unsafe path '{}'", file.path);
        }
        let path = out.join(relative);
        hevo_engine::store::write_atomic(&path, &file.content)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok((info, response.files.len()))
}

/// Cancels a job; returns its status.
pub async fn cancel(options: &ClientOptions, job: &str) -> Result<v1::JobInfo> {
    let mut client = job_client(options.connect().await?);
    let response = client
        .cancel_job(v1::CancelJobRequest {
            job_id: job.to_string(),
        })
        .await
        .map_err(refused)?
        .into_inner();
    response
        .job
        .ok_or_else(|| anyhow!("the master sent no job status"))
}

/// Deletes a finished job.
pub async fn delete(options: &ClientOptions, job: &str) -> Result<()> {
    let mut client = job_client(options.connect().await?);
    client
        .delete_job(v1::DeleteJobRequest {
            job_id: job.to_string(),
        })
        .await
        .map_err(refused)?;
    Ok(())
}

/// `YYYY-MM-DD HH:MM:SS` in UTC (days to civil date after H. Hinnant's algorithm).
pub fn format_utc(unix_ms: i64) -> String {
    let seconds = unix_ms.div_euclid(1000);
    let (days, rest) = (seconds.div_euclid(86_400), seconds.rem_euclid(86_400));
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02}",
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn utc_dates() {
        assert_eq!(format_utc(0), "1970-01-01 00:00:00");
        assert_eq!(
            format_utc(951_782_400_000 + 3_661_000),
            "2000-02-29 01:01:01"
        );
        assert_eq!(format_utc(1_763_856_000_000), "2025-11-23 00:00:00");
    }
}
