//! The master's own types on the wire: job records and progress events to `hevo.v1` messages,
//! and leased batches to `Batch` messages. sim-core values inside go through
//! `hevo_proto::convert`, the one conversion module master and worker share.

use crate::db::{JobRecord, JobState};
use hevo_engine::dispatch::Batch;
use hevo_engine::runner::ProgressEvent;
use hevo_proto::convert as wire;
use hevo_proto::v1;

/// A job state on the wire.
pub fn state_to_proto(state: JobState) -> v1::JobState {
    match state {
        JobState::Queued => v1::JobState::Queued,
        JobState::Running => v1::JobState::Running,
        JobState::Succeeded => v1::JobState::Succeeded,
        JobState::Failed => v1::JobState::Failed,
        JobState::Cancelled => v1::JobState::Cancelled,
    }
}

/// A job's status on the wire (its last event included).
pub fn job_info(record: &JobRecord) -> v1::JobInfo {
    v1::JobInfo {
        job_id: record.id.clone(),
        experiment_name: record.experiment_name.clone(),
        file_name: record.file_name.clone(),
        settings: Some(v1::JobSettings {
            node: record.settings.node.clone(),
            runs: record.settings.runs,
            generations: record.settings.generations,
            seed: record.settings.seed,
        }),
        state: state_to_proto(record.state) as i32,
        error: record.error.clone().unwrap_or_default(),
        created_unix_ms: record.created_unix_ms,
        finished_unix_ms: record.finished_unix_ms.unwrap_or_default(),
        generations_done: record.generations_done,
        generations_total: record.generations_total(),
        last_event: record.last_event.as_ref().map(|event| {
            Box::new(event_to_proto(
                &record.id,
                event,
                record.generations_done,
                record.generations_total(),
            ))
        }),
    }
}

/// A status event.
pub fn status_event(record: &JobRecord) -> v1::JobEvent {
    v1::JobEvent {
        job_id: record.id.clone(),
        event: Some(v1::job_event::Event::Status(Box::new(job_info(record)))),
    }
}

/// A progress event on the wire; `done`/`total` are the job's generation counts after it.
pub fn event_to_proto(job: &str, event: &ProgressEvent, done: u64, total: u64) -> v1::JobEvent {
    use v1::job_event::Event;
    let event = match event {
        ProgressEvent::NodeStarted {
            node,
            runs,
            generations,
        } => Event::NodeStarted(v1::NodeStarted {
            node: node.clone(),
            runs: *runs,
            generations: *generations,
        }),
        ProgressEvent::Generation {
            node,
            run,
            generation,
            generations,
            best,
            mean,
            cycles,
            ..
        } => Event::Generation(v1::GenerationDone {
            node: node.clone(),
            run: *run,
            generation: *generation,
            generations: *generations,
            best: *best,
            mean: *mean,
            cycles: *cycles,
            job_generations_done: done,
            job_generations_total: total,
        }),
        ProgressEvent::RunFinished {
            node,
            run,
            solve_rate,
        } => Event::RunFinished(v1::RunFinished {
            node: node.clone(),
            run: *run,
            solve_rate: *solve_rate,
        }),
        ProgressEvent::NodeFinished {
            node,
            best_run,
            best_solve_rate,
            mean_solve_rate,
        } => Event::NodeFinished(v1::NodeFinished {
            node: node.clone(),
            best_run: *best_run,
            best_solve_rate: *best_solve_rate,
            mean_solve_rate: *mean_solve_rate,
        }),
        ProgressEvent::Note { message } => Event::Note(message.clone()),
    };
    v1::JobEvent {
        job_id: job.to_string(),
        event: Some(event),
    }
}

/// A leased batch on the wire. The template and task text are left out when the worker said
/// it has them cached.
pub fn batch_to_proto(batch: &Batch, epoch: u64, lease_ms: u32, cached: &[String]) -> v1::Batch {
    let shared = &batch.shared;
    let key = wire::cache_key(&shared.template_hash, &shared.task_hash);
    let send_texts = !cached.contains(&key);
    v1::Batch {
        epoch,
        batch_id: batch.batch_id,
        lease_id: batch.lease_id,
        job_id: batch.job.clone(),
        template_hash: shared.template_hash.clone(),
        task_hash: shared.task_hash.clone(),
        template_json: if send_texts {
            wire::template_to_json(&shared.template)
        } else {
            String::new()
        },
        task_json: if send_texts {
            wire::task_to_json(&shared.task)
        } else {
            String::new()
        },
        genomes: batch
            .genomes
            .iter()
            .map(|(index, genes)| v1::Genome {
                index: *index,
                genes: genes.to_vec(),
            })
            .collect(),
        samples: batch.samples.iter().map(wire::sample_to_proto).collect(),
        lease_ms,
    }
}
