//! Properties of the simulated world that must hold whatever drives the robot: the robot never
//! overlaps a wall or obstacle (checked with our own geometry, not the simulator's), a
//! collision undoes the whole move, one (policy, task, sample) always gives the same outcome
//! and trace while different seeds give different samples, every start pose is free, and a
//! sample's environment depends on its seed only, never on the policy. The policies are random
//! piecewise-constant wheel commands drawn by proptest, plus the scripted reference policies.
//! The IR sensors must read an empty cone as 0 and never read a nearer wall as farther, with
//! every measured curve (SPEC section 2: "1 at contact, 0 at 12 cm or beyond"). The counts of
//! how long and how often each controller node drove match a known switching schedule.
//! The same holds in worlds of one's own: random maps (a random walk opens the cells; a map
//! compiles exactly when its goal can be reached from its entrance, by a search done here),
//! the paper's room over random generator ranges, and generated corridors over random ranges,
//! alone or joined under a room, whose goal the robot's body can always reach (and whose
//! fitness is a number even when the corridor is a single cell).
//! Case counts keep the file well under half a minute in release.

use hevo_sim_core::IrMapping;
use hevo_sim_core::N_IR;
use hevo_sim_core::Pose;
use hevo_sim_core::Rect;
use hevo_sim_core::{Evaluator, Policy, Sample, TaskConfig, Trace};
use hevo_sim_core::{IR_CURVE_NAMES, IrModel, IrSensorSetup, N_MEASURED_IR_CURVES};
use hevo_sim_core::{InputGroup, SensorFrame};
use hevo_sim_core::{SHIPPED_NAMES, Scenario};
use hevo_sim_core::{Stream, stream_rng};
use proptest::prelude::*;

use crate::support::{Scripted, signed_distance};

/// Drives by a fixed list of (cycles, left output, right output) segments, repeated.
#[derive(Debug, Clone)]
struct Wander {
    segments: Vec<(u32, [f32; 2])>,
    segment: usize,
    cycles_left: u32,
}

impl Wander {
    fn new(segments: Vec<(u32, [f32; 2])>) -> Wander {
        Wander {
            segments,
            segment: 0,
            cycles_left: 0,
        }
    }
}

impl Policy for Wander {
    fn reset(&mut self) {
        self.segment = 0;
        self.cycles_left = self.segments.first().map_or(0, |s| s.0);
    }

    fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        if self.segments.is_empty() {
            return [0.5, 0.5];
        }
        while self.cycles_left == 0 {
            self.segment = (self.segment + 1) % self.segments.len();
            self.cycles_left = self.segments[self.segment].0;
        }
        self.cycles_left -= 1;
        self.segments[self.segment].1
    }
}

/// Segments that mix any wheel commands with long pushes forward, so the robot spends much of
/// its time pressed against walls and obstacles.
fn segments() -> impl Strategy<Value = Vec<(u32, [f32; 2])>> {
    let any = (1u32..40, 0.0f32..=1.0, 0.0f32..=1.0).prop_map(|(n, l, r)| (n, [l, r]));
    let push = (20u32..120, 0.8f32..=1.0, 0.8f32..=1.0).prop_map(|(n, l, r)| (n, [l, r]));
    prop::collection::vec(prop_oneof![any, push], 1..24)
}

fn task_kind() -> impl Strategy<Value = &'static str> {
    prop::sample::select(SHIPPED_NAMES.to_vec())
}

fn evaluator(kind: &'static str, max_cycles: Option<u32>, end_on_collision: bool) -> Evaluator {
    let task = TaskConfig {
        max_cycles,
        end_on_collision,
        ..TaskConfig::shipped(kind).unwrap()
    };
    Evaluator::new(task).expect("the paper's task configurations are valid")
}

/// The nearest rectangle's distance from the robot's centre, and which rectangle it is.
fn clearance(pose: &Pose, rects: &[Rect]) -> (f32, usize) {
    rects
        .iter()
        .enumerate()
        .map(|(index, rect)| (signed_distance(pose.position(), rect), index))
        .fold((f32::INFINITY, usize::MAX), |best, next| {
            if next.0 < best.0 { next } else { best }
        })
}

/// Every pose of the trace keeps the robot's disc out of every rectangle, and a cycle whose
/// move collided leaves the robot where it was.
fn assert_never_inside(trace: &Trace, radius: f32) {
    let context = |cycle: usize| format!("{} {:?} cycle {cycle}", trace.scenario, trace.sample);
    let poses = trace
        .cycles
        .iter()
        .map(|c| c.robot)
        .chain(std::iter::once(trace.final_robot));
    for (cycle, pose) in poses.enumerate() {
        let (distance, rect) = clearance(&pose, &trace.rects);
        assert!(
            distance >= radius - 1e-4,
            "{}: robot at {pose:?} is {distance} from rect {:?}",
            context(cycle),
            trace.rects.get(rect)
        );
    }
    for (cycle, pair) in trace.cycles.windows(2).enumerate() {
        if pair[0].collided {
            assert_eq!(
                pair[0].robot,
                pair[1].robot,
                "{}: a collided move was not undone",
                context(cycle)
            );
        }
    }
    if let Some(last) = trace.cycles.last().filter(|c| c.collided) {
        assert_eq!(
            last.robot,
            trace.final_robot,
            "{}: the last collided move was not undone",
            context(trace.cycles.len())
        );
    }
}

/// A scripted policy for any task: used where a second, very different driver is needed.
fn scripted_trace(evaluator: &Evaluator, kind: &'static str, sample: Sample) -> Trace {
    evaluator.evaluate_traced(&mut Scripted::standard(kind), sample)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn robots_never_enter_walls_or_obstacles(kind in task_kind(), seed in any::<u64>(), segments in segments()) {
        let radius = TaskConfig::shipped(kind).unwrap().params.robot.radius;
        let evaluator = evaluator(kind, Some(1500), false);
        let trace = evaluator.evaluate_traced(&mut Wander::new(segments), Sample::seeded(seed));
        assert_never_inside(&trace, radius);
    }

    #[test]
    fn the_same_sample_replays_identically(kind in task_kind(), seed in any::<u64>(), segments in segments()) {
        let evaluator = evaluator(kind, Some(600), true);
        let sample = Sample::seeded(seed);
        let mut reused = Wander::new(segments.clone());
        let first = evaluator.evaluate_traced(&mut reused, sample);
        // The same policy object again (reset by the evaluator), and a fresh one.
        let again = evaluator.evaluate_traced(&mut reused, sample);
        let fresh = evaluator.evaluate_traced(&mut Wander::new(segments), sample);
        prop_assert_eq!(&first, &again);
        prop_assert_eq!(&first, &fresh);
        // The untraced evaluation gives the traced one's outcome.
        prop_assert_eq!(&evaluator.evaluate(&mut reused, sample), &first.outcome);
        // Another seed gives another sample.
        let other = evaluator.evaluate_traced(&mut reused, Sample::seeded(seed ^ 0x9E37_79B9));
        prop_assert_ne!(&first, &other);
    }

    #[test]
    fn the_environment_depends_on_the_seed_only(kind in task_kind(), seed in any::<u64>(), segments in segments()) {
        let evaluator = evaluator(kind, Some(400), true);
        let sample = Sample::seeded(seed);
        let wandering = evaluator.evaluate_traced(&mut Wander::new(segments), sample);
        let scripted = scripted_trace(&evaluator, kind, sample);
        prop_assert_eq!(&wandering.rects, &scripted.rects);
        prop_assert_eq!(&wandering.lights, &scripted.lights);
        prop_assert_eq!(wandering.goal, scripted.goal);
        prop_assert_eq!(wandering.exit, scripted.exit);
        prop_assert_eq!(wandering.outcome.variant, scripted.outcome.variant);
        // The start, and what is sensed before the policy has done anything.
        prop_assert_eq!(&wandering.cycles[0].robot, &scripted.cycles[0].robot);
        prop_assert_eq!(&wandering.cycles[0].teammate, &scripted.cycles[0].teammate);
        prop_assert_eq!(&wandering.cycles[0].frame, &scripted.cycles[0].frame);
    }
}

#[test]
fn wandering_does_press_against_walls() {
    // The property above is only worth something if the random drivers do touch walls: turn
    // about 100 degrees, then push straight on for 30 s.
    for kind in SHIPPED_NAMES {
        let evaluator = evaluator(kind, Some(400), false);
        let mut pusher = Wander::new(vec![(5, [0.0, 1.0]), (300, [1.0, 1.0])]);
        let touching = (0..8)
            .map(|seed| evaluator.evaluate_traced(&mut pusher, Sample::seeded(seed)))
            .filter(|trace| trace.cycles.iter().filter(|c| c.collided).count() > 10)
            .count();
        assert!(
            touching >= 4,
            "{kind}: only {touching} of 8 pushes reached a wall"
        );
    }
}

#[test]
fn the_scripted_policies_never_enter_walls_either() {
    // They drive close to walls on purpose (the room exiter at about 2 cm).
    for kind in SHIPPED_NAMES {
        let radius = TaskConfig::shipped(kind).unwrap().params.robot.radius;
        let evaluator = evaluator(kind, None, false);
        for seed in 0..12 {
            assert_never_inside(
                &scripted_trace(&evaluator, kind, Sample::seeded(seed)),
                radius,
            );
        }
    }
}

#[test]
fn every_start_pose_is_free() {
    for kind in SHIPPED_NAMES {
        let task = TaskConfig::shipped(kind).unwrap();
        let radius = task.params.robot.radius;
        let evaluator = evaluator(kind, Some(1), true);
        let seeds = if matches!(kind, "exit_room" | "rescue") {
            0..1500
        } else {
            0..200
        };
        for seed in seeds {
            let trace =
                evaluator.evaluate_traced(&mut Wander::new(Vec::new()), Sample::seeded(seed));
            let start = trace.cycles[0].robot;
            let (distance, rect) = clearance(&start, &trace.rects);
            assert!(
                distance >= radius,
                "{kind} seed {seed}: start {start:?} is {distance} from {:?}",
                trace.rects.get(rect)
            );
            assert!(
                !trace.cycles[0].collided,
                "{kind} seed {seed}: standing still collided"
            );
        }
    }
}

#[test]
fn light_configurations_and_branches_can_be_fixed_or_drawn() {
    // A fixed variant is used as given; a drawn one covers every variant and is the same for
    // the same seed whatever the policy.
    for kind in ["solve_maze", "return_room", "rescue"] {
        let evaluator = evaluator(kind, Some(5), true);
        for variant in 0..4 {
            let o = evaluator.evaluate(
                &mut Wander::new(Vec::new()),
                Sample {
                    seed: 7,
                    variant: Some(variant),
                },
            );
            assert_eq!(o.variant, variant, "{kind}");
        }
        let mut seen = [false; 4];
        for seed in 0..64 {
            let still = evaluator.evaluate(&mut Wander::new(Vec::new()), Sample::seeded(seed));
            let spinning = evaluator.evaluate(
                &mut Wander::new(vec![(3, [0.0, 1.0])]),
                Sample::seeded(seed),
            );
            assert_eq!(still.variant, spinning.variant, "{kind} seed {seed}");
            seen[still.variant as usize] = true;
        }
        assert_eq!(seen, [true; 4], "{kind}: drawn variants");
    }
}

/// Mean input of IR sensor 0 modelled by `curve` with the nearest surface at `distance` (`None`:
/// nothing in the cone), over many noisy reads.
fn mean_input(mapping: IrMapping, curve: u8, distance: Option<f32>) -> f32 {
    let setup = IrSensorSetup {
        curve: [curve; N_IR],
        offset: [0.0; N_IR],
        mapping,
    };
    let mut rng = stream_rng(u64::from(curve), Stream::Noise);
    let reads = 400;
    let sum: f32 = (0..reads)
        .map(|_| IrModel::builtin().read(&setup, 0, distance, &mut rng))
        .sum();
    sum / reads as f32
}

/// For every measured curve: an empty cone (and a surface at 12 cm or beyond) reads about 0,
/// and the mean input never rises as the surface moves away. Returns the violations.
fn ir_spec_violations(mapping: IrMapping) -> Vec<String> {
    let mut violations = Vec::new();
    for curve in 0..N_MEASURED_IR_CURVES as u8 {
        let name = IR_CURVE_NAMES[usize::from(curve)];
        for distance in [None, Some(0.12), Some(0.3)] {
            let input = mean_input(mapping, curve, distance);
            if input > 0.01 {
                violations.push(format!(
                    "{name}: surface at {distance:?} m reads {input:.3}, not 0"
                ));
            }
        }
        let inputs: Vec<f32> = (0..=12)
            .map(|cm| mean_input(mapping, curve, Some(cm as f32 * 0.01)))
            .collect();
        for cm in 1..inputs.len() {
            if inputs[cm] > inputs[cm - 1] + 0.01 {
                violations.push(format!(
                    "{name}: {} cm reads {:.3}, more than {} cm ({:.3})",
                    cm,
                    inputs[cm],
                    cm - 1,
                    inputs[cm - 1]
                ));
            }
        }
    }
    violations
}

#[test]
fn ir_inputs_meet_the_spec_with_the_linear_raw_mapping() {
    let violations = ir_spec_violations(IrMapping::LinearRaw);
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn ir_inputs_meet_the_spec_with_the_default_mapping() {
    let violations = ir_spec_violations(IrMapping::default());
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

/// Cycle-0 IR inputs of exit-room samples whose start has nothing within the sensors' reach
/// (obstacles kept 0.4 m from the room's centre): each must be about 0.
fn empty_room_start_readings(mapping: IrMapping) -> Vec<String> {
    let mut task = TaskConfig::shipped("exit_room").unwrap();
    task.params.ir.mapping = mapping;
    task.params.room.start_clearance = 0.4;
    let reach = task.params.robot.radius + task.params.ir.range_m;
    let evaluator = Evaluator::new(task).expect("a valid configuration");
    let mut bad = Vec::new();
    for seed in 0..200 {
        let trace = evaluator.evaluate_traced(&mut Wander::new(Vec::new()), Sample::seeded(seed));
        let start = trace.cycles[0].robot;
        let (nearest, _) = clearance(&start, &trace.rects);
        assert!(
            nearest > reach + 0.01,
            "seed {seed}: something within reach at the start"
        );
        let ir = trace.cycles[0].frame.values(InputGroup::IR);
        if ir.iter().any(|&input| input > 0.05) {
            bad.push(format!(
                "exit_room seed {seed}: nothing within {reach} m, IR inputs {ir:?}"
            ));
        }
    }
    bad
}

#[test]
fn nothing_in_reach_reads_zero_with_the_linear_raw_mapping() {
    let bad = empty_room_start_readings(IrMapping::LinearRaw);
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn nothing_in_reach_reads_zero_with_the_default_mapping() {
    let bad = empty_room_start_readings(IrMapping::default());
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Stands still while claiming, cycle by cycle, that a given child of a three-child root
/// drives: a stand-in for an arbitrator with a known switching schedule.
#[derive(Debug, Clone)]
struct Flicker {
    /// The child (1, 2 or 3) active in each cycle, repeated.
    schedule: Vec<usize>,
    cycle: usize,
    path: [usize; 2],
}

impl Policy for Flicker {
    fn reset(&mut self) {
        self.cycle = 0;
    }

    fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        self.path = [0, self.schedule[self.cycle % self.schedule.len()]];
        self.cycle += 1;
        [0.5, 0.5]
    }

    fn active_path(&self) -> &[usize] {
        &self.path
    }

    fn n_nodes(&self) -> usize {
        4
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Activations count the cycles in which a node is active and was not in the cycle
    /// before: the root once, each child once per stretch of the schedule it drives.
    #[test]
    fn activations_count_each_stretch_a_node_drives(
        stretches in prop::collection::vec((1usize..4, 1usize..30), 1..40),
    ) {
        let schedule: Vec<usize> = stretches
            .iter()
            .flat_map(|&(child, length)| std::iter::repeat_n(child, length))
            .collect();
        let mut task = TaskConfig::shipped("follow_wall").unwrap();
        task.max_cycles = Some(schedule.len() as u32);
        let evaluator = Evaluator::new(task).unwrap();
        let mut policy = Flicker { schedule: schedule.clone(), cycle: 0, path: [0, 0] };
        let outcome = evaluator.evaluate(&mut policy, Sample::seeded(3));
        prop_assert_eq!(outcome.cycles as usize, schedule.len(), "standing still never ends early");

        let mut expected_cycles = vec![schedule.len() as u32, 0, 0, 0];
        let mut expected_activations = vec![1u32, 0, 0, 0];
        for (cycle, &child) in schedule.iter().enumerate() {
            expected_cycles[child] += 1;
            if cycle == 0 || schedule[cycle - 1] != child {
                expected_activations[child] += 1;
            }
        }
        prop_assert_eq!(outcome.node_use.active_cycles, expected_cycles);
        prop_assert_eq!(outcome.node_use.activations, expected_activations);
    }
}

/// A map of one's own, drawn at random: a `width` x `height` grid in which a random walk from
/// the entrance (the bottom row's middle cell) opens cells, plus the goal at `goal` (a cell
/// the walk may or may not have reached). Returns the scenario's text, and whether the goal is
/// connected to the entrance through open cells (worked out here, independently of hevo).
fn random_map_scenario(
    width: usize,
    height: usize,
    walk: &[u8],
    goal: (usize, usize),
) -> Option<(String, bool)> {
    let entrance = (width / 2, height - 1);
    let mut open = vec![vec![false; width]; height];
    let (mut x, mut y) = entrance;
    open[y][x] = true;
    for step in walk {
        let (dx, dy): (isize, isize) = [(0, -1), (1, 0), (0, 1), (-1, 0)][usize::from(*step % 4)];
        let (nx, ny) = (x as isize + dx, y as isize + dy);
        // The walk stays off the entrance's row, so the entrance is the only way in from below.
        if nx < 0 || ny < 0 || nx >= width as isize || ny >= height as isize - 1 {
            continue;
        }
        (x, y) = (nx as usize, ny as usize);
        open[y][x] = true;
    }
    if goal == entrance {
        return None;
    }
    open[goal.1][goal.0] = true;
    // Breadth-first from the entrance over open cells.
    let mut reached = vec![vec![false; width]; height];
    let mut queue = std::collections::VecDeque::from([entrance]);
    reached[entrance.1][entrance.0] = true;
    while let Some((cx, cy)) = queue.pop_front() {
        for (dx, dy) in [(0isize, -1isize), (1, 0), (0, 1), (-1, 0)] {
            let (nx, ny) = (cx as isize + dx, cy as isize + dy);
            if nx < 0 || ny < 0 || nx >= width as isize || ny >= height as isize {
                continue;
            }
            let (nx, ny) = (nx as usize, ny as usize);
            if open[ny][nx] && !reached[ny][nx] {
                reached[ny][nx] = true;
                queue.push_back((nx, ny));
            }
        }
    }
    let grid: String = (0..height)
        .map(|row| {
            (0..width)
                .map(|col| match (col, row) {
                    cell if cell == entrance => 'S',
                    cell if cell == goal => 'G',
                    (col, row) if open[row][col] => '.',
                    _ => '#',
                })
                .collect::<String>()
                + "\n"
        })
        .collect();
    let text = format!(
        r##"schema = "hevo.scenario/1"
name = "random_map"
max_cycles = 300

[world]
map = {{ cell_size = 0.30, wall_thickness = 0.10, origin = [0, 0], grid = """
{grid}""", legend = {{ "." = "open", "#" = "solid", S = "entrance", G = "goal" }} }}

[[variant]]
name = "only"
goal = "goal"

[place]
at = "entrance"
facing = "path"

[end]
solved = "in goal"

[fitness]
solved = "1 + time_bonus"
otherwise = "progress"
"##
    );
    Some((text, reached[goal.1][goal.0]))
}

fn random_map() -> impl Strategy<Value = (usize, usize, Vec<u8>, (usize, usize))> {
    (3usize..=9, 3usize..=8).prop_flat_map(|(width, height)| {
        (
            Just(width),
            Just(height),
            prop::collection::vec(0u8..4, 0..40),
            (0..width, 0..height),
        )
    })
}

/// The paper's generated room over random generator ranges, as a scenario file.
fn random_room_scenario(side: (f32, f32), obstacle_side: (f32, f32)) -> String {
    format!(
        r#"schema = "hevo.scenario/1"
name = "random_room"
max_cycles = 300

[world]
room = "standalone"

[room]
min_side = {:.3}
max_side = {:.3}
obstacle_min_side = {:.3}
obstacle_max_side = {:.3}

[place]
at = "room.start"

[end]
solved = "beyond room.exit"

[fitness]
solved = "1 + time_bonus"
otherwise = "approach room.exit"
"#,
        side.0, side.1, obstacle_side.0, obstacle_side.1
    )
}

/// A generated corridor of `shape` over random length ranges and junction shares, alone (the
/// robot at its first cell, perhaps advanced along it) or joined under the paper's room (the
/// robot in the room), as a scenario file.
fn random_corridor_scenario(
    shape: &str,
    below_room: bool,
    lengths: [(u32, u32); 3],
    shares: (f32, f32),
    advance: bool,
) -> String {
    let range = |(low, extra): (u32, u32)| format!("[{low}, {}]", low + extra);
    let (world, place) = if below_room {
        ("room = \"below corridor\"\n", "at = \"room.start\"")
    } else if advance {
        (
            "",
            "at = \"corridor.start\"\nfacing = \"path\"\nadvance = true",
        )
    } else {
        ("", "at = \"corridor.start\"\nfacing = \"path\"")
    };
    format!(
        r#"schema = "hevo.scenario/1"
name = "random_corridor"
max_cycles = 300

[corridor]
straight_cells = {}
cells_before_turn = {}
cells_after_turn = {}
junction_share = {:.3}
side_junction_share = {:.3}
start_advance = {}

[world]
corridor = "{shape}"
{world}
[place]
{place}

[end]
solved = "in goal"
wrong_branch = "off path"

[fitness]
solved = "1 + time_bonus"
otherwise = "progress / 3"
"#,
        range(lengths[0]),
        range(lengths[1]),
        range(lengths[2]),
        shares.0,
        shares.1,
        if advance { "0.3" } else { "0.0" },
    )
}

/// Whether a disc of `radius` can move along the straight segment `from` -> `to` without
/// touching a solid, tested every centimetre.
fn segment_is_clear(
    scene: &hevo_sim_core::Scene,
    from: [f32; 2],
    to: [f32; 2],
    radius: f32,
) -> bool {
    let length = ((to[0] - from[0]).powi(2) + (to[1] - from[1]).powi(2)).sqrt();
    let steps = (length / 0.01).ceil().max(1.0) as usize;
    (0..=steps).all(|step| {
        let t = step as f32 / steps as f32;
        let at = [
            from[0] + t * (to[0] - from[0]),
            from[1] + t * (to[1] - from[1]),
        ];
        !scene.disc_hits(at, radius)
    })
}

fn wandering_evaluator(scenario: Scenario) -> Evaluator {
    let task = TaskConfig {
        end_on_collision: false,
        ..TaskConfig::from_scenario(std::sync::Arc::new(scenario))
    };
    Evaluator::new(task).expect("a compiled scenario makes a valid task")
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn a_random_map_compiles_exactly_when_its_goal_is_reachable(
        (width, height, walk, goal) in random_map()
    ) {
        let Some((text, reachable)) = random_map_scenario(width, height, &walk, goal) else {
            return Ok(());
        };
        match Scenario::parse(&text, "random_map.toml") {
            Ok(_) => prop_assert!(reachable, "an unreachable goal was accepted:\n{text}"),
            Err(error) => {
                prop_assert!(!reachable, "a reachable goal was refused: {error}\n{text}");
                prop_assert!(error.to_string().contains("no start can reach the goal 'goal'"), "{error}");
            }
        }
    }

    #[test]
    fn robots_never_enter_the_walls_of_a_random_map(
        (width, height, walk, goal) in random_map(),
        seed in any::<u64>(),
        segments in segments(),
    ) {
        let Some((text, true)) = random_map_scenario(width, height, &walk, goal) else {
            return Ok(());
        };
        let evaluator = wandering_evaluator(Scenario::parse(&text, "random_map.toml").unwrap());
        let sample = Sample::seeded(seed);
        let trace = evaluator.evaluate_traced(&mut Wander::new(segments.clone()), sample);
        assert_never_inside(&trace, evaluator.task().params.robot.radius);
        let again = evaluator.evaluate_traced(&mut Wander::new(segments), sample);
        prop_assert_eq!(&trace.outcome, &again.outcome, "same seed, same outcome");
    }

    #[test]
    fn robots_never_enter_the_walls_or_obstacles_of_a_random_room(
        low in 0.8f32..1.3,
        extra in 0.0f32..0.3,
        smallest_obstacle in 0.02f32..0.2,
        obstacle_extra in 0.0f32..0.15,
        seed in any::<u64>(),
        segments in segments(),
    ) {
        let text = random_room_scenario(
            (low, low + extra),
            (smallest_obstacle, smallest_obstacle + obstacle_extra),
        );
        let scenario = match Scenario::parse(&text, "random_room.toml") {
            Ok(scenario) => scenario,
            // A range the room generator cannot meet is refused by name, never drawn.
            Err(error) => {
                prop_assert!(error.to_string().contains("room"), "{error}");
                return Ok(());
            }
        };
        let evaluator = wandering_evaluator(scenario);
        let sample = Sample::seeded(seed);
        let trace = evaluator.evaluate_traced(&mut Wander::new(segments.clone()), sample);
        assert_never_inside(&trace, evaluator.task().params.robot.radius);
        let again = evaluator.evaluate_traced(&mut Wander::new(segments), sample);
        prop_assert_eq!(&trace.outcome, &again.outcome, "same seed, same outcome");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    /// Every generated corridor, alone or joined under a room, over random ranges: its goal
    /// can be reached by the robot's body (from the start cell, or from inside the room's
    /// exit, cell centre to cell centre along the path, never touching a wall), the robot
    /// never enters a wall, and one seed gives one outcome.
    #[test]
    fn every_generated_corridor_goal_is_reachable_and_its_walls_hold(
        shape in prop_oneof![Just("straight"), Just("left"), Just("right")],
        below_room in any::<bool>(),
        lengths in [(1u32..8, 0u32..5), (2u32..6, 0u32..4), (1u32..6, 0u32..4)],
        junction_share in 0.0f32..1.0,
        side_share in 0.0f32..1.0,
        advance in any::<bool>(),
        seed in any::<u64>(),
        segments in segments(),
    ) {
        let shares = (junction_share, side_share * (1.0 - junction_share));
        let text = random_corridor_scenario(shape, below_room, lengths, shares, advance);
        let scenario = Scenario::parse(&text, "random_corridor.toml").expect("it compiles");
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        if let Err(error) = task.validate() {
            // Only an advance from a one-cell corridor is refused, by its key.
            prop_assert_eq!(error.key.as_str(), "corridor.start_advance", "{}\n{}", error, text);
            return Ok(());
        }
        let evaluator = Evaluator::new(TaskConfig { end_on_collision: false, ..task })
            .expect("a valid task");
        let radius = evaluator.task().params.robot.radius;
        let sample = Sample::seeded(seed);
        let env = evaluator.environment(sample);
        let goal = env.ground.goal.as_ref().expect("a corridor has a goal in cells");
        let map = &goal.map;
        let path: Vec<usize> = {
            // The path from the start cell: down the distances to the goal.
            let mut at = (0..map.cells.len())
                .filter(|&cell| goal.on_path[cell])
                .max_by(|&a, &b| goal.distances[a].total_cmp(&goal.distances[b]))
                .expect("a path");
            let mut path = vec![at];
            while at != goal.goal {
                at = map
                    .neighbours(at)
                    .min_by(|&a, &b| goal.distances[a].total_cmp(&goal.distances[b]))
                    .expect("a way on");
                path.push(at);
                prop_assert!(path.len() <= map.cells.len(), "the distances lead round in circles");
            }
            path
        };
        prop_assert!(goal.total_distance.is_finite() && goal.total_distance > 0.0 || path.len() == 1);
        let mut from = match &env.ground.room {
            // From just inside the room's exit into the corridor's first cell.
            Some(room) => [
                room.exit_center[0] - 0.1 * room.exit_outward[0],
                room.exit_center[1] - 0.1 * room.exit_outward[1],
            ],
            None => map.center(path[0]),
        };
        for &cell in &path {
            let to = map.center(cell);
            prop_assert!(
                segment_is_clear(&env.scene, from, to, radius),
                "no way from {from:?} to {to:?} (cell {cell} of {path:?}), seed {seed}:\n{text}"
            );
            from = to;
        }
        let trace = evaluator.evaluate_traced(&mut Wander::new(segments.clone()), sample);
        assert_never_inside(&trace, radius);
        prop_assert!(trace.outcome.fitness.is_finite(), "{:?}\n{}", trace.outcome, text);
        let again = evaluator.evaluate_traced(&mut Wander::new(segments), sample);
        prop_assert_eq!(&trace.outcome, &again.outcome, "same seed, same outcome");
    }
}

#[test]
fn the_random_maps_and_rooms_are_mostly_real_worlds() {
    // The properties above skip what they cannot use; this keeps them from skipping most.
    use proptest::strategy::ValueTree;
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let (mut reachable, mut unreachable) = (0, 0);
    for _ in 0..200 {
        let (width, height, walk, goal) = random_map().new_tree(&mut runner).unwrap().current();
        match random_map_scenario(width, height, &walk, goal) {
            Some((_, true)) => reachable += 1,
            Some((_, false)) => unreachable += 1,
            None => {}
        }
    }
    assert!(
        reachable >= 40 && unreachable >= 40,
        "{reachable} reachable, {unreachable} not"
    );
    let mut rooms = 0;
    for index in 0..20 {
        let side = 0.8 + index as f32 * 0.025;
        let text = random_room_scenario((side, side + 0.1), (0.05, 0.2));
        rooms += usize::from(Scenario::parse(&text, "room.toml").is_ok());
    }
    assert!(rooms >= 15, "only {rooms} of 20 rooms compiled");
}
