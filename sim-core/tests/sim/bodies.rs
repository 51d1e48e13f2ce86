//! Movers and boxes (`[[movers]]`, `[[boxes]]`): however the robots drive, no robot ever
//! overlaps a wall, another robot, a mover or a box, and no box a wall, a mover or another
//! box; a mover waits for a robot in its way and a robot's move into a mover is a collision;
//! a robot driving into a box pushes it; a sample is the same every time and on both
//! evaluators (the lockstep property test draws from both shipped scenarios too); and a file
//! whose movers or boxes cannot work is refused before any evaluation, naming the key.

use hevo_sim_core::{BatchEvaluator, Ending, Evaluator, InputGroup, Sample, Scenario};
use hevo_sim_core::{SimRng, TaskConfig, Trace};
use proptest::prelude::*;
use rand::SeedableRng;
use std::sync::Arc;

use crate::support::signed_distance;

/// The shipped crossing scenario: three robots, three movers.
const CROSSING: &str = include_str!("../../../scenarios/swarm/crossing.toml");

/// The shipped box-pushing scenario: four robots, four boxes.
const BOX_PUSHING: &str = include_str!("../../../scenarios/swarm/box_pushing.toml");

fn task(text: &str) -> TaskConfig {
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(text, "bodies.toml").expect("the scenario compiles"),
    ))
}

pub(crate) fn crossing_task() -> TaskConfig {
    task(CROSSING)
}

pub(crate) fn box_pushing_task() -> TaskConfig {
    task(BOX_PUSHING)
}

fn apart(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Every cycle of `trace` (and its end): every robot clear of the walls, of each other and of
/// every mover and box; every box clear of the walls, of the movers and of each other.
/// Overlap is checked with 0.1 mm to spare for the f32 rounding of the centres.
fn assert_nothing_overlaps(trace: &Trace, radius: f32) -> Result<(), TestCaseError> {
    const SLACK: f32 = 1e-4;
    let n_movers = trace.movers.len();
    let body_radii: Vec<f32> = trace
        .movers
        .iter()
        .map(|mover| mover.radius)
        .chain(trace.boxes.iter().map(|one| one.radius))
        .collect();
    let ends: Vec<[f32; 2]> = trace
        .movers
        .iter()
        .map(|mover| mover.end)
        .chain(trace.boxes.iter().map(|one| one.end))
        .collect();
    let states = trace
        .cycles
        .iter()
        .map(|cycle| {
            let robots: Vec<[f32; 2]> = std::iter::once(cycle.robot.position())
                .chain(cycle.team.iter().map(|pose| pose.position()))
                .collect();
            (robots, cycle.bodies.clone())
        })
        .chain(std::iter::once((
            std::iter::once(trace.final_robot.position())
                .chain(trace.final_team.iter().map(|pose| pose.position()))
                .collect(),
            ends,
        )));
    for (cycle, (robots, bodies)) in states.enumerate() {
        prop_assert_eq!(bodies.len(), body_radii.len());
        for (idx, &robot) in robots.iter().enumerate() {
            for rect in &trace.rects {
                prop_assert!(
                    signed_distance(robot, rect) >= radius - SLACK,
                    "cycle {}",
                    cycle
                );
            }
            for &other in &robots[idx + 1..] {
                prop_assert!(
                    apart(robot, other) >= 2.0 * radius - SLACK,
                    "cycle {}",
                    cycle
                );
            }
            for (&body, &body_radius) in bodies.iter().zip(&body_radii) {
                prop_assert!(
                    apart(robot, body) >= radius + body_radius - SLACK,
                    "cycle {}: robot {} at {:?}, body at {:?}",
                    cycle,
                    idx,
                    robot,
                    body
                );
            }
        }
        for (idx, (&body, &body_radius)) in
            bodies.iter().zip(&body_radii).enumerate().skip(n_movers)
        {
            for rect in &trace.rects {
                prop_assert!(
                    signed_distance(body, rect) >= body_radius - SLACK,
                    "cycle {}",
                    cycle
                );
            }
            // Every other body: the movers and the other boxes.
            for (other_idx, (&other, &other_radius)) in bodies.iter().zip(&body_radii).enumerate() {
                if other_idx != idx {
                    prop_assert!(apart(body, other) >= body_radius + other_radius - SLACK);
                }
            }
        }
    }
    Ok(())
}

/// A primitive on the IR ring (and the light sensors where the scenario has lights) with
/// random genes: it drives anywhere, into walls, robots, movers and boxes.
fn random_controller(rng: &mut SimRng) -> (hevo_sim_core::ControllerFile, Vec<f32>) {
    crate::support::random_primitive(rng, vec![InputGroup::IR])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// However the robots drive, nothing overlaps anything, cycle after cycle.
    #[test]
    fn robots_movers_and_boxes_never_overlap(
        case_seed in any::<u64>(),
        seed in 0u64..1000,
        pushing in any::<bool>(),
    ) {
        let task = if pushing { box_pushing_task() } else { crossing_task() };
        let radius = task.params.robot.radius;
        let rng = &mut SimRng::seed_from_u64(case_seed);
        let (template, genes) = random_controller(rng);
        let batch = BatchEvaluator::new(template, task).expect("valid");
        let mut controller = batch.controller(Some(&genes)).expect("genes fit");
        let trace = batch.evaluator().evaluate_traced(&mut controller, Sample::seeded(seed));
        assert_nothing_overlaps(&trace, radius)?;
    }
}

#[test]
fn a_sample_with_movers_or_boxes_is_the_same_every_time_and_on_every_evaluator() {
    for task in [crossing_task(), box_pushing_task()] {
        let rng = &mut SimRng::seed_from_u64(5);
        let (template, genes) = random_controller(rng);
        crate::support::outcomes_on_every_evaluator(&template, &genes, &task);
    }
}

/// One robot facing east in an arena, with a box or a mover ahead of it.
const AHEAD: &str = r#"
schema = "hevo.scenario/1"
name = "ahead"
max_cycles = 60
end_on_collision = false
sensors = ["ir"]

[world]
solids = [[-1.05, -1.05, 1.05, -1.0], [-1.05, 1.0, 1.05, 1.05], [-1.05, -1.0, -1.0, 1.0], [1.0, -1.0, 1.05, 1.0]]

[regions]
here = { rect = [-0.001, -0.001, 0.001, 0.001] }
crate = { rect = [0.199, -0.001, 0.201, 0.001] }
east = { rect = [0.3, -0.5, 0.9, 0.5] }

[place]
at = "here"
facing = "right"

[[boxes]]
name = "crate"
count = 1
region = "crate"
radius = 0.05

[end]
solved = "boxes in east"

[fitness]
solved = "1 + boxes.in east"
otherwise = "boxes.in east"
"#;

#[test]
fn a_robot_driving_into_a_box_pushes_it_ahead_and_the_ir_sees_it() {
    let evaluator = Evaluator::new(task(AHEAD)).expect("valid");
    let trace =
        evaluator.evaluate_traced(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    // Pushed along the line of centres, east (the wheels' noise turns the robot a little, so
    // the box slides aside in the end).
    let crate_ = trace.boxes[0];
    assert!(crate_.end[0] > crate_.start[0] + 0.05, "{crate_:?}");
    let pushed = trace
        .cycles
        .windows(2)
        .filter(|pair| pair[1].bodies[0] != pair[0].bodies[0])
        .count();
    assert!(pushed > 5, "{pushed}");
    // Before the push the front sensors read the box, and no move was undone.
    let front = trace.cycles[0].frame.inputs[0];
    let seen = trace
        .cycles
        .iter()
        .any(|cycle| cycle.frame.inputs[0] > front && cycle.frame.inputs[3] > 0.0);
    assert!(seen, "the IR never saw the box");
    assert!(trace.cycles.iter().all(|cycle| !cycle.collided));
}

#[test]
fn a_box_against_a_wall_stops_the_robot_and_a_mover_waits_for_it() {
    // The box right against the east wall: the robot's moves into it are undone.
    let stuck = AHEAD
        .replace(
            "crate = { rect = [0.199, -0.001, 0.201, 0.001] }",
            "crate = { rect = [0.949, -0.001, 0.95, 0.001] }",
        )
        .replace("max_cycles = 60", "max_cycles = 200");
    let evaluator = Evaluator::new(task(&stuck)).expect("valid");
    let trace = evaluator.evaluate_traced(
        &mut crate::support::Fixed::new([1.0, 1.0], 200),
        Sample::seeded(0),
    );
    assert!(trace.cycles.iter().any(|cycle| cycle.collided));
    assert_eq!(trace.boxes[0].end, trace.boxes[0].start);

    // A mover running east along the x axis towards the robot standing at the origin: it
    // stops short of the robot, touching it, and waits there.
    let mover = |path: &str, speed: f32| {
        AHEAD
            .replace(
                "[[boxes]]\nname = \"crate\"\ncount = 1\nregion = \"crate\"\nradius = 0.05\n",
                &format!(
                    "[[movers]]\nname = \"cart\"\nradius = 0.05\npath = {path}\nspeed = {speed}\n\
                     mode = \"back_and_forth\"\n"
                ),
            )
            .replace("solved = \"boxes in east\"", "solved = \"in east\"")
            .replace("solved = \"1 + boxes.in east\"", "solved = \"1\"")
            .replace("otherwise = \"boxes.in east\"", "otherwise = \"0\"")
    };
    let waiting = mover("[[-0.5, 0.0], [0.5, 0.0]]", 0.1);
    let evaluator = Evaluator::new(task(&waiting)).expect("valid");
    let trace = evaluator.evaluate_traced(&mut crate::support::Fixed::still(), Sample::seeded(0));
    let mover_x: Vec<f32> = trace
        .cycles
        .iter()
        .map(|cycle| cycle.bodies[0][0])
        .collect();
    let closest = -(0.05 + trace.final_robot.x.abs() + 0.037);
    assert!(mover_x.iter().all(|&x| x <= closest + 1e-4), "{mover_x:?}");
    assert!(
        trace.movers[0].end[0] > closest - 0.011,
        "{:?}",
        trace.movers[0]
    );
    assert!(trace.cycles.iter().all(|cycle| !cycle.collided));

    // A mover nearly parked across the robot's way: driving into it is a collision, which
    // ends a sample that ends on collisions.
    let parked = mover("[[0.15, -0.01], [0.15, 0.01]]", 0.01);
    let evaluator = Evaluator::new(task(&parked)).expect("valid");
    let trace =
        evaluator.evaluate_traced(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    assert!(trace.cycles.iter().any(|cycle| cycle.collided));
    assert!(trace.final_robot.x < 0.1, "{:?}", trace.final_robot);
    let ending = parked.replace("end_on_collision = false", "end_on_collision = true");
    let evaluator = Evaluator::new(task(&ending)).expect("valid");
    let outcome = evaluator.evaluate(&mut crate::support::Fixed::straight(), Sample::seeded(0));
    assert_eq!(outcome.ending, Ending::Collision);
}

/// The refusal of the crossing scenario with `from` replaced by `to`.
fn refusal(from: &str, to: &str) -> String {
    crate::support::refusal_of(CROSSING, from, to)
}

#[test]
fn movers_and_boxes_that_cannot_work_are_refused_naming_the_key() {
    for (from, to, wanted) in [
        ("radius = 0.05", "radius = 0.6", "movers[0].radius"),
        ("radius = 0.05", "radius = nan", "movers[0].radius"),
        ("speed = 0.06", "speed = 0.0", "movers[0].speed"),
        ("speed = 0.06", "speed = 0.3", "movers[0].speed"),
        ("start = 0.5", "start = 1.0", "movers[1].start"),
        ("mode = \"loop\"", "mode = \"circle\"", "movers[2].mode"),
        (
            "path = [[0.05, -0.32], [0.05, 0.32]]",
            "path = [[0.05, -0.32]]",
            "movers[1].path",
        ),
        (
            "path = [[0.05, -0.32], [0.05, 0.32]]",
            "path = [[0.05, -0.32], [0.05, -0.32]]",
            "movers[1].path[1]",
        ),
        (
            "path = [[0.05, -0.32], [0.05, 0.32]]",
            "path = [[0.05, -0.32], [0.05, 0.32], [0.05, 90.0]]",
            "movers[1].path[2]",
        ),
        // Outside the walls altogether, and a leg through the south wall.
        (
            "path = [[0.05, -0.32], [0.05, 0.32]]",
            "path = [[0.05, -0.32], [0.05, 0.32], [0.9, 0.32]]",
            "movers[1].path[2]",
        ),
        (
            "path = [[0.05, -0.32], [0.05, 0.32]]",
            "path = [[0.05, -0.32], [0.05, 0.32], [0.1, 0.38]]",
            "movers[1].path[1]",
        ),
        (
            "path = [[-0.2, -0.32], [-0.2, 0.32]]",
            "path = [[-0.2, -0.38], [-0.2, 0.32]]",
            "movers[0].path[0]",
        ),
        ("name = \"cart_b\"", "name = \"cart_a\"", "movers[1].name"),
    ] {
        let error = refusal(from, to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
    // A mover starting on the robot's fixed start.
    let on_start = AHEAD.replace(
        "[[boxes]]",
        "[[movers]]\nname = \"cart\"\nradius = 0.05\npath = [[0.05, 0.0], [0.5, 0.0]]\n\
         speed = 0.1\n\n[[boxes]]",
    );
    let error = crate::support::refusal_of(&on_start, "max_cycles = 60", "max_cycles = 61");
    assert!(
        error.contains("`place`") && error.contains("on mover 'cart'"),
        "{error}"
    );
    // Seventeen movers.
    let mover = CROSSING
        .split("\n[[movers]]\n")
        .nth(1)
        .expect("a mover")
        .to_string();
    let many: String = (0..17)
        .map(|idx| {
            format!(
                "[[movers]]\n{}\n",
                mover.replace("cart_a", &format!("m{idx}"))
            )
        })
        .collect();
    let error = refusal("[end]", &format!("{many}[end]"));
    assert!(error.contains("at most 16"), "{error}");

    // Boxes: their keys, and their terms in a scenario without any.
    for (from, to, wanted) in [
        ("radius = 0.05", "radius = 0.2", "boxes[0].radius"),
        ("count = 4", "count = 0", "boxes[0].count"),
        ("count = 4", "count = 33", "at most 32"),
        (
            "region = \"field\"",
            "region = \"nowhere\"",
            "boxes[0].region",
        ),
        // Forty boxes in a small field: no room for them all.
        (
            "field = { rect = [-0.15, -0.45, 0.2, 0.45] }",
            "field = { rect = [-0.15, -0.05, -0.05, 0.05] }",
            "boxes[0].region",
        ),
    ] {
        let error = crate::support::refusal_of(BOX_PUSHING, from, to);
        assert!(error.contains(wanted), "{to}: {error}");
    }
    let no_boxes = BOX_PUSHING.replace(
        "[[boxes]]\nname = \"crates\"\ncount = 4\nregion = \"field\"\nradius = 0.05\n",
        "",
    );
    let error = Scenario::parse(&no_boxes, "none.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("end.solved") && error.contains("'boxes in dock': needs boxes ([[boxes]])"),
        "{error}"
    );
    let no_boxes = no_boxes.replace("solved = \"boxes in dock\"", "solved = \"always\"");
    let error = Scenario::parse(&no_boxes, "none.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("fitness.otherwise") && error.contains("needs boxes"),
        "{error}"
    );
    // Movers and boxes do not go with a [teammate].
    let wanderer = crate::support::example("find_wanderer");
    let error = crate::support::refusal_of(
        wanderer,
        "\n[end]",
        "\n[[movers]]\nname = \"cart\"\nradius = 0.05\npath = [[0.0, 0.0], [0.1, 0.0]]\n\
         speed = 0.1\n\n[end]",
    );
    assert!(error.contains("movers"), "{error}");
}
