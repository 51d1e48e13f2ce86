//! Batch evaluation shared by every kind of worker. An evaluator (a validated controller
//! template and task, with the task's prepared geometry) is built once per (template hash, task
//! hash) and cached; a batch's genomes are then evaluated on its samples, on the calling thread
//! or spread over several threads. Work is cut into (genome, run of samples) units handed out
//! in order and written back by index, so the result does not depend on the number of threads
//! or on which thread ran what: a sample's outcome depends only on the genome and the sample's
//! seed.

use hevo_sim_core::ControllerFile;
use hevo_sim_core::Sample;
use hevo_sim_core::TaskConfig;
use hevo_sim_core::{BatchEvaluator, SampleSummary};
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

/// Why a batch was not evaluated.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ExecError {
    /// The template, task or a genome is invalid: every worker would fail the same way.
    #[error("{0}")]
    Invalid(String),
    /// The batch came without its template or task and the worker no longer has them cached.
    #[error("the batch's template or task is not cached and was not sent")]
    Missing,
    /// Evaluation was stopped (shutdown, or the lease was lost).
    #[error("evaluation aborted")]
    Aborted,
}

/// Most evaluators kept. A run needs one for its generations and one per post-evaluation, so
/// a handful covers several concurrent jobs; clearing everything when full is simpler than an
/// LRU and costs one rebuild per evaluator.
const CACHE_CAPACITY: usize = 32;

/// Evaluators by (template hash, task hash), shared by the threads of one process.
#[derive(Debug, Default)]
pub struct EvaluatorCache {
    entries: Mutex<HashMap<(String, String), Arc<BatchEvaluator>>>,
}

impl EvaluatorCache {
    fn entries(&self) -> std::sync::MutexGuard<'_, HashMap<(String, String), Arc<BatchEvaluator>>> {
        // Entries are inserted whole, so a poisoned map is still consistent.
        self.entries
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The cached evaluator for the key, if any.
    pub fn get(&self, template_hash: &str, task_hash: &str) -> Option<Arc<BatchEvaluator>> {
        self.entries()
            .get(&(template_hash.to_string(), task_hash.to_string()))
            .cloned()
    }

    /// The evaluator for the key, built from what `source` returns on a miss.
    pub fn get_or_build(
        &self,
        template_hash: &str,
        task_hash: &str,
        source: impl FnOnce() -> Result<(ControllerFile, TaskConfig), ExecError>,
    ) -> Result<Arc<BatchEvaluator>, ExecError> {
        if let Some(found) = self.get(template_hash, task_hash) {
            return Ok(found);
        }
        let (template, task) = source()?;
        // Built outside the lock: preparing a task's geometry takes a while and other threads
        // may need other evaluators meanwhile.
        let evaluator = Arc::new(
            BatchEvaluator::new(template, task).map_err(|e| ExecError::Invalid(e.to_string()))?,
        );
        let mut entries = self.entries();
        if entries.len() >= CACHE_CAPACITY {
            entries.clear();
        }
        entries.insert(
            (template_hash.to_string(), task_hash.to_string()),
            evaluator.clone(),
        );
        Ok(evaluator)
    }

    /// The cached keys, (template hash, task hash) (what a worker tells the master).
    pub fn keys(&self) -> Vec<(String, String)> {
        self.entries().keys().cloned().collect()
    }
}

/// What one unit of work gave: its summaries, in sample order.
type UnitResult = Result<Vec<SampleSummary>, ExecError>;

/// Evaluates every genome on every sample: results indexed `[genome][sample]`. `threads` > 1
/// spreads the work over scoped threads; `abort` (checked between units) stops early.
pub fn evaluate_genomes(
    evaluator: &BatchEvaluator,
    genomes: &[&[f32]],
    samples: &[Sample],
    threads: usize,
    abort: Option<&AtomicBool>,
) -> Result<Vec<Vec<SampleSummary>>, ExecError> {
    let uses_genes = evaluator.n_free_genes() > 0;
    let run = |genes: &[f32], samples: &[Sample]| {
        evaluator
            .evaluate_summaries(uses_genes.then_some(genes), samples)
            .map_err(|e| ExecError::Invalid(e.to_string()))
    };
    let aborted = || abort.is_some_and(|flag| flag.load(Ordering::Relaxed));
    if genomes.is_empty() || samples.is_empty() {
        return Ok(vec![Vec::new(); genomes.len()]);
    }
    let threads = threads.max(1);
    if threads == 1 {
        let mut results = Vec::with_capacity(genomes.len());
        for genes in genomes {
            if aborted() {
                return Err(ExecError::Aborted);
            }
            results.push(run(genes, samples)?);
        }
        return Ok(results);
    }

    // Units: whole genomes when there are enough of them to keep every thread busy, else each
    // genome's samples in runs (a post-evaluation is one genome on hundreds of samples).
    let per_genome = if genomes.len() >= 2 * threads {
        1
    } else {
        (2 * threads).div_ceil(genomes.len()).min(samples.len())
    };
    let chunk = samples.len().div_ceil(per_genome);
    let units: Vec<(usize, std::ops::Range<usize>)> = (0..genomes.len())
        .flat_map(|g| {
            (0..samples.len())
                .step_by(chunk)
                .map(move |start| (g, start..(start + chunk).min(samples.len())))
        })
        .collect();
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let outputs: Vec<Mutex<Option<UnitResult>>> = units.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.min(units.len()) {
            scope.spawn(|| {
                loop {
                    if failed.load(Ordering::Relaxed) || aborted() {
                        break;
                    }
                    let idx = next.fetch_add(1, Ordering::Relaxed);
                    let Some((g, range)) = units.get(idx) else {
                        break;
                    };
                    let result = run(genomes[*g], &samples[range.clone()]);
                    if result.is_err() {
                        failed.store(true, Ordering::Relaxed);
                    }
                    *outputs[idx].lock().unwrap_or_else(|p| p.into_inner()) = Some(result);
                }
            });
        }
    });
    let mut results: Vec<Vec<SampleSummary>> = genomes
        .iter()
        .map(|_| Vec::with_capacity(samples.len()))
        .collect();
    for ((g, _), output) in units.iter().zip(outputs) {
        match output.into_inner().unwrap_or_else(|p| p.into_inner()) {
            Some(Ok(summaries)) => results[*g].extend(summaries),
            Some(Err(error)) => return Err(error),
            // A unit that never ran: only when stopped early.
            None => {
                return Err(if aborted() {
                    ExecError::Aborted
                } else {
                    ExecError::Invalid("internal: a unit was not evaluated".into())
                });
            }
        }
    }
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::NodeSpec;

    fn template() -> ControllerFile {
        ControllerFile::new(NodeSpec::primitive("p", vec![InputGroup::IR], 3))
    }

    fn task() -> TaskConfig {
        let mut task = TaskConfig::shipped("follow_wall").unwrap();
        task.max_cycles = Some(60);
        task
    }

    #[test]
    fn results_do_not_depend_on_threads_and_keep_order() {
        let cache = EvaluatorCache::default();
        let evaluator = cache
            .get_or_build("t", "k", || Ok((template(), task())))
            .unwrap();
        let n = evaluator.n_free_genes();
        let genomes: Vec<Vec<f32>> = (0..5)
            .map(|g| (0..n).map(|i| ((g * 7 + i) % 11) as f32 - 5.0).collect())
            .collect();
        let refs: Vec<&[f32]> = genomes.iter().map(Vec::as_slice).collect();
        let samples: Vec<Sample> = (0..7).map(Sample::seeded).collect();
        let one = evaluate_genomes(&evaluator, &refs, &samples, 1, None).unwrap();
        for threads in [2, 3, 8] {
            assert_eq!(
                evaluate_genomes(&evaluator, &refs, &samples, threads, None).unwrap(),
                one,
                "{threads} threads"
            );
        }
        // One genome on many samples is split by samples and still in order.
        let single = evaluate_genomes(&evaluator, &refs[..1], &samples, 4, None).unwrap();
        assert_eq!(single[0], one[0]);
        assert_eq!(cache.keys(), [("t".to_string(), "k".to_string())]);
        assert!(cache.get("t", "k").is_some());
    }

    #[test]
    fn bad_genomes_and_aborts_are_errors() {
        let cache = EvaluatorCache::default();
        let evaluator = cache
            .get_or_build("t", "k", || Ok((template(), task())))
            .unwrap();
        let short = [0.0f32; 2];
        let err =
            evaluate_genomes(&evaluator, &[&short], &[Sample::seeded(1)], 2, None).unwrap_err();
        assert!(matches!(err, ExecError::Invalid(_)), "{err:?}");
        let genes = vec![0.0f32; evaluator.n_free_genes()];
        let stop = AtomicBool::new(true);
        assert_eq!(
            evaluate_genomes(&evaluator, &[&genes], &[Sample::seeded(1)], 1, Some(&stop)),
            Err(ExecError::Aborted)
        );
        assert_eq!(
            evaluate_genomes(
                &evaluator,
                &[&genes, &genes, &genes],
                &[Sample::seeded(1)],
                2,
                Some(&stop)
            ),
            Err(ExecError::Aborted)
        );
        let missing = cache.get_or_build("x", "y", || Err(ExecError::Missing));
        assert_eq!(missing.unwrap_err(), ExecError::Missing);
    }
}
