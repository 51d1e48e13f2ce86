//! Local mode's workers: in-process tasks that lease batches from the dispatcher exactly as
//! remote workers do, evaluate them on a blocking thread with sim-core, and return the results.
//! One worker per thread, each evaluating one batch at a time, so `--threads N` keeps N cores
//! busy. Evaluators are cached by (template hash, task hash): building one validates the tree
//! and prepares the task's shared geometry, which a generation's batches all reuse.

use crate::dispatch::{Batch, Dispatcher};
use sim_core::batch::{BatchEvaluator, SampleSummary};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::watch;
use tokio::task::JoinHandle;

/// Evaluators shared by the workers of one process, by (template hash, task hash).
#[derive(Debug, Default)]
pub struct EvaluatorCache {
    entries: Mutex<HashMap<(String, String), Arc<BatchEvaluator>>>,
}

/// Most evaluators kept; a run needs one for its generations and one per post-evaluation
/// template, so a handful covers several concurrent jobs.
const CACHE_CAPACITY: usize = 32;

impl EvaluatorCache {
    /// The evaluator for a batch, built on first use.
    pub fn get(&self, batch: &Batch) -> Result<Arc<BatchEvaluator>, String> {
        let key = (batch.shared.template_hash.clone(), batch.shared.task_hash.clone());
        if let Some(found) = self.entries.lock().unwrap_or_else(|p| p.into_inner()).get(&key) {
            return Ok(found.clone());
        }
        let evaluator = Arc::new(
            BatchEvaluator::new(batch.shared.template.clone(), batch.shared.task.clone()).map_err(|e| e.to_string())?,
        );
        let mut entries = self.entries.lock().unwrap_or_else(|p| p.into_inner());
        if entries.len() >= CACHE_CAPACITY {
            entries.clear();
        }
        entries.insert(key, evaluator.clone());
        Ok(evaluator)
    }
}

/// Evaluates a whole batch on the calling thread.
pub fn evaluate_batch(evaluator: &BatchEvaluator, batch: &Batch) -> Result<Vec<Vec<SampleSummary>>, String> {
    batch
        .genomes
        .iter()
        .map(|(_, genes)| {
            let genes = (evaluator.n_free_genes() > 0).then_some(&genes[..]);
            evaluator.evaluate_summaries(genes, &batch.samples).map_err(|e| e.to_string())
        })
        .collect()
}

/// A running pool of in-process workers.
#[derive(Debug)]
pub struct LocalPool {
    stop: watch::Sender<bool>,
    handles: Vec<JoinHandle<()>>,
}

impl LocalPool {
    /// Starts `threads` workers on the dispatcher.
    pub fn start(dispatcher: Arc<Dispatcher>, threads: usize) -> LocalPool {
        let (stop, stopped) = watch::channel(false);
        let cache = Arc::new(EvaluatorCache::default());
        let handles = (0..threads.max(1))
            .map(|worker_idx| {
                let dispatcher = dispatcher.clone();
                let cache = cache.clone();
                let mut stopped = stopped.clone();
                let name = format!("local-{worker_idx}");
                tokio::spawn(async move {
                    loop {
                        if *stopped.borrow() {
                            break;
                        }
                        let batch = tokio::select! {
                            batch = dispatcher.lease(&name, Duration::from_secs(1)) => batch,
                            _ = stopped.changed() => break,
                        };
                        let Some(batch) = batch else { continue };
                        let cache = cache.clone();
                        let work = batch.clone();
                        let result = tokio::task::spawn_blocking(move || {
                            let evaluator = cache.get(&work)?;
                            evaluate_batch(&evaluator, &work)
                        })
                        .await
                        .unwrap_or_else(|join_error| Err(format!("evaluation thread failed: {join_error}")));
                        match result {
                            Ok(results) => {
                                if let Err(error) = dispatcher.complete(batch.lease_id, batch.batch_id, results) {
                                    tracing::error!(%error, "local worker result refused");
                                }
                            }
                            Err(message) => dispatcher.fail(batch.lease_id, message),
                        }
                    }
                })
            })
            .collect();
        LocalPool { stop, handles }
    }

    /// Stops the workers after their current batch.
    pub async fn stop(self) {
        let _ = self.stop.send(true);
        for handle in self.handles {
            let _ = handle.await;
        }
    }
}
