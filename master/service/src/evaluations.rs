//! Remote evaluation (`EvaluateGenomes`): a batch of genomes for a template and a task,
//! evaluated on the connected workers and streamed back; what `hevo.Client.evaluate` calls. It
//! is a job-like request of one generation on the jobs' dispatcher, so it gets the same
//! leases, result checks, spot checks and fault tolerance, and shares the workers round-robin
//! with the jobs: the genomes go to the dispatcher in chunks, all at once, and each chunk's
//! results are sent as soon as it and the chunks before it are in. Nothing is stored.
//!
//! Bounded like a job: the request is checked in full before anything is queued (template and
//! task as a worker would check them, every gene, and the cost limits of a generation,
//! `experiment::check_evaluation_cost`), and at most `max_live` evaluations run at once.
//! Dropping the stream, `CancelJob` with the evaluation's id, or a spot check that catches a
//! worker whose results it took ends it and drops its queued batches. An evaluation that has
//! ended is forgotten at once (its contributors too, so they take no memory): results already
//! streamed are the client's, as a finished job's results are its owner's.

use hevo_engine::dispatch::{DispatchError, Dispatcher, EvaluationRequest, RequestShared};
use hevo_proto::convert as wire;
use hevo_proto::v1;
use hevo_sim_core::{GENE_MAX, GENE_MIN, Sample};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio::sync::{Semaphore, watch};
use tokio_stream::wrappers::ReceiverStream;
use tonic::Status;

/// (genome, sample) evaluations per chunk: a chunk's results are one message of about a MiB.
const CHUNK_EVALUATIONS: usize = 16_384;
/// The most genomes per chunk, so that a small batch still spreads over many workers.
const CHUNK_GENOMES: usize = 256;

/// Why a running evaluation stops before its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stop {
    Running,
    Cancelled,
    /// A spot check caught a worker whose results it accepted.
    FalseResults,
}

/// The stream `EvaluateGenomes` answers with.
pub type EvaluationStream = ReceiverStream<Result<v1::EvaluateGenomesResponse, Status>>;

/// The master's running evaluations. Cheap to clone.
#[derive(Debug, Clone)]
pub struct Evaluations {
    dispatcher: Arc<Dispatcher>,
    live: Arc<Mutex<HashMap<String, watch::Sender<Stop>>>>,
    places: Arc<Semaphore>,
    max_live: usize,
}

/// A checked request: what the dispatcher is given.
struct Checked {
    shared: Arc<RequestShared>,
    genomes: Vec<Arc<[f32]>>,
    samples: Arc<[Sample]>,
}

fn invalid(field: &str, message: impl std::fmt::Display) -> Status {
    Status::invalid_argument(format!("{field}: {message}"))
}

/// Checks a request in full, as a worker would check its batches and as a job's generation is
/// bounded, before anything is allocated for its results.
fn check(request: v1::EvaluateGenomesRequest) -> Result<Checked, Status> {
    let template = wire::template_from_json(&request.template_json, &request.template_hash)
        .map_err(|error| Status::invalid_argument(error.to_string()))?;
    let task = wire::task_from_json(&request.task_json, &request.task_hash)
        .map_err(|error| Status::invalid_argument(error.to_string()))?;
    let Some((free_path, topology)) = template.free_node_topology() else {
        return Err(invalid(
            "template_json",
            "the template has no free node: every node has its genome",
        ));
    };
    let n_genes = topology.n_genes();
    if request.samples == 0 {
        return Err(invalid("samples", "must be at least 1"));
    }
    hevo_engine::experiment::check_evaluation_cost(
        request.genomes,
        n_genes,
        request.samples,
        task.scenario.n_variants(),
    )
    .map_err(|(field, message)| invalid(field, message))?;
    let expected = request.genomes as usize * n_genes;
    if request.genes.len() != expected {
        return Err(invalid(
            "genes",
            format!(
                "{} values, expected {} ({} genomes x {n_genes} genes of the free node '{free_path}')",
                request.genes.len(),
                expected,
                request.genomes
            ),
        ));
    }
    if let Some(idx) = request
        .genes
        .iter()
        .position(|gene| !(GENE_MIN..=GENE_MAX).contains(gene))
    {
        return Err(invalid(
            &format!("genes[{idx}]"),
            format!(
                "genome {}, gene {} is {}, outside [{GENE_MIN}, {GENE_MAX}]",
                idx / n_genes.max(1),
                idx % n_genes.max(1),
                request.genes[idx]
            ),
        ));
    }
    hevo_sim_core::controller_fits(&template, &task.scenario)
        .map_err(|problem| invalid("template_json", format!("the template {problem}")))?;
    hevo_sim_core::BatchEvaluator::new(template.clone(), task.clone())
        .map_err(|error| invalid("task_json", error))?;
    let samples =
        hevo_engine::post_evaluation::post_evaluation_samples(&task, request.samples, request.seed)
            .into();
    let genomes = if n_genes == 0 {
        Vec::new()
    } else {
        request.genes.chunks(n_genes).map(Into::into).collect()
    };
    Ok(Checked {
        shared: Arc::new(RequestShared::new(template, task)),
        genomes,
        samples,
    })
}

impl Evaluations {
    /// Evaluations on `dispatcher`, at most `max_live` at once.
    pub fn new(dispatcher: Arc<Dispatcher>, max_live: usize) -> Evaluations {
        Evaluations {
            dispatcher,
            live: Arc::default(),
            places: Arc::new(Semaphore::new(max_live)),
            max_live,
        }
    }

    /// Checks the request and starts the evaluation; returns its stream.
    pub async fn start(
        &self,
        request: v1::EvaluateGenomesRequest,
    ) -> Result<EvaluationStream, Status> {
        let Ok(place) = self.places.clone().try_acquire_owned() else {
            tracing::warn!(
                max_live = self.max_live,
                "evaluation limit reached: an evaluation was refused"
            );
            return Err(Status::resource_exhausted(format!(
                "{} evaluations are running, the most this master serves at once; try again later",
                self.max_live
            )));
        };
        // Parsing the template and task and building an evaluator is blocking work.
        let checked = tokio::task::spawn_blocking(move || check(request))
            .await
            .map_err(|error| Status::internal(format!("the request's check failed: {error}")))??;
        let id = format!("eval-{}", uuid::Uuid::now_v7().simple());
        let (stop, stopped) = watch::channel(Stop::Running);
        self.lock().insert(id.clone(), stop);
        let (sender, receiver) = tokio::sync::mpsc::channel(4);
        tracing::info!(
            evaluation = %id,
            genomes = checked.genomes.len(),
            samples = checked.samples.len(),
            "evaluation started"
        );
        let evaluations = self.clone();
        tokio::spawn(async move {
            let _place = place;
            let ended = evaluations.run(&id, checked, &sender, stopped).await;
            // Whatever ended it, nothing of it stays queued or remembered.
            evaluations.dispatcher.cancel_job(&id);
            evaluations.dispatcher.forget_contributors(&id);
            evaluations.lock().remove(&id);
            match ended {
                Ok(()) => tracing::info!(evaluation = %id, "evaluation finished"),
                Err(status) => {
                    tracing::info!(evaluation = %id, reason = %status.message(), "evaluation ended early");
                    let _ = sender.send(Err(status)).await;
                }
            }
        });
        Ok(ReceiverStream::new(receiver))
    }

    /// Queues the chunks and sends their results in order; an error ends the stream.
    async fn run(
        &self,
        id: &str,
        checked: Checked,
        sender: &tokio::sync::mpsc::Sender<Result<v1::EvaluateGenomesResponse, Status>>,
        mut stopped: watch::Receiver<Stop>,
    ) -> Result<(), Status> {
        let message = |first_genome: usize, results: Vec<v1::GenomeResult>| {
            Ok(v1::EvaluateGenomesResponse {
                evaluation_id: id.to_string(),
                first_genome: first_genome as u32,
                results,
            })
        };
        let gone = || Status::cancelled("the client went away");
        if sender.send(message(0, Vec::new())).await.is_err() {
            return Err(gone());
        }
        let per_chunk = (CHUNK_EVALUATIONS / checked.samples.len().max(1)).clamp(1, CHUNK_GENOMES);
        let now = Instant::now();
        let pending: Vec<_> = checked
            .genomes
            .chunks(per_chunk)
            .map(|chunk| {
                self.dispatcher.submit(
                    EvaluationRequest {
                        job: id.to_string(),
                        shared: checked.shared.clone(),
                        genomes: chunk.to_vec(),
                        samples: checked.samples.clone(),
                    },
                    now,
                )
            })
            .collect();
        drop(checked);
        let stop_status = |stop: Stop| match stop {
            Stop::FalseResults => Status::aborted(
                "a spot check caught a worker that sent results for this evaluation; evaluate again (that worker is refused from now on)",
            ),
            _ => Status::cancelled("the evaluation was cancelled"),
        };
        for (chunk_idx, waiting) in pending.into_iter().enumerate() {
            let results = tokio::select! {
                results = waiting.wait() => results,
                () = sender.closed() => return Err(gone()),
                stop = stopped.wait_for(|&stop| stop != Stop::Running) => {
                    let stop = stop.map_or(Stop::Cancelled, |stop| *stop);
                    return Err(stop_status(stop));
                }
            };
            let results = match results {
                Ok(results) => results,
                Err(DispatchError::Cancelled(_)) => return Err(stop_status(*stopped.borrow())),
                Err(DispatchError::Failed(why)) => {
                    return Err(Status::failed_precondition(format!(
                        "the genomes cannot be evaluated: {why}"
                    )));
                }
                Err(DispatchError::ShuttingDown) => {
                    return Err(Status::unavailable("the master is shutting down"));
                }
            };
            let first_genome = chunk_idx * per_chunk;
            if sender
                .send(message(first_genome, wire::results_to_proto(&results)))
                .await
                .is_err()
            {
                return Err(gone());
            }
        }
        Ok(())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, watch::Sender<Stop>>> {
        self.live.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn stop(&self, id: &str, why: Stop) -> bool {
        match self.lock().get(id) {
            Some(stop) => {
                stop.send_replace(why);
                true
            }
            None => false,
        }
    }

    /// Cancels a running evaluation; false when `id` is none.
    pub fn cancel(&self, id: &str) -> bool {
        let cancelled = self.stop(id, Stop::Cancelled);
        if cancelled {
            self.dispatcher.cancel_job(id);
        }
        cancelled
    }

    /// Ends a running evaluation that accepted results of a worker a spot check caught (its
    /// client evaluates again); false when `id` is no running evaluation.
    pub fn caught_false_results(&self, id: &str) -> bool {
        let running = self.stop(id, Stop::FalseResults);
        if running {
            tracing::warn!(evaluation = %id, "the evaluation accepted results of a worker a spot check caught; it ends, for its client to evaluate again");
            self.dispatcher.cancel_job(id);
        }
        running
    }
}
