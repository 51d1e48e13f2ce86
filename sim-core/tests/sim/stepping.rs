//! An episode stepped from outside against the evaluator: a controller stepped by the test,
//! its outputs given to an `Episode` cycle by cycle, must see the frames the evaluator's trace
//! records and end with the evaluator's outcome, fitness to the bit (what a Python environment
//! driven by a controller's own outputs relies on). Node use and the root's choices are the
//! controller tree's, which an episode driven from outside does not have: on a scenario whose
//! fitness counts the root's choices (phases), only the rest is compared.

use hevo_sim_core::{Controller, Ending, N_FLAT, SimRng, TaskConfig, mix64};
use hevo_sim_core::{ControllerFile, Episode, Evaluator, Outcome, Policy, Sample, StepError};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};

use crate::lockstep::{random_root, tasks};

/// Steps `controller` through `sample` as an episode driven from outside: the frames it read
/// and the outcome.
fn drive(
    evaluator: &Evaluator,
    controller: &mut Controller,
    sample: Sample,
) -> (Vec<[f32; N_FLAT]>, Outcome) {
    let dt = evaluator.task().params.robot.cycle_seconds;
    controller.reset();
    let mut episode = Episode::new(evaluator, sample);
    let mut frames = Vec::new();
    loop {
        frames.push(episode.frame().inputs);
        let wheels = Policy::step(controller, episode.frame(), dt);
        if episode
            .step(wheels)
            .expect("a running episode steps")
            .is_some()
        {
            break;
        }
    }
    let outcome = episode
        .into_outcome()
        .expect("an ended episode has its outcome");
    (frames, outcome)
}

fn assert_same_sample(task: &TaskConfig, controller: &mut Controller, sample: Sample, what: &str) {
    let evaluator = Evaluator::new(task.clone()).expect("valid task");
    let trace = evaluator.evaluate_traced(controller, sample);
    let (frames, outcome) = drive(&evaluator, controller, sample);
    let traced: Vec<[f32; N_FLAT]> = trace
        .cycles
        .iter()
        .map(|cycle| cycle.frame.inputs)
        .collect();
    assert!(frames == traced, "{what}: the frames differ");
    let expected = trace.outcome;
    assert_eq!(outcome.ending, expected.ending, "{what}: ending");
    assert_eq!(outcome.cycles, expected.cycles, "{what}: cycles");
    assert_eq!(outcome.solved, expected.solved, "{what}: solved");
    assert_eq!(outcome.collided, expected.collided, "{what}: collided");
    assert_eq!(outcome.stage, expected.stage, "{what}: stage");
    assert_eq!(outcome.variant, expected.variant, "{what}: variant");
    if !task.scenario.has_phases() {
        assert_eq!(
            outcome.fitness.to_bits(),
            expected.fitness.to_bits(),
            "{what}: fitness {} vs {}",
            outcome.fitness,
            expected.fitness
        );
        assert_eq!(
            outcome.descriptor, expected.descriptor,
            "{what}: descriptor"
        );
    }
    // Driven from outside, nothing counts nodes or choices.
    assert!(
        outcome.node_use.active_cycles.is_empty(),
        "{what}: node use"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn an_episode_driven_by_a_controller_ends_as_its_evaluation(
        case_seed in any::<u64>(),
        task_pick in any::<usize>(),
        max_cycles in prop_oneof![Just(None), (1u32..400).prop_map(Some)],
        end_on_collision in any::<bool>(),
    ) {
        let rng = &mut SimRng::seed_from_u64(case_seed);
        // A team's evolved robots run the controller's copies, which an episode driven from
        // outside has none of: they stand still there (`Episode::new`).
        let all: Vec<_> = tasks()
            .into_iter()
            .filter(|task| !task.scenario.has_evolved_team())
            .collect();
        let mut task = all[task_pick % all.len()].clone();
        task.max_cycles = max_cycles.map(|limit| limit.min(task.max_cycles()));
        task.end_on_collision = end_on_collision;
        let depth = rng.random_range(0..3);
        let file = ControllerFile::new(random_root(&task, depth, rng));
        let mut controller = Controller::new(&file, None).expect("a complete controller");
        let n_variants = task.scenario.n_variants();
        let sample = Sample {
            seed: mix64(case_seed),
            variant: (rng.random_range(0..2) == 0).then(|| rng.random_range(0..n_variants)),
        };
        assert_same_sample(
            &task,
            &mut controller,
            sample,
            &format!("{} (case seed {case_seed})", task.name()),
        );
    }
}

/// The shipped maze controller on the maze, every light configuration: the samples the Python
/// environment's own test replays.
#[test]
fn the_shipped_maze_controller_ends_as_its_evaluation() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../controllers/solve_maze.json"
    ))
    .expect("controllers/solve_maze.json");
    let file = ControllerFile::from_json_str(&text).expect("a controller file");
    let mut controller = Controller::new(&file, None).expect("a complete controller");
    let task = TaskConfig::shipped("solve_maze").expect("shipped");
    for variant in 0..task.scenario.n_variants() {
        let sample = Sample {
            seed: 4,
            variant: Some(variant),
        };
        assert_same_sample(
            &task,
            &mut controller,
            sample,
            &format!("variant {variant}"),
        );
    }
}

#[test]
fn an_episode_clips_wheels_and_refuses_nan_and_steps_after_its_end() {
    let task = TaskConfig {
        max_cycles: Some(30),
        ..TaskConfig::shipped("exit_room").expect("shipped")
    };
    let evaluator = Evaluator::new(task).expect("valid task");
    let sample = Sample::seeded(3);
    let run = |wheels: [f32; 2]| {
        let mut episode = Episode::new(&evaluator, sample);
        let mut frames = Vec::new();
        while episode.step(wheels).expect("steps").is_none() {
            frames.push(episode.frame().inputs);
        }
        (frames, episode.into_outcome().expect("ended"))
    };
    // Beyond the range is the range's end.
    assert_eq!(run([1.7, 1.0]), run([1.0, 1.0]));
    assert_eq!(run([-3.0, 0.25]), run([0.0, 0.25]));
    assert_ne!(
        run([1.0, 1.0]),
        run([0.0, 0.0]),
        "the wheels do move the robot"
    );

    let mut episode = Episode::new(&evaluator, sample);
    let error = episode.step([f32::NAN, 0.5]).unwrap_err();
    assert!(
        matches!(error, StepError::NotFinite { wheel: 0, value } if value.is_nan()),
        "NaN refused: {error:?}"
    );
    let error = episode.step([0.5, f32::INFINITY]).unwrap_err();
    assert_eq!(
        error.to_string(),
        "wheel 1 (right) is inf: wheel outputs must be finite"
    );
    assert_eq!(episode.cycles(), 1, "a refused step runs no cycle");
    while episode.step([0.5, 0.5]).expect("steps").is_none() {}
    assert_eq!(episode.ending(), Some(Ending::Timeout));
    assert_eq!(episode.cycles(), 30);
    let error = episode.step([0.5, 0.5]).unwrap_err();
    assert_eq!(
        error.to_string(),
        "the episode ended (Timeout) after 30 cycles; start a new one"
    );
    let outcome = episode.into_outcome().expect("ended");
    assert_eq!((outcome.cycles, outcome.ending), (30, Ending::Timeout));
}
