//! The lockstep evaluator against the scalar reference: on random controller trees (depth up to
//! three, any input groups and sizes, with and without a minimum time on, with and without a
//! free node), every shipped scenario, the example T-maze and the wandering teammate's example,
//! the team arena (also with a group running a controller file), the foraging scenario and the movers' and boxes' scenarios, random seeds and variants, cycle limits and
//! collision rules, both must give the same outcome for every sample, fitness to the bit. Sample counts that are not a multiple of the lane count exercise lanes that refill and
//! lanes left empty.

use hevo_sim_core::{BatchEvaluator, EvaluatorKind};
use hevo_sim_core::{ControllerFile, NodeSpec};
use hevo_sim_core::{InputGroup, SensorSet};
use hevo_sim_core::{Outcome, Sample, Scenario, TaskConfig};
use hevo_sim_core::{SimRng, mix64};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};

use crate::support::example_task;

/// Every task the property draws from: the shipped scenarios and the examples.
pub(crate) fn tasks() -> Vec<TaskConfig> {
    let mut tasks: Vec<TaskConfig> = Scenario::shipped_names()
        .into_iter()
        .map(|name| TaskConfig::shipped(name).expect("shipped"))
        .collect();
    tasks.push(example_task("t_maze"));
    // A wandering teammate: its walk lives in the per-sample state both evaluators share.
    tasks.push(example_task("find_wanderer"));
    // A team: copies of the lane's controller, wanderers and a fixed robot beside it.
    tasks.push(crate::team::team_task());
    // A group running a controller file's copies beside them.
    tasks.push(crate::group_files::file_group_task(17));
    // Scheduled lights, and phases and stages that see them and the team.
    tasks.push(crate::schedules::scheduled_task());
    // Items: picked up, carried and delivered by the lane's robot and its team.
    tasks.push(crate::objects::foraging_task());
    // Movers that wait for robots, and boxes the robots push.
    tasks.push(crate::bodies::crossing_task());
    tasks.push(crate::bodies::box_pushing_task());
    tasks
}

/// Random input groups among those the robot `carried` (the e-puck's, and `items` where the
/// scenario has them).
fn random_inputs(carried: SensorSet, rng: &mut SimRng) -> Vec<InputGroup> {
    let all = [
        InputGroup::IR,
        InputGroup::LIGHT,
        InputGroup::NEAR_ROBOT,
        InputGroup::ITEMS,
    ];
    let mut inputs: Vec<InputGroup> = all
        .into_iter()
        .filter(|&group| carried.carries(group))
        .filter(|_| rng.random_range(0..3) > 0)
        .collect();
    if inputs.is_empty() {
        inputs.push(InputGroup::IR);
    }
    // Any order: a network reads its groups in the order it lists them.
    if rng.random_range(0..2) == 0 {
        inputs.reverse();
    }
    inputs
}

fn random_genes(rng: &mut SimRng, n: usize) -> Vec<f32> {
    (0..n).map(|_| rng.random_range(-10.0f32..10.0)).collect()
}

/// A random node with its genes; arbitrators above `depth` 0 get two or three children.
fn random_node(name: String, depth: u32, carried: SensorSet, rng: &mut SimRng) -> NodeSpec {
    let hidden = rng.random_range(1..7);
    let inputs = random_inputs(carried, rng);
    let spec = if depth > 0 && rng.random_range(0..3) > 0 {
        let n_children = rng.random_range(2..4);
        let children = (0..n_children)
            .map(|idx| random_node(format!("{name}_{idx}"), depth - 1, carried, rng))
            .collect();
        let mut spec = NodeSpec::arbitrator(name, inputs, hidden, children);
        if rng.random_range(0..3) == 0 {
            spec.min_active_cycles = rng.random_range(1..6);
        }
        spec
    } else {
        NodeSpec::primitive(name, inputs, hidden)
    };
    let n_genes = spec.topology().n_genes();
    spec.with_genome(random_genes(rng, n_genes))
}

/// A random tree for `task`: when its phases name children, an arbitrator over random
/// subtrees of those names (the evaluators refuse a root that lacks one), else any tree.
pub(crate) fn random_root(task: &TaskConfig, depth: u32, rng: &mut SimRng) -> NodeSpec {
    let names = task.scenario.named_phase_children();
    let carried = task.scenario.sensors;
    if names.is_empty() {
        return random_node("root".into(), depth, carried, rng);
    }
    let children = names
        .iter()
        .map(|name| random_node(name.to_string(), depth.saturating_sub(1), carried, rng))
        .collect();
    let hidden = rng.random_range(1..7);
    let spec = NodeSpec::arbitrator("root", random_inputs(carried, rng), hidden, children);
    let n_genes = spec.topology().n_genes();
    spec.with_genome(random_genes(rng, n_genes))
}

/// Both evaluators' outcomes for one case.
fn both(
    template: ControllerFile,
    genes: Option<Vec<f32>>,
    task: TaskConfig,
    samples: &[Sample],
) -> (Vec<Outcome>, Vec<Outcome>) {
    let scalar = BatchEvaluator::new(template.clone(), task.clone())
        .expect("valid case")
        .with_kind(EvaluatorKind::Scalar);
    let lockstep = BatchEvaluator::new(template, task)
        .expect("valid case")
        .with_kind(EvaluatorKind::Lockstep);
    let genes = genes.as_deref();
    (
        scalar.evaluate_genome(genes, samples).expect("genome fits"),
        lockstep
            .evaluate_genome(genes, samples)
            .expect("genome fits"),
    )
}

fn assert_same(scalar: &[Outcome], lockstep: &[Outcome], what: &str) {
    assert_eq!(scalar.len(), lockstep.len(), "{what}: sample count");
    for (idx, (a, b)) in scalar.iter().zip(lockstep).enumerate() {
        assert_eq!(
            a.fitness.to_bits(),
            b.fitness.to_bits(),
            "{what}, sample {idx}: fitness {} vs {}",
            a.fitness,
            b.fitness
        );
        assert_eq!(a, b, "{what}, sample {idx}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn lockstep_outcomes_equal_the_scalar_ones(
        case_seed in any::<u64>(),
        task_pick in any::<usize>(),
        n_samples in 1usize..21,
        max_cycles in prop_oneof![Just(None), (1u32..400).prop_map(Some)],
        end_on_collision in any::<bool>(),
        free_root in any::<bool>(),
    ) {
        let rng = &mut SimRng::seed_from_u64(case_seed);
        let all = tasks();
        let mut task = all[task_pick % all.len()].clone();
        task.max_cycles = max_cycles.map(|limit| limit.min(task.max_cycles()));
        task.end_on_collision = end_on_collision;
        let depth = rng.random_range(0..4);
        let mut root = random_root(&task, depth, rng);
        let genes = if free_root { root.genome.take() } else { None };
        let n_variants = task.scenario.n_variants();
        let samples: Vec<Sample> = (0..n_samples)
            .map(|idx| Sample {
                seed: mix64(case_seed ^ idx as u64),
                variant: (rng.random_range(0..2) == 0).then(|| rng.random_range(0..n_variants)),
            })
            .collect();
        let (scalar, lockstep) = both(ControllerFile::new(root), genes, task.clone(), &samples);
        assert_same(&scalar, &lockstep, &format!("{} (case seed {case_seed})", task.name()));
    }
}

/// Every task at its full length, collisions not ending a sample, with a two-level tree that
/// reads every input group the robot carries: the longest trajectories, where any drift would show.
#[test]
fn full_length_samples_agree_on_every_task() {
    for task in tasks() {
        let mut task = task;
        task.end_on_collision = false;
        let rng = &mut SimRng::seed_from_u64(29);
        let mut root = (0..)
            .map(|_| random_root(&task, 2, rng))
            .find(|node| !node.children.is_empty())
            .expect("an arbitrator comes up");
        root.inputs = task.scenario.sensors.groups().collect();
        let n_genes = root.topology().n_genes();
        root.genome = Some(random_genes(rng, n_genes));
        let samples: Vec<Sample> = (0..11).map(|seed| Sample::seeded(1000 + seed)).collect();
        let (scalar, lockstep) = both(ControllerFile::new(root), None, task.clone(), &samples);
        assert_same(&scalar, &lockstep, task.name());
    }
}
