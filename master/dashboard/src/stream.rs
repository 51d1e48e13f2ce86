//! A job's Server-Sent Events stream: the page's script listens to it and redraws what
//! changed. One task per open stream waits on the source's change counter (never on a timer),
//! reads the job, and sends only what differs from what it sent before: `job` (state and
//! progress), `run` (a run's generation count and latest fitness, after which the page fetches
//! the node's plot again) and `node` (a node finished; the page reloads to show its table and
//! replays). Updates are coalesced to at most one read per [`MIN_INTERVAL`]. When the client
//! goes away the task notices at once (the channel to the response closes) and ends; a
//! keep-alive comment every 15 s makes a silent dead connection show too.

use crate::pages::run_progress_text;
use crate::{JobOverview, NodeView, Source, SourceError};
use axum::response::sse::{Event, KeepAlive, Sse};
use std::collections::{BTreeMap, BTreeSet};
use std::convert::Infallible;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;
use tokio::sync::{mpsc, watch};
use tokio_stream::wrappers::ReceiverStream;

/// The shortest time between two reads of a job for one stream.
pub const MIN_INTERVAL: Duration = Duration::from_millis(250);

/// Counts the streams open now: each stream's task counts itself while it runs.
#[derive(Debug, Default)]
pub struct OpenStreams(AtomicUsize);

impl OpenStreams {
    /// Streams open now.
    pub fn count(&self) -> usize {
        self.0.load(Ordering::SeqCst)
    }
}

/// A stream's place among the open ones, held while it runs.
#[derive(Debug)]
pub struct StreamGuard(Arc<OpenStreams>);

impl StreamGuard {
    /// Takes a place, unless `max` streams are open already.
    pub fn try_new(open: Arc<OpenStreams>, max: usize) -> Option<StreamGuard> {
        open.0
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |count| {
                (count < max).then_some(count + 1)
            })
            .ok()?;
        Some(StreamGuard(open))
    }
}

impl Drop for StreamGuard {
    fn drop(&mut self) {
        self.0.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// What the stream has told its client.
#[derive(Debug, Default)]
struct Sent {
    job: Option<String>,
    runs: BTreeMap<(String, u32), String>,
    finished_nodes: BTreeSet<String>,
}

/// The events that bring a client from `sent` to this snapshot, and `sent` updated.
fn events_for(sent: &mut Sent, job: &JobOverview, nodes: &[NodeView]) -> Vec<Event> {
    let mut events = Vec::new();
    let job_data = serde_json::json!({
        "state": job.state,
        "finished": job.finished,
        "done": job.generations_done,
        "total": job.generations_total,
    })
    .to_string();
    if sent.job.as_deref() != Some(job_data.as_str()) {
        events.push(Event::default().event("job").data(&job_data));
        sent.job = Some(job_data);
    }
    for node in nodes {
        for run in &node.runs {
            let text = run_progress_text(node, run);
            let key = (node.name.clone(), run.run);
            if sent.runs.get(&key) != Some(&text) {
                let data = serde_json::json!({
                    "node": node.name,
                    "run": run.run,
                    "generations": run.rows.len(),
                    "text": text,
                });
                events.push(Event::default().event("run").data(data.to_string()));
                sent.runs.insert(key, text);
            }
        }
        if node.finished() && sent.finished_nodes.insert(node.name.clone()) {
            let data = serde_json::json!({ "node": node.name, "finished": true });
            events.push(Event::default().event("node").data(data.to_string()));
        }
    }
    events
}

/// The stream of job `id`, holding its place `guard` while it runs. The caller has checked
/// that the job exists.
pub fn job_events(
    source: Arc<dyn Source>,
    id: String,
    mut stopping: watch::Receiver<bool>,
    guard: StreamGuard,
) -> axum::response::Response {
    let (sender, receiver) = mpsc::channel::<Result<Event, Infallible>>(64);
    let mut changes = source.changes();
    tokio::spawn(async move {
        let _guard = guard;
        let mut sent = Sent::default();
        loop {
            changes.borrow_and_update();
            let read = {
                let source = source.clone();
                let id = id.clone();
                tokio::task::spawn_blocking(move || -> Result<_, SourceError> {
                    Ok((source.job(&id)?, source.nodes(&id)?))
                })
                .await
            };
            let Ok(Ok((job, nodes))) = read else {
                // The job went away or reading failed: the client reconnects and sees why.
                return;
            };
            for event in events_for(&mut sent, &job, &nodes) {
                if sender.send(Ok(event)).await.is_err() {
                    return;
                }
            }
            tokio::select! {
                changed = changes.changed() => if changed.is_err() { return },
                _ = sender.closed() => return,
                _ = stopping.wait_for(|&s| s) => return,
            }
            tokio::select! {
                _ = tokio::time::sleep(MIN_INTERVAL) => {},
                _ = sender.closed() => return,
            }
        }
    });
    axum::response::IntoResponse::into_response(
        Sse::new(ReceiverStream::new(receiver)).keep_alive(KeepAlive::default()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::RunView;
    use hevo_rundir::FitnessRow;

    fn job(done: u64) -> JobOverview {
        JobOverview {
            id: "j".into(),
            name: "j".into(),
            state: "running".into(),
            finished: false,
            generations_done: done,
            generations_total: Some(4),
            created_unix_ms: None,
            finished_unix_ms: None,
            error: None,
            nodes: vec!["n".into()],
            cancellable: true,
            location: String::new(),
        }
    }

    fn node(generations: u32) -> NodeView {
        NodeView {
            name: "n".into(),
            runs: vec![RunView {
                archive: None,
                qd: Vec::new(),
                run: 0,
                rows: (0..generations)
                    .map(|generation| FitnessRow {
                        generation,
                        best: 1.0,
                        mean: 0.5,
                        min: 0.0,
                        max: 1.0,
                        std: 0.0,
                    })
                    .collect(),
                summary: None,
            }],
            summary: None,
            planned: Some((1, 4)),
        }
    }

    #[test]
    fn only_what_changed_is_sent_again() {
        let mut sent = Sent::default();
        assert_eq!(events_for(&mut sent, &job(1), &[node(1)]).len(), 2);
        assert_eq!(events_for(&mut sent, &job(1), &[node(1)]).len(), 0);
        assert_eq!(events_for(&mut sent, &job(2), &[node(2)]).len(), 2);
    }
}
