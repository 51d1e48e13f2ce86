//! Teams (`[[robots]]`): robots never overlap a wall or one another, whatever their controller
//! does; a sample is the same every time it runs; the lockstep evaluator agrees with the scalar
//! one on a team (its `tasks()` include one); and a file whose team cannot be built is refused
//! before any evaluation, naming the key.

use hevo_sim_core::{BatchEvaluator, ControllerFile, Pose, Sample};
use hevo_sim_core::{Evaluator, InputGroup, Scenario, SimRng, TaskConfig};
use proptest::prelude::*;
use rand::SeedableRng;
use std::sync::Arc;

/// A walled arena with two pillars, the focal robot and eight more: five running copies of the
/// evaluated controller, two wandering, one standing still.
pub(crate) const TEAM_ARENA: &str = r#"
schema = "hevo.scenario/1"
name = "team_arena"
max_cycles = 300
end_on_collision = false

[world]
solids = [
    [-0.65, -0.65, 0.65, -0.6],
    [-0.65, 0.6, 0.65, 0.65],
    [-0.65, -0.6, -0.6, 0.6],
    [0.6, -0.6, 0.65, 0.6],
    [-0.2, -0.05, -0.1, 0.05],
    [0.15, 0.2, 0.25, 0.3],
]

[regions]
arena = { rect = [-0.55, -0.55, 0.55, 0.55] }
corner = { rect = [0.2, -0.55, 0.55, -0.2] }

[place]
at = "arena"
anywhere = true
facing = "up"
turn_deg = [-180, 180]

[[robots]]
name = "copies"
count = 5
region = "arena"
controller = "evolved"

[[robots]]
name = "wanderers"
count = 2
region = "arena"
controller = "wander"

[[robots]]
name = "post"
count = 1
region = "corner"
controller = "fixed"

[end]
solved = "team gathered"
near_m = 0.15

[fitness]
solved = "2 + time_bonus"
otherwise = "1 + team.spread * -1.25 + team.in corner"

[descriptor]
quantities = ["team.spread", "team.nearest"]
"#;

pub(crate) fn team_task() -> TaskConfig {
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(TEAM_ARENA, "team_arena.toml").expect("the team arena compiles"),
    ))
}

/// A primitive on the IR ring with random genes: it drives anywhere, into walls and robots.
fn random_controller(rng: &mut SimRng) -> (ControllerFile, Vec<f32>) {
    crate::support::random_primitive(rng, vec![InputGroup::IR])
}

fn overlaps(a: &Pose, b: &Pose, radius: f32) -> bool {
    a.distance_to(b.position()) < 2.0 * radius - 1e-5
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// At the start of every cycle (after the last cycle's moves), no robot's disc touches a
    /// solid and no two robots' discs overlap.
    #[test]
    fn robots_never_overlap_walls_or_each_other(case_seed in any::<u64>(), seed in 0u64..1000) {
        let task = team_task();
        let rng = &mut SimRng::seed_from_u64(case_seed);
        let (template, genes) = random_controller(rng);
        let batch = BatchEvaluator::new(template, task.clone()).expect("valid");
        let mut controller = batch.controller(Some(&genes)).expect("genes fit");
        let evaluator = batch.evaluator();
        let radius = task.params.robot.radius;
        let scene = evaluator.environment(Sample::seeded(seed)).scene;
        let trace = evaluator.evaluate_traced(&mut controller, Sample::seeded(seed));
        prop_assert_eq!(trace.cycles[0].team.len(), 8);
        for (cycle_idx, cycle) in trace.cycles.iter().enumerate() {
            let robots: Vec<&Pose> = std::iter::once(&cycle.robot).chain(&cycle.team).collect();
            for (idx, robot) in robots.iter().enumerate() {
                prop_assert!(
                    !scene.disc_hits(robot.position(), radius),
                    "cycle {}: robot {} touches a solid at {:?}", cycle_idx, idx, robot
                );
                for (other_idx, other) in robots.iter().enumerate().skip(idx + 1) {
                    prop_assert!(
                        !overlaps(robot, other, radius),
                        "cycle {}: robots {} and {} overlap", cycle_idx, idx, other_idx
                    );
                }
            }
        }
    }
}

/// A trace's final team poses are where the team stands after the last cycle's moves: where
/// the same sample, one cycle longer, has them at the start of that cycle.
#[test]
fn the_final_team_poses_follow_the_last_cycle() {
    let rng = &mut SimRng::seed_from_u64(9);
    let (template, genes) = random_controller(rng);
    let traced = |max_cycles: u32| {
        let mut task = team_task();
        task.max_cycles = Some(max_cycles);
        let batch = BatchEvaluator::new(template.clone(), task).expect("valid");
        let mut controller = batch.controller(Some(&genes)).expect("genes fit");
        batch
            .evaluator()
            .evaluate_traced(&mut controller, Sample::seeded(4))
    };
    let (short, long) = (traced(40), traced(41));
    assert_eq!((short.cycles.len(), long.cycles.len()), (40, 41));
    assert_eq!(short.final_team.len(), 8);
    assert_eq!(short.final_team, long.cycles[40].team);
    assert_eq!(short.final_robot, long.cycles[40].robot);
    // Someone moved in the last cycle: the last recorded poses are not the final ones.
    assert_ne!(short.final_team, short.cycles[39].team);
}

#[test]
fn a_team_sample_is_the_same_every_time_and_on_every_evaluator() {
    let task = team_task();
    let rng = &mut SimRng::seed_from_u64(5);
    let (template, genes) = random_controller(rng);
    let scalar = crate::support::outcomes_on_every_evaluator(&template, &genes, &task);
    // The team moved: its robots' spread is not the same in every sample.
    let spreads: Vec<f32> = scalar.iter().map(|outcome| outcome.descriptor[0]).collect();
    assert!(spreads.iter().any(|&s| s != spreads[0]), "{spreads:?}");
    assert!(spreads.iter().all(|&s| s > 0.0 && s < 0.8), "{spreads:?}");
}

#[test]
fn the_evolved_copies_move_and_scripted_robots_keep_to_their_script() {
    let task = team_task();
    let rng = &mut SimRng::seed_from_u64(9);
    let (template, genes) = random_controller(rng);
    let batch = BatchEvaluator::new(template, task).expect("valid");
    let mut controller = batch.controller(Some(&genes)).expect("genes fit");
    let trace = batch
        .evaluator()
        .evaluate_traced(&mut controller, Sample::seeded(3));
    let (first, last) = (
        &trace.cycles[0].team,
        &trace.cycles[trace.cycles.len() - 1].team,
    );
    let moved: Vec<bool> = first
        .iter()
        .zip(last)
        .map(|(a, b)| a.distance_to(b.position()) > 1e-4)
        .collect();
    assert!(
        moved[..5].iter().any(|&m| m),
        "no evolved copy moved: {moved:?}"
    );
    assert!(moved[5] || moved[6], "no wanderer moved: {moved:?}");
    assert!(!moved[7], "the fixed robot moved");
}

/// The refusal of the team arena with `from` replaced by `to`.
fn refusal(from: &str, to: &str) -> String {
    crate::support::refusal_of(TEAM_ARENA, from, to)
}

#[test]
fn a_team_that_cannot_be_built_is_refused_naming_the_key() {
    for (from, to, wanted) in [
        ("count = 5", "count = 0", "robots[0].count"),
        ("count = 5", "count = 61", "at most 64"),
        (
            "region = \"corner\"",
            "region = \"nowhere\"",
            "robots[2].region",
        ),
        (
            "controller = \"wander\"",
            "controller = \"dance\"",
            "robots[1].controller",
        ),
        (
            "controller = \"wander\"",
            "controller = \"follow\"",
            "not evolved, wander, fixed or { file = \"PATH\" }",
        ),
        ("name = \"post\"", "name = \"copies\"", "robots[2].name"),
        ("name = \"post\"", "name = \"a post\"", "not a group name"),
        // 40 robots of radius 0.037 m cannot all fit clear of one another in 0.35 m x 0.35 m.
        (
            "count = 1\nregion = \"corner\"",
            "count = 40\nregion = \"corner\"",
            "no room",
        ),
    ] {
        let error = refusal(from, to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
    let alone = "otherwise = \"approach room.exit\"";
    let error = Scenario::parse(
        &TEAM_ARENA
            .split("[[robots]]")
            .next()
            .map(|head| {
                format!("{head}[end]\nsolved = \"always\"\n[fitness]\nsolved = \"team.spread\"\n")
            })
            .unwrap(),
        "alone.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(error.contains("needs other robots"), "{alone}: {error}");
}

/// A robot standing 0.1 m (centre to centre) ahead of the focal robot, in an open arena.
const ONE_AHEAD: &str = r#"
schema = "hevo.scenario/1"
name = "one_ahead"
max_cycles = 3
sensors = ["ir"]

[world]
solids = [[-1.05, -1.05, 1.05, -1.0], [-1.05, 1.0, 1.05, 1.05], [-1.05, -1.0, -1.0, 1.0], [1.0, -1.0, 1.05, 1.0]]

[regions]
here = { rect = [-0.01, -0.01, 0.01, 0.01] }
ahead = { rect = [-0.001, 0.099, 0.001, 0.101] }

[place]
at = "here"
facing = "up"

[[robots]]
name = "post"
count = 1
region = "ahead"
controller = "fixed"

[end]
solved = "always"

[fitness]
solved = "1"
otherwise = "0"
"#;

#[test]
fn the_ir_ring_sees_another_robot_ahead_and_nothing_without_it() {
    let read = |text: &str| {
        let task = TaskConfig::from_scenario(Arc::new(Scenario::parse(text, "t.toml").unwrap()));
        let evaluator = Evaluator::new(task).expect("valid");
        let trace =
            evaluator.evaluate_traced(&mut crate::support::Fixed::still(), Sample::seeded(0));
        trace.cycles[0].frame.values(InputGroup::IR).to_vec()
    };
    let with_robot = read(ONE_AHEAD);
    let alone = read(&ONE_AHEAD.replace(
        "[[robots]]\nname = \"post\"\ncount = 1\nregion = \"ahead\"\ncontroller = \"fixed\"\n",
        "",
    ));
    assert!(alone.iter().all(|&v| v == 0.0), "alone: {alone:?}");
    // The gap between the bodies is 0.1 - 2 x 0.037 = 0.026 m: the front sensors read it
    // (the IR's range is 0.12 m), the rear ones do not.
    let front = with_robot[0].max(with_robot[with_robot.len() - 1]);
    assert!(front > 0.3, "{with_robot:?}");
    assert!(
        with_robot.iter().filter(|&&v| v > 0.0).count() < with_robot.len(),
        "{with_robot:?}"
    );
}
