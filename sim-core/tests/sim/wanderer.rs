//! The wandering teammate of `scenarios/examples/find_wanderer.toml`: it walks on its own
//! (never into a solid, judged by the robot's own disc test), its walk is the same for the same
//! seed and differs between seeds, and once the robot meets it, it stops wandering and
//! follows.

use hevo_sim_core::Pose;
use hevo_sim_core::Scene;
use hevo_sim_core::{Ending, Evaluator, Sample, TaskConfig, Trace};

use crate::support::{Fixed, example_task};

fn task() -> TaskConfig {
    example_task("find_wanderer")
}

fn traced(task: &TaskConfig, seed: u64) -> Trace {
    Evaluator::new(task.clone())
        .unwrap()
        .evaluate_traced(&mut Fixed::still(), Sample::seeded(seed))
}

fn teammate_path(trace: &Trace) -> Vec<Pose> {
    trace.cycles.iter().map(|c| c.teammate.unwrap()).collect()
}

#[test]
fn the_wanderer_moves_and_never_touches_a_solid() {
    let task = task();
    for seed in 0..8 {
        let trace = traced(&task, seed);
        let path = teammate_path(&trace);
        assert_eq!(path.len(), trace.cycles.len());
        let scene = Scene::new(trace.rects.clone(), task.params.query_margin());
        for (cycle, pose) in path.iter().enumerate() {
            assert!(
                !scene.disc_hits(pose.position(), task.params.robot.radius),
                "seed {seed}: the wanderer touches a solid at cycle {cycle}: {pose:?}"
            );
        }
        // It covers ground: at half the top speed for most of the sample, far more than a
        // cell's width in all, and it leaves its den.
        let travelled: f32 = path
            .windows(2)
            .map(|w| w[0].distance_to(w[1].position()))
            .sum();
        assert!(travelled > 1.0, "seed {seed}: travelled {travelled} m");
        let moved_off = path
            .iter()
            .map(|p| p.distance_to(path[0].position()))
            .fold(0.0f32, f32::max);
        assert!(
            moved_off > 0.3,
            "seed {seed}: at most {moved_off} m from the den"
        );
        // Its steps are never longer than half the robot's top speed allows.
        let longest = path
            .windows(2)
            .map(|w| w[0].distance_to(w[1].position()))
            .fold(0.0f32, f32::max);
        let allowed = 0.5 * task.params.robot.v_max * task.params.robot.cycle_seconds;
        assert!(longest <= allowed * 1.0001 + 1e-6, "a step of {longest} m");
    }
}

#[test]
fn the_walk_is_fixed_by_the_seed() {
    let task = task();
    let a = teammate_path(&traced(&task, 5));
    let b = teammate_path(&traced(&task, 5));
    assert_eq!(a, b);
    let c = teammate_path(&traced(&task, 6));
    assert_ne!(a, c);
}

#[test]
fn a_met_wanderer_follows_and_the_sample_is_solved() {
    let mut task = task();
    // With the near-robot range larger than the room, the wanderer is met in the first cycle
    // wherever it is.
    task.params.robot.near_robot_range = 5.0;
    let evaluator = Evaluator::new(task.clone()).unwrap();
    let outcome = evaluator.evaluate(&mut Fixed::straight(), Sample::seeded(1));
    assert_eq!(outcome.ending, Ending::Solved);
    assert_eq!(outcome.cycles, 1);
    // Solved in the first cycle: 1 plus the share of cycles left.
    let expected = 1.0 + (1000.0 - 1.0) / 1000.0;
    assert!(
        (outcome.fitness - expected).abs() < 1e-6,
        "{}",
        outcome.fitness
    );
}

#[test]
fn a_robot_that_stands_still_scores_its_closest_approach() {
    let task = task();
    let mut evaluator_task = task.clone();
    evaluator_task.end_on_collision = false;
    let trace = traced(&evaluator_task, 2);
    let path = teammate_path(&trace);
    let start = trace.cycles[0].robot.position();
    let first = path[0].distance_to(start);
    let closest = path
        .iter()
        .map(|p| p.distance_to(start))
        .fold(f32::INFINITY, f32::min);
    if trace.outcome.ending == Ending::Timeout {
        // `approach teammate / 2`: half the share of the first distance the closest covered;
        // the judge also sees the pose after the last move, so allow for one more step.
        let expected = 0.5 * (first - closest) / first;
        let step = 0.5 * task.params.robot.v_max * task.params.robot.cycle_seconds;
        assert!(
            trace.outcome.fitness >= expected - 1e-6
                && trace.outcome.fitness <= expected + 0.5 * step / first + 1e-6,
            "fitness {} against {expected}",
            trace.outcome.fitness
        );
        assert!(trace.outcome.fitness > 0.0);
    } else {
        assert_eq!(trace.outcome.ending, Ending::Solved);
        assert!(closest < task.params.robot.near_robot_range + 0.05);
    }
}
