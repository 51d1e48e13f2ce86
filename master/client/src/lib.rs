//! The client side of hevo's service: submit an experiment with the files it reads, follow a
//! job's events (outliving master restarts: when the stream breaks it reconnects with backoff
//! and carries on), list, fetch, cancel and delete jobs, and evaluate genomes on the master's
//! workers. Each call connects to a master with the shared
//! token (and TLS when the URL is https://) and turns a refusal into one clear error
//! (`INVALID_ARGUMENT: experiment_toml: ...`). It prints nothing and parses no command line: the
//! `hevo` command (`hevo submit`, `watch`, `jobs`, `fetch`, `cancel`) and the Python module's
//! `Client` both call it, so they cannot disagree.

use anyhow::{Context, Result, anyhow, bail};
use hevo_engine::experiment::{DiskFiles, Experiment};
use hevo_engine::runner::Overrides;
use hevo_proto::client::{ClientOptions, describe_status, job_client};
use hevo_proto::is_final;
use hevo_proto::v1;
use hevo_proto::v1::job_event::Event;
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

/// Follows a job's events until it reaches a final state, calling `on_event` for each, and
/// returns that final status. When the stream breaks (the master restarts) it reconnects with
/// backoff, telling `on_note` why, and carries on; a refusal (unknown job, bad token) is an
/// error.
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

/// Deletes a finished job: its record, files and memory on the master.
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

/// What [`evaluate_genomes`] hands its caller, in order.
#[derive(Debug)]
pub enum EvaluationEvent {
    /// An attempt started on the master with this id: results from an earlier attempt (cut
    /// off by a lost connection or a worker a spot check caught) are to be forgotten, and
    /// they come again from genome 0.
    Started(String),
    /// The outcomes of genomes `first_genome..first_genome + results.len()`, one per sample
    /// in sample order.
    Results {
        /// The index of the first genome.
        first_genome: usize,
        /// `[genome][sample]`.
        results: Vec<Vec<hevo_sim_core::SampleSummary>>,
    },
}

/// Attempts of one remote evaluation, when connections are lost or a spot check ends it.
const EVALUATE_ATTEMPTS: u32 = 6;

/// Evaluates `genomes` (genes of `template`'s free node) on the master's workers, on the
/// samples of `hevo eval --samples SAMPLES --seed SEED` for `task`: the `EvaluateGenomes`
/// call. `on_event` gets each attempt's start and its results, in genome order. A lost
/// connection or an evaluation ended by a spot check is evaluated again from the start, up to
/// a few times (evaluation is deterministic, so the results are the same); a refusal is an
/// error naming what the master refused.
pub async fn evaluate_genomes(
    options: &ClientOptions,
    template: &hevo_sim_core::ControllerFile,
    task: &hevo_sim_core::TaskConfig,
    genomes: &[std::sync::Arc<[f32]>],
    samples: u32,
    seed: u64,
    mut on_event: impl FnMut(EvaluationEvent),
) -> Result<()> {
    let request = v1::EvaluateGenomesRequest {
        template_json: hevo_proto::convert::template_to_json(template),
        template_hash: template.content_hash(),
        task_json: hevo_proto::convert::task_to_json(task),
        task_hash: hevo_sim_core::task_content_hash(task),
        genomes: u32::try_from(genomes.len()).context("too many genomes for one call")?,
        genes: genomes
            .iter()
            .flat_map(|genes| genes.iter().copied())
            .collect(),
        samples,
        seed,
    };
    let n_samples =
        hevo_engine::post_evaluation::post_evaluation_samples(task, samples, seed).len();
    let mut delay = Duration::from_millis(500);
    for attempt in 1.. {
        let outcome = async {
            let mut client = job_client(
                options
                    .connect()
                    .await
                    .map_err(|error| Retry::Connect(error.into()))?,
            );
            let mut stream = client
                .evaluate_genomes(request.clone())
                .await
                .map_err(Retry::Status)?
                .into_inner();
            let mut next_genome = 0;
            while let Some(message) = stream.message().await.map_err(Retry::Status)? {
                if next_genome == 0 && message.results.is_empty() {
                    on_event(EvaluationEvent::Started(message.evaluation_id));
                    continue;
                }
                let results = hevo_proto::convert::results_from_proto(&message.results)
                    .map_err(|e| Retry::Fatal(anyhow!("the master sent a bad result: {e}")))?;
                let first_genome = message.first_genome as usize;
                if first_genome != next_genome
                    || next_genome + results.len() > genomes.len()
                    || results.iter().any(|genome| genome.len() != n_samples)
                {
                    return Err(Retry::Fatal(anyhow!(
                        "the master sent results for genomes {first_genome}.. of another shape than asked (expected genome {next_genome}, {n_samples} samples each)"
                    )));
                }
                next_genome += results.len();
                on_event(EvaluationEvent::Results {
                    first_genome,
                    results,
                });
            }
            if next_genome != genomes.len() {
                return Err(Retry::Status(tonic::Status::unavailable(format!(
                    "the stream ended after {next_genome} of {} genomes",
                    genomes.len()
                ))));
            }
            Ok(())
        }
        .await;
        let again = match outcome {
            Ok(()) => return Ok(()),
            Err(Retry::Fatal(error)) => return Err(error),
            // Not CANCELLED: that is a cancel (`hevo cancel` of the evaluation's id), final.
            Err(Retry::Status(status))
                if matches!(
                    status.code(),
                    tonic::Code::Unavailable | tonic::Code::Unknown | tonic::Code::Aborted
                ) =>
            {
                describe_status(&status)
            }
            Err(Retry::Status(status)) => return Err(refused(status)),
            Err(Retry::Connect(error)) => format!("{error:#}"),
        };
        if attempt >= EVALUATE_ATTEMPTS {
            bail!("{again} (gave up after {attempt} attempts)");
        }
        tokio::time::sleep(delay).await;
        delay = (delay * 2).min(Duration::from_secs(8));
    }
    unreachable!("the loop returns")
}

/// How an attempt of [`evaluate_genomes`] failed.
enum Retry {
    Connect(anyhow::Error),
    Status(tonic::Status),
    Fatal(anyhow::Error),
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
