//! Local mode's workers: in-process tasks that lease batches from the dispatcher exactly as
//! remote workers do, evaluate them on a blocking thread with sim-core, and return the results.
//! One worker per thread, each evaluating one batch at a time, so `--threads N` keeps N cores
//! busy. The evaluation itself is the [`crate::executor`], the same code remote workers run, with
//! evaluators cached by (template hash, task hash): building one validates the tree and
//! prepares the task's shared geometry, which a generation's batches all reuse.
//!
//! [`local_dispatcher`] and [`run_local`] are local mode as a whole, shared by `hevo run`,
//! `hevo eval` and the Python module: a dispatcher, a runtime and a pool, for the time one piece
//! of work takes.

use crate::dispatch::{Batch, DispatchConfig, Dispatcher};
use crate::executor::{EvaluatorCache, ExecError, evaluate_genomes};
use hevo_sim_core::{BatchEvaluator, SampleSummary};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;
use tokio::task::JoinHandle;

/// The evaluator for a batch, from the process's cache (built from the batch's template and
/// task on first use).
pub fn evaluator_for(
    cache: &EvaluatorCache,
    batch: &Batch,
) -> Result<Arc<BatchEvaluator>, ExecError> {
    let shared = &batch.shared;
    cache.get_or_build(&shared.template_hash, &shared.task_hash, || {
        Ok((shared.template.clone(), shared.task.clone()))
    })
}

/// Evaluates a whole batch on the calling thread.
pub fn evaluate_batch(
    evaluator: &BatchEvaluator,
    batch: &Batch,
) -> Result<Vec<Vec<SampleSummary>>, ExecError> {
    let genomes: Vec<&[f32]> = batch.genomes.iter().map(|(_, genes)| &genes[..]).collect();
    evaluate_genomes(evaluator, &genomes, &batch.samples, 1, None)
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
                            batch = dispatcher.lease(&name, 1, Duration::from_secs(1)) => batch,
                            _ = stopped.changed() => break,
                        };
                        let Some(batch) = batch else { continue };
                        let cache = cache.clone();
                        let work = batch.clone();
                        let result = tokio::task::spawn_blocking(move || {
                            let evaluator = evaluator_for(&cache, &work)?;
                            evaluate_batch(&evaluator, &work)
                        })
                        .await
                        .unwrap_or_else(|join_error| {
                            Err(ExecError::Invalid(format!(
                                "evaluation thread failed: {join_error}"
                            )))
                        });
                        match result {
                            Ok(results) => {
                                if let Err(error) = dispatcher.complete(
                                    batch.lease_id,
                                    batch.batch_id,
                                    &name,
                                    results,
                                ) {
                                    tracing::error!(%error, "local worker result refused");
                                }
                            }
                            Err(error) => {
                                if let Err(refused) =
                                    dispatcher.fail(batch.lease_id, &name, error.to_string())
                                {
                                    tracing::error!(%refused, "local worker failure refused");
                                }
                            }
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

/// How long an in-process worker may hold a batch: in effect for ever. In-process workers
/// cannot vanish while the process lives, and they do not heartbeat: a lease that expired
/// because the process was starved of CPU (a suspended job, a compile at higher priority) would
/// only make the batch run twice.
pub const LOCAL_LEASE: Duration = Duration::from_secs(7 * 24 * 3600);

/// A dispatcher for `threads` in-process workers. Kept by the caller, so that another thread
/// can [`Dispatcher::shut_down`] it to stop the work early (Python's Ctrl-C).
pub fn local_dispatcher(threads: usize) -> Arc<Dispatcher> {
    Arc::new(Dispatcher::new(DispatchConfig {
        expected_workers: threads.max(1),
        lease_timeout: LOCAL_LEASE,
        ..DispatchConfig::default()
    }))
}

/// Runs `work` on a new multi-threaded runtime against `dispatcher`, served by `threads`
/// in-process workers, and stops the workers once it is done. The error is the runtime's, which
/// could not start.
pub fn run_local<T>(
    dispatcher: Arc<Dispatcher>,
    threads: usize,
    work: impl AsyncFnOnce(&Dispatcher) -> T,
) -> std::io::Result<T> {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    Ok(runtime.block_on(async {
        let pool = LocalPool::start(dispatcher.clone(), threads);
        let result = work(&dispatcher).await;
        pool.stop().await;
        result
    }))
}

#[cfg(test)]
mod tests {
    //! Local mode as `hevo run` uses it, with the real simulator, on a tiny budget.

    use super::*;
    use crate::experiment::Experiment;
    use crate::rundir::{BEST, FITNESS_CSV, SUMMARY, TASK, run_dir};
    use crate::runner::{Overrides, Progress, ProgressEvent, RunSettings, run_experiment};

    struct Quiet;

    impl Progress for Quiet {
        fn event(&self, _: &ProgressEvent) {}
    }

    /// One run of three generations of a small exit-room network, with the evolution keys
    /// given.
    fn tiny_experiment(evolution: &str) -> String {
        format!(
            r#"
[experiment]
name = "tiny"
seed = 7

[evolution]
post_evaluation_samples = 1
{evolution}

[[node]]
name = "exit_room"
kind = "primitive"
inputs = ["ir"]
hidden = 1
task = "exit_room"
samples = 2
cycles = 40
generations = 3
runs = 1
"#
        )
    }

    /// Runs `text` (an experiment) into `out`, as `hevo run --out` does.
    fn run_into(text: &str, dir: &std::path::Path, out: &std::path::Path) -> Result<(), String> {
        let experiment = Experiment::parse(text, &dir.join("tiny.toml")).unwrap();
        let settings = RunSettings {
            out_dir: out.to_path_buf(),
            overrides: Overrides::default(),
            job: "tiny".into(),
        };
        run_local(local_dispatcher(1), 1, async |dispatcher| {
            run_experiment(&experiment, &settings, dispatcher, &Quiet).await
        })
        .unwrap()
        .map(|_| ())
        .map_err(|e| e.to_string())
    }

    #[test]
    fn a_node_records_its_task_and_a_changed_task_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let node = out.join("exit_room");
        let experiment = tiny_experiment("population = 4\nelites = 1");
        run_into(&experiment, dir.path(), &out).unwrap();
        let recorded = std::fs::read_to_string(node.join(TASK)).unwrap();
        let task = Experiment::parse(&experiment, &dir.path().join("tiny.toml"))
            .unwrap()
            .nodes[0]
            .task
            .clone();
        let read: hevo_sim_core::TaskConfig = serde_json::from_str(&recorded).unwrap();
        assert_eq!(read, task);

        // A node finished before nodes recorded their task gains the file when run again,
        // without evolving again.
        let log = std::fs::read_to_string(run_dir(&node, 0).join(FITNESS_CSV)).unwrap();
        std::fs::remove_file(node.join(TASK)).unwrap();
        run_into(&experiment, dir.path(), &out).unwrap();
        assert_eq!(std::fs::read_to_string(node.join(TASK)).unwrap(), recorded);
        let log_after = std::fs::read_to_string(run_dir(&node, 0).join(FITNESS_CSV)).unwrap();
        assert_eq!(log_after, log);

        // Another task over the recorded one is refused, naming the file.
        let changed = experiment.replace("cycles = 40", "cycles = 41");
        let error = run_into(&changed, dir.path(), &out).unwrap_err();
        assert!(error.contains("records another task"), "{error}");
        assert!(
            error.contains(&node.join(TASK).display().to_string()),
            "{error}"
        );

        // Without the file, another setup is refused by its fingerprint before any file is
        // written: the task file never names a task the node's results were not made on.
        std::fs::remove_file(node.join(TASK)).unwrap();
        let error = run_into(&changed, dir.path(), &out).unwrap_err();
        assert!(error.contains("fingerprint"), "{error}");
        assert!(!node.join(TASK).exists());
    }

    #[test]
    fn every_cmaes_variant_and_novelty_search_run_through_local_mode() {
        for evolution in [
            "algorithm = \"cmaes\"\npopulation = 6",
            "algorithm = \"cmaes\"\npopulation = 6\ncmaes_variant = \"separable\"",
            "algorithm = \"cmaes\"\npopulation = 4\nrestarts = 2\nrestart_population_factor = 3",
            // Over the simulator's behaviour descriptor, the final position.
            "algorithm = \"novelty\"\npopulation = 6\nelites = 2\nnovelty_neighbours = 3",
        ] {
            let dir = tempfile::tempdir().unwrap();
            let experiment =
                Experiment::parse(&tiny_experiment(evolution), &dir.path().join("tiny.toml"))
                    .unwrap();
            let settings = RunSettings {
                out_dir: dir.path().join("out"),
                overrides: Overrides::default(),
                job: "tiny".into(),
            };
            let summaries = run_local(local_dispatcher(2), 2, async |dispatcher| {
                run_experiment(&experiment, &settings, dispatcher, &Quiet).await
            })
            .unwrap()
            .unwrap_or_else(|e| panic!("{evolution}: {e}"));
            assert_eq!(summaries.len(), 1, "{evolution}");
            let run = run_dir(&settings.out_dir.join("exit_room"), 0);
            for file in [BEST, FITNESS_CSV, SUMMARY] {
                assert!(run.join(file).is_file(), "{evolution}: {file}");
            }
            let rows = std::fs::read_to_string(run.join(FITNESS_CSV)).unwrap();
            assert_eq!(rows.lines().count(), 1 + 3, "{evolution}: {rows}");
        }
    }
}
