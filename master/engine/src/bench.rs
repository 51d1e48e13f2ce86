//! `hevo bench`: simulator throughput on this machine. Two modes: the raw simulator (threads
//! each running samples back to back, control cycles per second), and the pipeline (a
//! generation-sized request through the dispatcher and the local worker pool, the exact path of
//! `hevo run`, in evaluations per second), so the scaling from 1 to N threads can be measured.

use crate::dispatch::{DispatchConfig, Dispatcher, EvaluationRequest, RequestShared};
use crate::experiment::Experiment;
use crate::local::LocalPool;
use hevo_sim_core::InputGroup;
use hevo_sim_core::SimRng;
use hevo_sim_core::{BatchEvaluator, EvaluatorKind};
use hevo_sim_core::{ControllerFile, NodeKind, NodeSpec};
use hevo_sim_core::{Sample, TaskConfig};
use rand::{RngExt, SeedableRng};
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

fn node(
    name: &str,
    kind: NodeKind,
    inputs: Vec<InputGroup>,
    hidden: usize,
    children: Vec<NodeSpec>,
    rng: &mut SimRng,
) -> NodeSpec {
    let spec = match kind {
        NodeKind::Primitive => NodeSpec::primitive(name, inputs, hidden),
        NodeKind::Arbitrator => NodeSpec::arbitrator(name, inputs, hidden, children),
    };
    let n_genes = spec.topology().n_genes();
    let genes = (0..n_genes)
        .map(|_| rng.random_range(-3.0f32..3.0))
        .collect();
    spec.with_genome(genes)
}

fn maze_primitives(rng: &mut SimRng) -> Vec<NodeSpec> {
    ["follow_wall", "turn_left", "turn_right"]
        .iter()
        .map(|name| {
            node(
                name,
                NodeKind::Primitive,
                vec![InputGroup::IR],
                3,
                vec![],
                rng,
            )
        })
        .collect()
}

// The sub-trees below are whole controllers of their own and parts of the rescue controller;
// the genes are drawn children first, in the order the tree lists them.

fn exit_room_primitive(rng: &mut SimRng) -> NodeSpec {
    node(
        "exit_room",
        NodeKind::Primitive,
        vec![InputGroup::IR],
        10,
        vec![],
        rng,
    )
}

fn solve_maze_arbitrator(rng: &mut SimRng) -> NodeSpec {
    let children = maze_primitives(rng);
    node(
        "solve_maze",
        NodeKind::Arbitrator,
        vec![InputGroup::IR, InputGroup::LIGHT],
        10,
        children,
        rng,
    )
}

fn return_room_arbitrator(children: Vec<NodeSpec>, rng: &mut SimRng) -> NodeSpec {
    node(
        "return_room",
        NodeKind::Arbitrator,
        vec![InputGroup::IR],
        10,
        children,
        rng,
    )
}

/// The controller a task is benchmarked with, with random fixed genes: for the paper's tasks
/// the paper's (Figure 4 topologies), so each is measured with the network sizes it is evolved
/// with; for another scenario an arbitrator over one primitive per phase of its derived
/// fitness, or a primitive, seeing every input group.
pub fn paper_controller(task: &TaskConfig, seed: u64) -> ControllerFile {
    let rng = &mut SimRng::seed_from_u64(seed);
    let scenario = &task.scenario;
    let root = match scenario.legacy().unwrap_or_default() {
        "exit_room" => exit_room_primitive(rng),
        name @ ("follow_wall" | "turn_left" | "turn_right") => node(
            name,
            NodeKind::Primitive,
            vec![InputGroup::IR],
            3,
            vec![],
            rng,
        ),
        "solve_maze" => solve_maze_arbitrator(rng),
        "return_room" => return_room_arbitrator(maze_primitives(rng), rng),
        "rescue" => {
            let exit = exit_room_primitive(rng);
            let maze = solve_maze_arbitrator(rng);
            let mut back = maze_primitives(rng);
            for child in &mut back {
                child.name = format!("{}_back", child.name);
            }
            let ret = return_room_arbitrator(back, rng);
            node(
                "rescue",
                NodeKind::Arbitrator,
                vec![InputGroup::IR, InputGroup::NEAR_ROBOT],
                10,
                vec![exit, maze, ret],
                rng,
            )
        }
        _ => {
            // Every input group the scenario's robot carries (a network may read no other).
            let all_inputs: Vec<InputGroup> = scenario.sensors.groups().collect();
            let primitive = |name: &str, rng: &mut SimRng| {
                node(
                    name,
                    NodeKind::Primitive,
                    all_inputs.clone(),
                    4,
                    vec![],
                    rng,
                )
            };
            if scenario.has_phases() {
                let children = scenario
                    .phases
                    .iter()
                    .enumerate()
                    .map(|(idx, phase)| match &phase.child {
                        hevo_sim_core::ChildRef::Name(name) => primitive(name, rng),
                        hevo_sim_core::ChildRef::Index(_) => {
                            primitive(&format!("child_{idx}"), rng)
                        }
                    })
                    .collect();
                node(
                    scenario.name(),
                    NodeKind::Arbitrator,
                    all_inputs.clone(),
                    10,
                    children,
                    rng,
                )
            } else {
                primitive(scenario.name(), rng)
            }
        }
    };
    ControllerFile::new(root)
}

/// A benchmark's result.
#[derive(Debug, Clone, Serialize)]
pub struct BenchReport {
    /// Task.
    pub task: String,
    /// Threads.
    pub threads: usize,
    /// `simulator` or `pipeline`.
    pub mode: String,
    /// The evaluator measured (the pipeline runs the default one).
    pub evaluator: EvaluatorKind,
    /// Control cycles simulated per second (all threads).
    pub cycles_per_second: f64,
    /// Per thread.
    pub cycles_per_second_per_thread: f64,
    /// Samples (evaluations) per second.
    pub evaluations_per_second: f64,
    /// Wall time measured, seconds.
    pub seconds: f64,
    /// Control cycles simulated in that time (all threads).
    pub cycles: u64,
    /// Samples (evaluations) run in that time.
    pub evaluations: u64,
    /// Robots in a sample (the focal one and a team's others, `[[robots]]`).
    pub robots: u32,
    /// Robot-cycles (a cycle of one robot: sense, decide, move) per second per thread:
    /// `cycles_per_second_per_thread` times `robots`, what a team's cost is compared by.
    pub robot_cycles_per_second_per_thread: f64,
}

impl BenchReport {
    /// The figures of `cycles` control cycles and `evaluations` samples run in `elapsed`
    /// seconds on `threads` threads, samples of `robots` robots.
    fn new(
        task: String,
        mode: &str,
        evaluator: EvaluatorKind,
        threads: usize,
        robots: u32,
        (cycles, evaluations, elapsed): (u64, u64, f64),
    ) -> BenchReport {
        let threads = threads.max(1);
        let cycles_per_second = cycles as f64 / elapsed;
        let cycles_per_second_per_thread = cycles_per_second / threads as f64;
        BenchReport {
            task,
            threads,
            mode: mode.into(),
            evaluator,
            cycles_per_second,
            cycles_per_second_per_thread,
            evaluations_per_second: evaluations as f64 / elapsed,
            seconds: elapsed,
            cycles,
            evaluations,
            robots,
            robot_cycles_per_second_per_thread: cycles_per_second_per_thread * f64::from(robots),
        }
    }
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The benchmark's controller or task is invalid (a bug: both are built here).
    #[error(transparent)]
    Setup(#[from] hevo_sim_core::BatchError),
    /// The dispatcher stopped.
    #[error(transparent)]
    Dispatch(#[from] crate::dispatch::DispatchError),
}

/// Samples one simulator call evaluates: a generation evaluates each genome on tens of samples,
/// and the lockstep evaluator needs several at once to fill its lanes. The scalar evaluator runs
/// the same calls, so both measure the same work.
pub const SIMULATOR_BATCH: usize = 16;

/// The controller a node of an experiment evolves, with random genes: its own network over
/// its children's, each as declared (a fixed child from elsewhere as it is), so that a
/// measurement with it costs per cycle what the node's evaluations will.
pub fn node_controller(experiment: &Experiment, name: &str, seed: u64) -> ControllerFile {
    fn spec(experiment: &Experiment, name: &str, rng: &mut SimRng) -> NodeSpec {
        let Some(plan) = experiment.node(name) else {
            return NodeSpec::primitive(name, vec![InputGroup::IR], 1);
        };
        let decl = &plan.decl;
        let children = decl
            .children
            .iter()
            .enumerate()
            .map(
                |(child_idx, child)| match plan.fixed_children.get(&child_idx) {
                    Some(fixed) => fixed.root.clone(),
                    None => spec(experiment, &child.to_string(), rng),
                },
            )
            .collect();
        node(
            &decl.name,
            decl.kind,
            decl.inputs.clone(),
            decl.hidden,
            children,
            rng,
        )
    }
    ControllerFile::new(spec(experiment, name, &mut SimRng::seed_from_u64(seed)))
}

/// Raw simulator throughput: `threads` threads evaluate batches of [`SIMULATOR_BATCH`] samples
/// with the paper's controller for `seconds`, with the evaluator `kind`.
pub fn simulator(
    task: TaskConfig,
    threads: usize,
    seconds: f64,
    kind: EvaluatorKind,
) -> Result<BenchReport, BenchError> {
    let controller = paper_controller(&task, 1);
    simulator_with(controller, task, threads, seconds, kind)
}

/// [`simulator`] with a controller of the caller's (complete, every node with genes).
pub fn simulator_with(
    controller: ControllerFile,
    mut task: TaskConfig,
    threads: usize,
    seconds: f64,
    kind: EvaluatorKind,
) -> Result<BenchReport, BenchError> {
    // Collisions do not end samples, so every sample runs to its limit and the figure measures
    // the simulator rather than how soon a random genome crashes.
    task.end_on_collision = false;
    let name = task.name().to_string();
    let robots = task.scenario.n_robots() as u32;
    let evaluator = BatchEvaluator::new(controller, task)?.with_kind(kind);
    let stop = AtomicBool::new(false);
    let cycles = AtomicU64::new(0);
    let samples = AtomicU64::new(0);
    let started = Instant::now();
    std::thread::scope(|scope| {
        for thread_idx in 0..threads.max(1) {
            let (evaluator, stop, cycles, samples) = (&evaluator, &stop, &cycles, &samples);
            scope.spawn(move || {
                let mut seed = thread_idx as u64 * 1_000_000;
                while !stop.load(Ordering::Relaxed) {
                    let batch: Vec<Sample> = (0..SIMULATOR_BATCH as u64)
                        .map(|k| Sample::seeded(seed + k))
                        .collect();
                    seed += SIMULATOR_BATCH as u64;
                    if let Ok(outcomes) = evaluator.evaluate_summaries(None, &batch) {
                        cycles.fetch_add(
                            outcomes.iter().map(|o| u64::from(o.cycles)).sum(),
                            Ordering::Relaxed,
                        );
                        samples.fetch_add(outcomes.len() as u64, Ordering::Relaxed);
                    }
                }
            });
        }
        std::thread::sleep(Duration::from_secs_f64(seconds));
        stop.store(true, Ordering::Relaxed);
    });
    let elapsed = started.elapsed().as_secs_f64();
    let (cycles, samples) = (
        cycles.load(Ordering::Relaxed),
        samples.load(Ordering::Relaxed),
    );
    Ok(BenchReport::new(
        name,
        "simulator",
        kind,
        threads,
        robots,
        (cycles, samples, elapsed),
    ))
}

/// The `hevo run` path: generations of 100 genomes x `samples` through the dispatcher and a
/// local pool of `threads` workers, repeated for `seconds`.
pub async fn pipeline(
    mut task: TaskConfig,
    threads: usize,
    seconds: f64,
    samples: u32,
) -> Result<BenchReport, BenchError> {
    let mut template = paper_controller(&task, 1);
    let genes = template.root.genome.take().unwrap_or_default();
    let name = task.name().to_string();
    let robots = task.scenario.n_robots() as u32;
    // As in `simulator`: every sample runs to its limit, as most do once a population avoids
    // walls. Random genomes crash within about 80 cycles, and a benchmark of such samples
    // measures per-sample set-up rather than the pipeline an evolution run spends its time in.
    // The same work in both modes also makes pipeline / simulator the pipeline's efficiency.
    task.end_on_collision = false;
    let shared = Arc::new(RequestShared::new(template, task));
    let dispatcher = Arc::new(Dispatcher::new(DispatchConfig {
        expected_workers: threads.max(1),
        ..DispatchConfig::default()
    }));
    let pool = LocalPool::start(dispatcher.clone(), threads.max(1));
    let started = Instant::now();
    let (mut cycles, mut evaluations, mut generation) = (0u64, 0u64, 0u64);
    while started.elapsed().as_secs_f64() < seconds {
        let mut rng = SimRng::seed_from_u64(generation);
        // Perturbed copies of one genome: a realistic population after a few generations.
        let genomes: Vec<Arc<[f32]>> = (0..100)
            .map(|_| {
                genes
                    .iter()
                    .map(|g| g + rng.random_range(-0.5f32..0.5))
                    .collect::<Vec<_>>()
                    .into()
            })
            .collect();
        let request = EvaluationRequest {
            job: "bench".into(),
            shared: shared.clone(),
            genomes,
            samples: (0..samples)
                .map(|s| Sample::seeded(generation * 1000 + u64::from(s)))
                .collect(),
        };
        let results = dispatcher.evaluate(request).await?;
        cycles += results
            .iter()
            .flatten()
            .map(|s| u64::from(s.cycles))
            .sum::<u64>();
        evaluations += results.iter().map(|g| g.len() as u64).sum::<u64>();
        generation += 1;
    }
    let elapsed = started.elapsed().as_secs_f64();
    pool.stop().await;
    Ok(BenchReport::new(
        name,
        "pipeline",
        EvaluatorKind::default(),
        threads,
        robots,
        (cycles, evaluations, elapsed),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The benchmark's own controllers, at the paper's topologies, on every shipped task at
    /// full length: the lockstep evaluator gives the scalar one's outcomes.
    #[test]
    fn both_evaluators_agree_on_the_benchmarked_controllers() {
        for name in hevo_sim_core::Scenario::shipped_names() {
            let mut task = TaskConfig::shipped(name).unwrap();
            task.end_on_collision = false;
            let template = paper_controller(&task, 3);
            let samples: Vec<Sample> = (0..10).map(Sample::seeded).collect();
            let run = |kind| {
                BatchEvaluator::new(template.clone(), task.clone())
                    .unwrap()
                    .with_kind(kind)
                    .evaluate_genome(None, &samples)
                    .unwrap()
            };
            assert_eq!(
                run(EvaluatorKind::Scalar),
                run(EvaluatorKind::Lockstep),
                "{name}"
            );
        }
    }

    #[test]
    fn paper_controllers_have_the_papers_topologies() {
        let shipped = |name: &str| TaskConfig::shipped(name).unwrap();
        let rescue = paper_controller(&shipped("rescue"), 1);
        rescue.validate().unwrap();
        assert_eq!(rescue.root.topology().to_string(), "5-10-3");
        assert_eq!(rescue.root.children[1].topology().to_string(), "6-10-3");
        assert_eq!(
            paper_controller(&shipped("exit_room"), 1)
                .root
                .topology()
                .to_string(),
            "4-10-2"
        );
    }
}
