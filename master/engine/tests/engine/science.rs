//! The science, pinned to the paper rather than to the code: the paper's experiment and the
//! model's numbers against SPEC's literal values, the shipped controllers' provenance, the
//! separation of post-evaluation samples from training samples, and the derived fitness f3
//! credited to an arbitrator's children by name. Each test states its expected values itself,
//! so a change to the code, a shipped file or a default that departs from the paper fails
//! here, named, instead of passing unseen or only through a snapshot's hash.

use hevo_engine::dispatch::{Batch, DispatchConfig, Dispatcher};
use hevo_engine::experiment::{ChildDecl, EvolutionParams, Experiment};
use hevo_engine::post_evaluation::post_evaluation_samples;
use hevo_engine::rundir;
use hevo_engine::runner::{Overrides, Progress, ProgressEvent, RunSettings, run_experiment};
use hevo_evolve::seeds;
use hevo_sim_core::CtrnnTopology;
use hevo_sim_core::InputGroup;
use hevo_sim_core::SampleSummary;
use hevo_sim_core::{Controller, ControllerFile, NodeKind, NodeSpec};
use hevo_sim_core::{Evaluator, Sample, TaskConfig};
use std::collections::{BTreeMap, HashSet};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::support::{read, repo_root, shipped_controller};

// --- SPEC conformance ---------------------------------------------------------------------

/// One node of the paper's rescue controller (SPEC section 5, the paper's Figure 4 and
/// Table 1): name, kind, inputs, hidden neurons, children, samples, cycles (`None` where the
/// paper leaves the corridor primitives' to us), generations, runs.
type PaperNode = (
    &'static str,
    NodeKind,
    &'static [&'static str],
    usize,
    &'static [&'static str],
    u32,
    Option<u32>,
    u32,
    u32,
);

const MAZE_PRIMITIVES: &[&str] = &["follow_wall", "turn_left", "turn_right"];

const PAPER_NODES: &[PaperNode] = &[
    (
        "exit_room",
        NodeKind::Primitive,
        &["ir"],
        10,
        &[],
        50,
        Some(1000),
        500,
        10,
    ),
    (
        "follow_wall",
        NodeKind::Primitive,
        &["ir"],
        3,
        &[],
        50,
        None,
        100,
        5,
    ),
    (
        "turn_left",
        NodeKind::Primitive,
        &["ir"],
        3,
        &[],
        50,
        None,
        100,
        5,
    ),
    (
        "turn_right",
        NodeKind::Primitive,
        &["ir"],
        3,
        &[],
        50,
        None,
        100,
        5,
    ),
    (
        "solve_maze",
        NodeKind::Arbitrator,
        &["ir", "light"],
        10,
        MAZE_PRIMITIVES,
        50,
        Some(1000),
        1000,
        10,
    ),
    (
        "return_room",
        NodeKind::Arbitrator,
        &["ir"],
        10,
        MAZE_PRIMITIVES,
        50,
        Some(1000),
        500,
        10,
    ),
    (
        "rescue",
        NodeKind::Arbitrator,
        &["ir", "near_robot"],
        10,
        &["exit_room", "solve_maze", "return_room"],
        20,
        Some(2000),
        1000,
        10,
    ),
];

/// The paper's network shapes, inputs-hidden-outputs (SPEC section 5's table).
const PAPER_TOPOLOGIES: &[(&str, [usize; 3])] = &[
    ("exit_room", [4, 10, 2]),
    ("follow_wall", [4, 3, 2]),
    ("turn_left", [4, 3, 2]),
    ("turn_right", [4, 3, 2]),
    ("solve_maze", [6, 10, 3]),
    ("return_room", [4, 10, 3]),
    ("rescue", [5, 10, 3]),
];

/// SPEC section 6: population 100, 5 elites with 19 mutated copies each, every gene mutated
/// with probability 0.1 by N(0, 1) and clamped to [-10, 10], initial genes N(0, 2^2); and the
/// paper's post-evaluation of 100 samples per controller (per light configuration for maze
/// tasks).
fn assert_papers_evolution(params: &EvolutionParams, what: &str) {
    assert_eq!(params.population, 100, "{what}: population");
    assert_eq!(params.elites, 5, "{what}: elites");
    assert_eq!(
        params.mutation_probability, 0.1,
        "{what}: mutation probability"
    );
    assert_eq!(params.mutation_sigma, 1.0, "{what}: mutation sigma");
    assert_eq!(params.initial_sigma, 2.0, "{what}: initial sigma");
    assert_eq!(params.gene_range, [-10.0, 10.0], "{what}: gene range");
    assert_eq!(
        params.post_evaluation_samples, 100,
        "{what}: post-evaluation samples"
    );
}

#[test]
fn the_default_evolution_is_the_papers() {
    assert_papers_evolution(&EvolutionParams::default(), "the defaults");
}

#[test]
fn the_paper_experiment_file_is_the_papers() {
    let file = repo_root().join("experiments/rescue.toml");
    let experiment = Experiment::load(&file).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = experiment
        .nodes
        .iter()
        .map(|n| n.decl.name.as_str())
        .collect();
    let mut expected: Vec<&str> = PAPER_NODES.iter().map(|n| n.0).collect();
    let mut sorted = names.clone();
    sorted.sort_unstable();
    expected.sort_unstable();
    assert_eq!(sorted, expected, "the rescue experiment's nodes");
    for &(name, kind, inputs, hidden, children, samples, cycles, generations, runs) in PAPER_NODES {
        let plan = experiment.node(name).unwrap();
        let decl = &plan.decl;
        assert_papers_evolution(&plan.evolution, name);
        assert_eq!(decl.kind, kind, "{name}: kind");
        let found_inputs: Vec<String> = decl.inputs.iter().map(|g| g.to_string()).collect();
        assert_eq!(found_inputs, inputs, "{name}: inputs");
        assert_eq!(decl.hidden, hidden, "{name}: hidden neurons");
        let found_children: Vec<&str> = decl
            .children
            .iter()
            .map(|child| match child {
                ChildDecl::Node(child) => child.as_str(),
                other => panic!("{name}: child {other:?} is not a node of the experiment"),
            })
            .collect();
        assert_eq!(found_children, children, "{name}: children");
        assert_eq!(decl.samples, samples, "{name}: samples per genome");
        if let Some(cycles) = cycles {
            assert_eq!(plan.task.max_cycles(), cycles, "{name}: cycles");
        }
        assert_eq!(decl.generations, generations, "{name}: generations");
        assert_eq!(decl.runs, runs, "{name}: runs");
        assert_eq!(decl.task, name, "{name}: task");
        let width: usize = decl.inputs.iter().map(|g| g.width()).sum();
        let outputs = if kind == NodeKind::Primitive {
            2
        } else {
            children.len()
        };
        let shape = PAPER_TOPOLOGIES.iter().find(|t| t.0 == name).unwrap().1;
        assert_eq!([width, hidden, outputs], shape, "{name}: topology");
        assert_eq!(
            CtrnnTopology::new(width, hidden, outputs).n_genes(),
            width * hidden + hidden * hidden + 2 * hidden + hidden * outputs + outputs,
            "{name}: genes"
        );
    }
}

/// SPEC sections 1 and 2, literally: the numbers of the robot and its sensors in every paper
/// task's model, and the tasks' cycle limits (section 5).
#[test]
fn every_paper_task_models_the_papers_robot_and_sensors() {
    let cycles = [
        ("exit_room", 1000),
        ("solve_maze", 1000),
        ("return_room", 1000),
        ("rescue", 2000),
        ("follow_wall", 400),
        ("turn_left", 400),
        ("turn_right", 400),
    ];
    for (name, max_cycles) in cycles {
        let task = TaskConfig::shipped(name).unwrap();
        let robot = &task.params.robot;
        assert_eq!(
            robot.radius, 0.0375,
            "{name}: body radius (diameter 0.075 m)"
        );
        assert_eq!(robot.wheel_base, 0.053, "{name}: wheel base");
        assert_eq!(robot.v_max, 0.1, "{name}: v_max");
        assert_eq!(robot.wheel_noise, 0.05, "{name}: wheel noise");
        assert_eq!(robot.cycle_seconds, 0.1, "{name}: control cycle");
        assert_eq!(robot.near_robot_range, 0.15, "{name}: near-robot range");
        assert_eq!(
            task.params.light.hold_cycles, 15,
            "{name}: flash hold, cycles"
        );
        assert_eq!(
            task.params.ir.offset_fraction, 0.05,
            "{name}: IR offset noise"
        );
        assert_eq!(task.params.ir.range_m, 0.14, "{name}: IR range");
        assert_eq!(task.params.ir.cone_deg, 70.0, "{name}: IR cone opening");
        assert_eq!(task.max_cycles(), max_cycles, "{name}: cycle limit");
    }
}

// --- provenance -----------------------------------------------------------------------------

/// Where each shipped controller came from: the run whose `best.json` it is, byte for byte, as
/// docs/decisions/reproduction/0018-shipped-controllers.md and REPRODUCTION.md say.
const PROVENANCE: &[(&str, &str)] = &[
    ("exit_room.json", "experiments/runs/exit_room/run-3"),
    ("follow_wall.json", "experiments/runs/follow_wall/run-1"),
    ("turn_left.json", "experiments/runs/turn_left/run-1"),
    ("turn_right.json", "experiments/runs/turn_right/run-1"),
    ("solve_maze.json", "experiments/runs/solve_maze/run-0"),
    ("return_room.json", "experiments/runs/return_room/run-0"),
    ("rescue.json", "experiments/runs/rescue/run-7"),
    (
        "triple_t_maze.json",
        "experiments/runs-triple-t-maze/triple_t_maze/run-0",
    ),
    (
        "triple_t_maze_single.json",
        "experiments/runs-triple-t-maze/triple_t_maze_single/run-1",
    ),
    ("cross_yard.json", "experiments/runs-yard/cross_yard/run-0"),
    (
        "aggregation.json",
        "experiments/runs-swarm/aggregation/run-0",
    ),
    ("dispersion.json", "experiments/runs-swarm/dispersion/run-1"),
    ("homing.json", "experiments/runs-swarm/homing/run-1"),
    ("mission.json", "experiments/runs-mission/mission/run-1"),
    ("foraging.json", "experiments/runs-foraging/foraging/run-1"),
    ("crossing.json", "experiments/runs-bodies/crossing/run-0"),
    (
        "room_to_yard.json",
        "experiments/runs-yard/room_to_yard/run-0",
    ),
];

#[test]
fn each_shipped_controller_is_the_best_of_the_run_it_came_from() {
    let mut shipped: Vec<String> = std::fs::read_dir(repo_root().join("controllers"))
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".json"))
        .collect();
    shipped.sort();
    let mut listed: Vec<String> = PROVENANCE.iter().map(|p| p.0.to_string()).collect();
    listed.sort();
    assert_eq!(shipped, listed, "every shipped controller has its run here");
    for (file, run_dir) in PROVENANCE {
        let shipped = read(&repo_root().join("controllers").join(file));
        let run_dir = repo_root().join(run_dir);
        assert!(
            shipped == read(&run_dir.join("best.json")),
            "controllers/{file} differs from {}/best.json",
            run_dir.display()
        );
        // The run is the node's best run: the node directory's controller is the same.
        let node_dir = run_dir.parent().unwrap();
        assert!(
            shipped == read(&node_dir.join("best.json")),
            "controllers/{file} differs from {}/best.json, its node's best",
            node_dir.display()
        );
    }
}

/// A composed controller's fixed children are the shipped children, gene for gene: the
/// hierarchy was evolved bottom-up on exactly the controllers shipped beside it.
#[test]
fn composed_controllers_contain_exactly_the_shipped_children() {
    let root_of = |file: &str| shipped_controller(file).root;
    let composed: &[(&str, &[&str])] = &[
        ("solve_maze.json", MAZE_PRIMITIVES),
        ("return_room.json", MAZE_PRIMITIVES),
        ("rescue.json", &["exit_room", "solve_maze", "return_room"]),
        ("mission.json", &["aggregation", "dispersion"]),
    ];
    for (file, children) in composed {
        let root = root_of(file);
        let names: Vec<&str> = root.children.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(&names, children, "{file}: children");
        for child in &root.children {
            let shipped: NodeSpec = root_of(&format!("{}.json", child.name));
            assert!(
                *child == shipped,
                "{file}: its child {} is not controllers/{}.json",
                child.name,
                child.name
            );
        }
    }
}

// --- post-evaluation samples apart from training samples ----------------------------------

/// A primitive on the maze (four light configurations) with a fake worker: small enough to
/// run in a test, with the paper's post-evaluation of 100 samples per light configuration.
const MAZE_EXPERIMENT: &str = r#"
[experiment]
name = "seeds"
seed = 11

[evolution]
population = 10
elites = 2

[[node]]
name = "maze"
kind = "primitive"
inputs = ["ir", "light"]
hidden = 2
task = "solve_maze"
samples = 8
generations = 3
runs = 2
"#;

/// Every sample a worker was given, as (seed, variant), split into training samples (the batch
/// carried free genes) and post-evaluation samples (a complete controller, no free genes).
#[derive(Debug, Default)]
struct SeenSamples {
    training: Vec<(u64, Option<u32>)>,
    post_evaluation: Vec<(u64, Option<u32>)>,
}

#[derive(Debug, Default)]
struct NoProgress;

impl Progress for NoProgress {
    fn event(&self, _event: &ProgressEvent) {}
}

/// A result every task accepts: nothing solved, one cycle, no fitness.
fn unsolved(batch: &Batch) -> Vec<Vec<SampleSummary>> {
    batch
        .genomes
        .iter()
        .map(|_| {
            batch
                .samples
                .iter()
                .map(|sample| SampleSummary {
                    cycles: 1,
                    variant: sample.variant.unwrap_or(0),
                    descriptor: vec![0.0; hevo_sim_core::DEFAULT_DESCRIPTOR.len()],
                    ..SampleSummary::default()
                })
                .collect()
        })
        .collect()
}

/// Runs `experiment` on a dispatcher served by one fake worker that records every sample it is
/// given and answers with [`unsolved`]. A panic in the worker fails the test with the worker's
/// message, and the whole run is bounded in time, so the test fails instead of hanging.
async fn run_recorded(experiment: &Experiment, out_dir: &Path) -> SeenSamples {
    let dispatcher = Arc::new(Dispatcher::new(DispatchConfig::default()));
    let seen: Arc<Mutex<SeenSamples>> = Arc::default();
    let mut worker = tokio::spawn({
        let (dispatcher, seen) = (dispatcher.clone(), seen.clone());
        async move {
            loop {
                let Some(batch) = dispatcher
                    .lease("fake", 1, Duration::from_millis(200))
                    .await
                else {
                    continue;
                };
                {
                    let mut seen = seen.lock().unwrap();
                    let post = batch.genomes.iter().all(|(_, genes)| genes.is_empty());
                    let into = if post {
                        &mut seen.post_evaluation
                    } else {
                        &mut seen.training
                    };
                    into.extend(batch.samples.iter().map(|s| (s.seed, s.variant)));
                }
                let results = unsolved(&batch);
                dispatcher
                    .complete(batch.lease_id, batch.batch_id, "fake", results)
                    .expect("the dispatcher takes the fake results");
            }
        }
    });
    let settings = RunSettings {
        out_dir: out_dir.to_path_buf(),
        overrides: Overrides::default(),
        job: "seeds".into(),
    };
    let run = run_experiment(experiment, &settings, &dispatcher, &NoProgress);
    let outcome = tokio::select! {
        outcome = tokio::time::timeout(Duration::from_secs(300), run) => outcome,
        ended = &mut worker => panic!("the fake worker stopped: {ended:?}"),
    };
    worker.abort();
    outcome
        .expect("the run finished within 300 s")
        .unwrap_or_else(|e| panic!("{e}"));
    std::mem::take(&mut *seen.lock().unwrap())
}

#[tokio::test]
async fn post_evaluation_samples_are_fresh_and_one_hundred_per_light_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let experiment = Experiment::parse(MAZE_EXPERIMENT, &dir.path().join("seeds.toml")).unwrap();
    let seen = run_recorded(&experiment, dir.path()).await;

    // Training: 2 runs x 3 generations x 8 samples (several batches may carry one sample).
    let training: HashSet<u64> = seen.training.iter().map(|s| s.0).collect();
    assert_eq!(training.len(), 2 * 3 * 8, "distinct training seeds");
    // Post-evaluation: per run, 100 distinct samples in each of the four light
    // configurations, none of them a training sample of either run, none shared by the runs.
    let post: HashSet<(u64, Option<u32>)> = seen.post_evaluation.iter().copied().collect();
    assert_eq!(post.len(), 2 * 400, "distinct post-evaluation samples");
    let post_seeds: HashSet<u64> = post.iter().map(|s| s.0).collect();
    assert_eq!(post_seeds.len(), 2 * 400, "distinct post-evaluation seeds");
    let mut per_variant: BTreeMap<Option<u32>, usize> = BTreeMap::new();
    for (_, variant) in &post {
        *per_variant.entry(*variant).or_default() += 1;
    }
    let expected: BTreeMap<Option<u32>, usize> = (0..4).map(|v| (Some(v), 200)).collect();
    assert_eq!(
        per_variant, expected,
        "post-evaluation samples per light configuration"
    );
    let shared: Vec<&u64> = post_seeds.intersection(&training).collect();
    assert!(
        shared.is_empty(),
        "post-evaluation on training seeds: {shared:?}"
    );

    // Each run's summary reports its post-evaluation over those 400 samples.
    for run in 0..2 {
        let summary_path =
            rundir::run_dir(&rundir::node_dir(dir.path(), "maze"), run).join("summary.json");
        let summary: serde_json::Value = serde_json::from_str(&read(&summary_path)).unwrap();
        assert_eq!(summary["post_evaluation"]["samples"], 400, "run {run}");
    }
}

/// At the paper's own budget (the rescue: 10 runs x 1000 generations x 20 samples), no
/// post-evaluation seed of a run is any run's training seed.
#[test]
fn at_the_papers_budget_no_post_evaluation_seed_is_a_training_seed() {
    let file = repo_root().join("experiments/rescue.toml");
    let experiment = Experiment::load(&file).unwrap_or_else(|e| panic!("{e}"));
    let plan = experiment.node("rescue").unwrap();
    let seed = experiment.header.seed;
    let mut training = HashSet::new();
    for run in 0..plan.decl.runs {
        let run_seed = seeds::run_seed(seed, "rescue", run);
        for generation in 0..plan.decl.generations {
            training.extend(seeds::generation_seeds(
                run_seed,
                generation,
                plan.decl.samples,
            ));
        }
    }
    assert_eq!(training.len(), 10 * 1000 * 20);
    for run in 0..plan.decl.runs {
        let run_seed = seeds::run_seed(seed, "rescue", run);
        let post = post_evaluation_samples(
            &plan.task,
            plan.evolution.post_evaluation_samples,
            seeds::post_evaluation_seeds(run_seed, 1)[0],
        );
        assert_eq!(post.len(), 400, "100 per light configuration");
        assert!(
            post.iter().all(|s| !training.contains(&s.seed)),
            "run {run}: a post-evaluation seed is a training seed"
        );
    }
}

// --- f3 credited by child name --------------------------------------------------------------

/// The right choices of a controller on the rescue, summed over samples: per sub-task (exit
/// room, solve maze, return to room), the cycles in it and those in which the root chose its
/// child; and the sum of the samples' f3.
fn right_choices(file: &ControllerFile, samples: &[Sample]) -> ([[u64; 2]; 3], f64) {
    let evaluator = Evaluator::new(TaskConfig::shipped("rescue").unwrap()).unwrap();
    let mut counts = [[0u64; 2]; 3];
    let mut f3 = 0.0;
    for sample in samples {
        let mut controller = Controller::new(file, None).unwrap();
        let summary = SampleSummary::from(&evaluator.evaluate(&mut controller, *sample));
        for (sub_task, count) in counts.iter_mut().enumerate() {
            count[0] += u64::from(summary.sub_task_choices.cycles[sub_task]);
            count[1] += u64::from(summary.sub_task_choices.correct[sub_task]);
        }
        f3 += f64::from(summary.fitness);
    }
    (counts, f3)
}

/// 10 post-evaluation samples of each light configuration.
fn rescue_samples() -> Vec<Sample> {
    post_evaluation_samples(&TaskConfig::shipped("rescue").unwrap(), 10, 1)
}

/// The shipped rescue arbitrator on 40 fixed samples: how often it chose the child each
/// sub-task asks for (the terms of f3). A phase of `scenarios/rescue.toml` that names another
/// child, or f3 crediting children by position, changes these counts.
#[test]
fn the_shipped_rescue_chooses_the_named_child_of_each_sub_task() {
    // Measured at MODEL_VERSION 4.
    const MEAN_F3: f64 = 2.727_625_255;
    let (counts, f3) = right_choices(&shipped_controller("rescue.json"), &rescue_samples());
    // [cycles in the sub-task, cycles the root chose its child], measured at MODEL_VERSION 4.
    let measured: [[u64; 2]; 3] = [[18_094, 16_127], [12_403, 10_325], [14_998, 14_871]];
    assert_eq!(counts, measured, "right choices per sub-task");
    let mean_f3 = f3 / 40.0;
    assert!(
        (mean_f3 - MEAN_F3).abs() < 1e-6,
        "mean f3 {mean_f3}, measured {MEAN_F3}"
    );
}

/// The rescue arbitrator with its children in another order, and its output rows moved with
/// them, so it drives the robot as before: f3 must credit the same choices, as the phases name
/// their children. (Not always exactly the same: where two outputs saturate to the same 1.0,
/// the activator takes the first, which the permutation moves; that changes a handful of
/// cycles, where crediting by position would move thousands.)
#[test]
fn an_arbitrator_with_its_children_permuted_is_credited_by_name() {
    let original = shipped_controller("rescue.json");
    let permutation = [2usize, 0, 1];
    let mut permuted = original.clone();
    let root = &mut permuted.root;
    root.children = permutation
        .iter()
        .map(|&c| original.root.children[c].clone())
        .collect();
    let topology = CtrnnTopology::new(
        root.inputs.iter().map(|g: &InputGroup| g.width()).sum(),
        root.hidden,
        3,
    );
    let layout = topology.layout();
    let genes = original.root.genome.clone().unwrap();
    let genome = root.genome.as_mut().unwrap();
    for (to, &from) in permutation.iter().enumerate() {
        let row = |output: usize| {
            let start = layout.output_weights.start + output * topology.n_hidden;
            start..start + topology.n_hidden
        };
        genome[row(to)].copy_from_slice(&genes[row(from)]);
        genome[layout.output_biases.start + to] = genes[layout.output_biases.start + from];
    }
    assert_ne!(permuted, original);
    let samples = &rescue_samples()[..12];
    let before = right_choices(&original, samples);
    let after = right_choices(&permuted, samples);
    for (sub_task, (a, b)) in after.0.iter().zip(&before.0).enumerate() {
        let close = |x: u64, y: u64| x.abs_diff(y) * 200 <= y;
        assert!(
            close(a[0], b[0]) && close(a[1], b[1]),
            "sub-task {sub_task}: {a:?} (cycles, right choices) after permuting the children, \
             {b:?} before"
        );
    }
    assert!(
        (after.1 - before.1).abs() < 0.01 * before.1,
        "f3 summed over the samples: {} after, {} before",
        after.1,
        before.1
    );
    assert!(
        before.1 > 12.0 * 2.0,
        "the shipped rescue scores f3 {}",
        before.1
    );
}
