//! The scripted reference policies against the real simulator: every task is solvable with the
//! robot's own sensors (each policy solves at least a fixed number of 200 seeded samples), the
//! simulator's goal detection and fitness bands agree with what the robot actually did, wrong
//! turns are caught as wrong branches, the derived fitness f3 counts the root's choices
//! against the ground truth, and the light flashes reach the controller as the paper's held
//! inputs. The counts asserted are floors on fixed seeds, two or three samples below what the
//! policies reach today (noted next to each, see `assert_count`), so a change that costs a
//! policy a few samples, not only one that makes a task unsolvable or breaks its goal
//! detection, fails. `--nocapture` shows every count. They simulate a few million cycles
//! (about 35 s on two cores).
//!
//! The main tests run the paper's tasks with the IR mapping that meets the specification's
//! "1 at contact, 0 at 12 cm or beyond" for every measured sensor curve (`linear_raw`). The
//! default mapping (`average_table`, model version 4: `IrConfig::default()` in
//! `sensors/ir.rs`, which `TaskConfig::new` uses) turns each sensor's raw reading back into a
//! distance through the average curve, so a sensor whose own curve differs from the average
//! reads walls systematically off, and a wall 9 cm away reads about 0.25, close to the scripted
//! policies' "nothing there" threshold; that costs the policies part of their reliability at
//! turns. One test checks the default configuration with lower bars (see
//! `the_default_configuration_is_solvable_too`).

use hevo_scripted::{
    CorridorFollower, MazeSolver, Rescuer, Returner, RoomExiter, TurnSide, Turner,
};
use hevo_sim_core::IrMapping;
use hevo_sim_core::{Ending, Evaluator, Outcome, Policy, Sample, TaskConfig, Trace};
use hevo_sim_core::{InputGroup, SensorFrame};

use crate::support::Scripted;

/// Samples per task (per light configuration for the maze).
const SEEDS: u64 = 200;

/// The paper's task with the specification-conforming IR mapping (see the top of the file).
fn spec_task(kind: &'static str) -> TaskConfig {
    let mut task = TaskConfig::shipped(kind).unwrap();
    task.params.ir.mapping = IrMapping::LinearRaw;
    task
}

fn evaluator(kind: &'static str) -> Evaluator {
    Evaluator::new(spec_task(kind)).expect("the paper's task configurations are valid")
}

// The scripted policies, told the IR mapping of `spec_task`.
fn follower() -> CorridorFollower {
    CorridorFollower::for_task(&spec_task("follow_wall"))
}

fn turner(side: TurnSide) -> Turner {
    Turner::for_task(side, &spec_task("turn_left"))
}

fn solver() -> MazeSolver {
    MazeSolver::for_task(&spec_task("solve_maze"))
}

fn returner() -> Returner {
    Returner::for_task(&spec_task("return_room"))
}

fn exiter() -> RoomExiter {
    RoomExiter::for_task(&spec_task("exit_room"))
}

fn rescuer() -> Rescuer {
    Rescuer::for_task(&spec_task("rescue"))
}

/// Runs one policy (reset by the evaluator before each sample) on seeds `0..SEEDS` of a task.
fn run_on(
    task: &TaskConfig,
    policy: &mut impl Policy,
    variant: Option<u32>,
) -> Vec<(Sample, Outcome)> {
    let evaluator =
        Evaluator::new(task.clone()).expect("the paper's task configurations are valid");
    (0..SEEDS)
        .map(|seed| {
            let sample = Sample { seed, variant };
            (sample, evaluator.evaluate(policy, sample))
        })
        .collect()
}

/// `run_on` the specification-conforming task.
fn run(
    kind: &'static str,
    policy: &mut impl Policy,
    variant: Option<u32>,
) -> Vec<(Sample, Outcome)> {
    run_on(&spec_task(kind), policy, variant)
}

fn failures(outcomes: &[(Sample, Outcome)]) -> Vec<(u64, Ending, u32)> {
    outcomes
        .iter()
        .filter(|(_, o)| !o.solved)
        .map(|(s, o)| (s.seed, o.ending, o.cycles))
        .take(20)
        .collect()
}

/// Asserts that at least `at_least` of the outcomes satisfy `counted`. The samples are
/// fixed-seed, so a count is the same on every run: each floor sits three samples below the
/// count measured on a whole task's 200 samples, two below on a part of them (one light
/// configuration, start branch or corridor shape); the measured counts are noted beside the
/// floors. A change that costs a policy a few samples fails here.
fn assert_count(
    what: &str,
    outcomes: &[(Sample, Outcome)],
    counted: impl Fn(&Outcome) -> bool,
    at_least: usize,
) {
    let count = outcomes.iter().filter(|(_, o)| counted(o)).count();
    // Shown with `--nocapture`, for re-measuring after an intended model change.
    eprintln!("{what}: {count} of {} (floor {at_least})", outcomes.len());
    assert!(
        count >= at_least,
        "{what}: {count} of {}, below the floor of {at_least}; first failures (seed, ending, \
         cycles): {:?}",
        outcomes.len(),
        failures(outcomes)
    );
}

/// `assert_count` of the solved samples.
fn assert_solved(what: &str, outcomes: &[(Sample, Outcome)], at_least: usize) {
    assert_count(&format!("{what} solved"), outcomes, |o| o.solved, at_least);
}

/// Floors for the rescue's stages: samples that left the room (stage 1 or more), reached the
/// teammate (2 or more) and brought it back (3, solved).
fn assert_rescue_stages(what: &str, outcomes: &[(Sample, Outcome)], at_least: [usize; 3]) {
    for (stage, name) in [
        (1, "left the room"),
        (2, "reached the teammate"),
        (3, "returned"),
    ] {
        assert_count(
            &format!("{what} {name}"),
            outcomes,
            |o| o.stage >= stage,
            at_least[stage as usize - 1],
        );
    }
}

/// The outcomes of one variant (light configuration, start branch or corridor shape).
fn of_variant(outcomes: &[(Sample, Outcome)], variant: u32) -> Vec<(Sample, Outcome)> {
    outcomes
        .iter()
        .filter(|(_, o)| o.variant == variant)
        .cloned()
        .collect()
}

/// Checks what must hold for every outcome of a task, whatever the policy did.
fn assert_coherent(kind: &'static str, outcomes: &[(Sample, Outcome)]) {
    let max_cycles = spec_task(kind).max_cycles();
    for (sample, o) in outcomes {
        let context = format!("{kind} {sample:?} {o:?}");
        assert_eq!(o.solved, o.ending == Ending::Solved, "{context}");
        assert!(o.cycles >= 1 && o.cycles <= max_cycles, "{context}");
        if o.ending == Ending::Timeout {
            assert_eq!(o.cycles, max_cycles, "{context}");
        }
        if o.ending == Ending::Collision {
            assert!(o.collided, "{context}");
        }
        assert!(o.fitness.is_finite(), "{context}");
        let f = o.fitness;
        match kind {
            "exit_room" => {
                if o.solved {
                    assert!(
                        f > 5.0 && f <= 6.0,
                        "f1 of a solved sample out of (5, 6]: {context}"
                    );
                } else {
                    assert!(
                        (0.0..=1.0).contains(&f),
                        "f1 of an unsolved sample out of [0, 1]: {context}"
                    );
                }
            }
            "solve_maze" | "return_room" => {
                if o.solved {
                    assert!(
                        f > 1.0 && f <= 2.0,
                        "f2 of a solved sample out of (1, 2]: {context}"
                    );
                } else {
                    assert!(
                        (0.0..=1.0 / 3.0).contains(&f),
                        "f2 of an unsolved sample out of [0, 1/3]: {context}"
                    );
                }
                if o.ending == Ending::Timeout {
                    assert_eq!(f, 0.0, "f2 of a timeout: {context}");
                }
            }
            "follow_wall" | "turn_left" | "turn_right" => {
                if o.solved {
                    assert!(f > 1.0 && f <= 2.0, "{context}");
                } else {
                    assert!((0.0..=0.5).contains(&f), "{context}");
                }
            }
            "rescue" => {
                assert!((0.0..=3.0).contains(&f), "f3 out of [0, 3]: {context}");
                assert_eq!(
                    o.stage == 3,
                    o.solved,
                    "rescue stage 3 iff solved: {context}"
                );
            }
            other => panic!("no scripted policy for {other}"),
        }
        if kind != "rescue" {
            assert_eq!(o.stage, u8::from(o.solved), "{context}");
        }
        if let Some(variant) = sample.variant {
            assert_eq!(o.variant, variant, "{context}");
        }
    }
}

fn distance_beyond(point: [f32; 2], exit: ([f32; 2], [f32; 2])) -> f32 {
    let (center, outward) = exit;
    (point[0] - center[0]) * outward[0] + (point[1] - center[1]) * outward[1]
}

/// For cell tasks: a solved sample ends with the robot inside the goal cell (0.30 m square).
fn assert_ends_in_goal(kind: &'static str, policy: &mut impl Policy, seeds: std::ops::Range<u64>) {
    let evaluator = evaluator(kind);
    for seed in seeds {
        let trace = evaluator.evaluate_traced(policy, Sample::seeded(seed));
        if !trace.outcome.solved {
            continue;
        }
        let Some(goal) = trace.goal else {
            panic!("{kind}: a cell task's trace names its goal")
        };
        let end = trace.final_robot;
        let (dx, dy) = ((end.x - goal[0]).abs(), (end.y - goal[1]).abs());
        assert!(
            dx <= 0.15 + 1e-4 && dy <= 0.15 + 1e-4,
            "{kind} seed {seed}: solved at {end:?}, goal cell at {goal:?}"
        );
    }
}

#[test]
fn follow_wall_is_solved_by_the_corridor_follower() {
    let outcomes = run("follow_wall", &mut follower(), None);
    assert_coherent("follow_wall", &outcomes);
    // Measured: 200 of 200.
    assert_solved("follow_wall", &outcomes, 197);
    assert_ends_in_goal("follow_wall", &mut follower(), 0..20);
}

#[test]
fn turns_are_solved_by_the_turners_at_bends_and_junctions() {
    // Measured: left 198 and right 199 of 200; of each shape (bend, T-end, side junction),
    // left 50, 74 and 74 and right 50, 74 and 75 of 50, 74 and 76.
    for (kind, side, floors) in [
        ("turn_left", TurnSide::Left, [195, 48, 72, 72]),
        ("turn_right", TurnSide::Right, [196, 48, 72, 73]),
    ] {
        let outcomes = run(kind, &mut turner(side), None);
        assert_coherent(kind, &outcomes);
        assert_solved(kind, &outcomes, floors[0]);
        for shape in 0..3 {
            let of_shape = of_variant(&outcomes, shape);
            assert!(
                of_shape.len() >= 30,
                "{kind}: too few samples of shape {shape}"
            );
            assert_solved(
                &format!("{kind} shape {shape}"),
                &of_shape,
                floors[1 + shape as usize],
            );
        }
        assert_ends_in_goal(kind, &mut turner(side), 0..20);
    }
}

#[test]
fn a_turn_to_the_wrong_side_at_a_junction_is_a_wrong_branch() {
    // At a T-junction (variant 1) the other arm is a wrong branch; an L-bend (variant 0) only
    // opens to the correct side, so the turner takes it whatever its preference.
    // Measured: 74 of the 74 T-junction samples on each side end in a wrong branch.
    for (kind, wrong, floor) in [
        ("turn_left", TurnSide::Right, 72),
        ("turn_right", TurnSide::Left, 72),
    ] {
        let outcomes = run(kind, &mut turner(wrong), None);
        assert_coherent(kind, &outcomes);
        for (sample, o) in &outcomes {
            if o.variant == 1 {
                assert!(
                    !o.solved,
                    "{kind} {sample:?}: a wrong turn at a junction was counted as solved"
                );
            }
        }
        assert_count(
            &format!("{kind} T-junction wrong branches"),
            &of_variant(&outcomes, 1),
            |o| o.ending == Ending::WrongBranch,
            floor,
        );
    }
}

#[test]
fn solve_maze_is_solved_in_every_light_configuration() {
    // Measured, of 200 per configuration: 200 in each.
    for (configuration, floor) in [(0, 197), (1, 197), (2, 197), (3, 197)] {
        let outcomes = run("solve_maze", &mut solver(), Some(configuration));
        assert_coherent("solve_maze", &outcomes);
        assert_solved(
            &format!("solve_maze configuration {configuration}"),
            &outcomes,
            floor,
        );
    }
    assert_ends_in_goal("solve_maze", &mut solver(), 0..20);
}

/// Swaps the two light inputs before a wrapped policy sees them.
#[derive(Debug)]
struct SwappedLights<P>(P);

impl<P: Policy> Policy for SwappedLights<P> {
    fn reset(&mut self) {
        self.0.reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let mut swapped = *frame;
        swapped.values_mut(InputGroup::LIGHT).reverse();
        self.0.step(&swapped, dt)
    }
}

#[test]
fn turning_against_the_lights_ends_in_a_wrong_branch() {
    // Measured, of 200 per configuration: 200 wrong branches in each.
    for (configuration, floor) in [(0, 197), (1, 197), (2, 197), (3, 197)] {
        let outcomes = run(
            "solve_maze",
            &mut SwappedLights(solver()),
            Some(configuration),
        );
        assert_coherent("solve_maze", &outcomes);
        assert!(
            outcomes.iter().all(|(_, o)| !o.solved),
            "configuration {configuration}: solved against the lights"
        );
        assert_count(
            &format!("solve_maze configuration {configuration} against the lights, wrong branches"),
            &outcomes,
            |o| o.ending == Ending::WrongBranch,
            floor,
        );
    }
}

#[test]
fn return_room_is_solved_by_the_returner() {
    let outcomes = run("return_room", &mut returner(), None);
    assert_coherent("return_room", &outcomes);
    // Measured: 200 of 200.
    assert_solved("return_room", &outcomes, 197);
    // Measured, per start branch: all of 55, 46, 59 and 40.
    for (branch, floor) in [(0, 53), (1, 44), (2, 57), (3, 38)] {
        let from_branch = of_variant(&outcomes, branch);
        assert!(
            from_branch.len() >= 25,
            "too few samples from branch {branch}"
        );
        assert_solved(&format!("return_room branch {branch}"), &from_branch, floor);
    }
    assert_ends_in_goal("return_room", &mut returner(), 0..20);
}

#[test]
fn exit_room_is_solved_by_the_room_exiter() {
    let outcomes = run("exit_room", &mut exiter(), None);
    assert_coherent("exit_room", &outcomes);
    // Measured: 185 of 200 (about 93% over 1000 seeds).
    assert_solved("exit_room", &outcomes, 182);
    // A solved sample ends with the robot's centre beyond the exit wall and its own radius.
    let evaluator = evaluator("exit_room");
    let task = spec_task("exit_room");
    for seed in 0..30 {
        let trace = evaluator.evaluate_traced(&mut exiter(), Sample::seeded(seed));
        let Some(exit) = trace.exit else {
            panic!("the room's trace names its exit")
        };
        let beyond = distance_beyond(trace.final_robot.position(), exit);
        let needed = task.params.room.wall_thickness + task.params.robot.radius;
        assert_eq!(
            trace.outcome.solved,
            beyond > needed,
            "seed {seed}: {beyond} beyond the exit"
        );
    }
}

#[test]
fn rescue_is_solved_by_the_rescuer_and_its_stages_are_counted() {
    let outcomes = run("rescue", &mut rescuer(), None);
    assert_coherent("rescue", &outcomes);
    // Measured, of 200 (about 91% solved over 1000 seeds): 186 left the room, 183 reached the
    // teammate, 180 brought it back.
    assert_rescue_stages("rescue", &outcomes, [183, 180, 177]);
    for (sample, o) in &outcomes {
        // Four nodes, the root always active and exactly one child with it.
        assert_eq!(o.node_use.active_cycles.len(), 4, "{sample:?}");
        assert_eq!(o.node_use.active_cycles[0], o.cycles, "{sample:?}");
        assert_eq!(
            o.node_use.active_cycles[1..].iter().sum::<u32>(),
            o.cycles,
            "{sample:?}"
        );
        // The rescuer's phases only go forward: the root is switched on once, each child at
        // most once, and exactly the children that ran.
        let ran: Vec<u32> = o
            .node_use
            .active_cycles
            .iter()
            .map(|&c| u32::from(c > 0))
            .collect();
        assert_eq!(o.node_use.activations, ran, "{sample:?}");
        // Every cycle falls in one sub-task, the fitness is f3 of the counts, and a solved
        // sample went through all three sub-tasks.
        let choices = o.sub_task_choices;
        assert_eq!(choices.cycles.iter().sum::<u32>(), o.cycles, "{sample:?}");
        assert!(
            (0..3).all(|s| choices.correct[s] <= choices.cycles[s]),
            "{sample:?}"
        );
        assert_eq!(o.fitness, choices.derived_fitness(), "{sample:?}");
        if o.solved {
            assert!(choices.cycles[..3].iter().all(|&c| c > 0), "{sample:?}");
        }
    }
    // Every light configuration is met and solved. Measured: 50 of 55, 42 of 46, 52 of 59 and
    // 36 of 40.
    for (configuration, floor) in [(0, 48), (1, 40), (2, 50), (3, 34)] {
        let of_configuration = of_variant(&outcomes, configuration);
        assert!(
            of_configuration.len() >= 25,
            "too few rescue samples with configuration {configuration}"
        );
        assert_solved(
            &format!("rescue configuration {configuration}"),
            &of_configuration,
            floor,
        );
    }
    // A solved rescue ends with the teammate inside the room: the last recorded teammate pose
    // is at most one cycle's travel short of the room side of the exit.
    let evaluator = evaluator("rescue");
    let task = spec_task("rescue");
    for seed in 0..20 {
        let trace = evaluator.evaluate_traced(&mut rescuer(), Sample::seeded(seed));
        if !trace.outcome.solved {
            continue;
        }
        let Some(exit) = trace.exit else {
            panic!("the rescue trace names the room's exit")
        };
        let Some(mate) = trace.cycles.last().and_then(|c| c.teammate) else {
            panic!("the rescue has a teammate")
        };
        let step = task.params.robot.v_max * task.params.robot.cycle_seconds;
        assert!(
            distance_beyond(mate.position(), exit) < -task.params.robot.radius + step + 1e-4,
            "seed {seed}: teammate at {mate:?}"
        );
    }
}

/// What a wrapped rescuer reports as its root's choice.
#[derive(Debug, Clone, Copy)]
enum Report {
    /// Its own phase.
    Own,
    /// Its own phase, except `reported` while in `phase`.
    Replace { phase: usize, reported: usize },
    /// Always this child.
    Always(usize),
}

/// The rescuer's driving with a chosen report of the root's choice.
#[derive(Debug)]
struct ReportedChoice {
    inner: Rescuer,
    report: Report,
}

impl Policy for ReportedChoice {
    fn reset(&mut self) {
        self.inner.reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.inner.step(frame, dt)
    }

    fn root_choice(&self) -> Option<usize> {
        let phase = self.inner.phase();
        Some(match self.report {
            Report::Own => phase,
            Report::Replace {
                phase: replaced,
                reported,
            } if replaced == phase => reported,
            Report::Replace { .. } => phase,
            Report::Always(child) => child,
        })
    }

    fn active_path(&self) -> &[usize] {
        self.inner.active_path()
    }

    fn n_nodes(&self) -> usize {
        self.inner.n_nodes()
    }
}

#[test]
fn derived_fitness_counts_the_roots_choices_against_the_ground_truth() {
    let evaluator = evaluator("rescue");
    let samples: Vec<Sample> = (0..60).map(Sample::seeded).collect();
    let mut right = ReportedChoice {
        inner: rescuer(),
        report: Report::Own,
    };
    // The same driving, but while solving the maze the root claims to be exiting the room.
    let mut wrong_in_maze = ReportedChoice {
        inner: rescuer(),
        report: Report::Replace {
            phase: 1,
            reported: 0,
        },
    };
    let mut solved = 0;
    for &sample in &samples {
        let good = evaluator.evaluate(&mut right, sample);
        let bad = evaluator.evaluate(&mut wrong_in_maze, sample);
        // The choice does not steer anything: both runs drive identically.
        assert_eq!(
            (good.ending, good.cycles, good.stage),
            (bad.ending, bad.cycles, bad.stage),
            "{sample:?}"
        );
        if !good.solved {
            continue;
        }
        solved += 1;
        // Each stage's ratio is about 1; the few cycles lost are those between the ground
        // truth's switch (the robot's centre entering the maze's first cell) and the
        // rescuer's own (it first sees corridor walls for a few cycles).
        assert!(
            good.fitness > 2.9 && good.fitness <= 3.0,
            "{sample:?}: f3 {}",
            good.fitness
        );
        // Wrong throughout the maze stage: that stage's ratio drops to 0, the others stay.
        assert!(
            bad.fitness > 1.9 && bad.fitness <= 2.0,
            "{sample:?}: f3 {}",
            bad.fitness
        );
        assert!(bad.fitness < good.fitness, "{sample:?}");
    }
    // Measured: 55 of 60.
    assert!(
        solved >= 53,
        "only {solved} of {} rescues solved",
        samples.len()
    );

    // A root that always reports "exit room" is right in the room and nowhere else: exactly
    // 1 whatever happens. One that keeps reporting "solve maze" on the way back loses the
    // return stage only.
    let mut always_exit = ReportedChoice {
        inner: rescuer(),
        report: Report::Always(0),
    };
    let mut lost_on_return = ReportedChoice {
        inner: rescuer(),
        report: Report::Replace {
            phase: 2,
            reported: 1,
        },
    };
    for &sample in samples.iter().take(20) {
        assert_eq!(
            evaluator.evaluate(&mut always_exit, sample).fitness,
            1.0,
            "{sample:?}"
        );
        let o = evaluator.evaluate(&mut lost_on_return, sample);
        if o.solved {
            assert!(
                o.fitness > 1.9 && o.fitness <= 2.0,
                "{sample:?}: f3 {}",
                o.fitness
            );
        }
    }

    // Without a root (a primitive) nothing is ever right.
    let mut plain = RescuerWithoutRoot(rescuer());
    for &sample in samples.iter().take(5) {
        assert_eq!(
            evaluator.evaluate(&mut plain, sample).fitness,
            0.0,
            "{sample:?}"
        );
    }
}

/// The rescuer's driving with the trait's default root choice (none).
#[derive(Debug)]
struct RescuerWithoutRoot(Rescuer);

impl Policy for RescuerWithoutRoot {
    fn reset(&mut self) {
        self.0.reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.0.step(frame, dt)
    }
}

/// Runs of consecutive cycles with a side's light input at 1: (side, first cycle, length,
/// whether the run reaches the end of the trace).
fn light_runs(trace: &Trace) -> Vec<(usize, usize, usize, bool)> {
    let mut runs = Vec::new();
    for side in 0..2 {
        let mut start = None;
        for (index, cycle) in trace.cycles.iter().enumerate() {
            let lit = cycle.frame.values(InputGroup::LIGHT)[side] >= 0.5;
            match (lit, start) {
                (true, None) => start = Some(index),
                (false, Some(first)) => {
                    runs.push((side, first, index - first, false));
                    start = None;
                }
                _ => {}
            }
        }
        if let Some(first) = start {
            runs.push((side, first, trace.cycles.len() - first, true));
        }
    }
    runs.sort_by_key(|&(_, first, _, _)| first);
    runs
}

#[test]
fn light_flashes_are_held_and_come_on_the_side_of_the_turn() {
    let evaluator = evaluator("solve_maze");
    let hold = spec_task("solve_maze").params.light.hold_cycles as usize;
    assert_eq!(hold, 15, "the paper holds a flash for 15 cycles");
    // The shipped layout: configurations 0 and 1 flash on the right in the first row, 2 and 3
    // on the left; in the second row 1 and 2 on the right, 0 and 3 on the left.
    let layout_sides = [[1, 0], [1, 1], [0, 1], [0, 0]];
    for configuration in 0..4u32 {
        for seed in 0..40 {
            let sample = Sample {
                seed,
                variant: Some(configuration),
            };
            let trace = evaluator.evaluate_traced(&mut solver(), sample);
            // The rows of this sample's flashing lights, in the order the robot meets them
            // driving up the stem (+y); a light at x > 0 is on the robot's right (input 1).
            let mut flashing: Vec<[f32; 2]> = trace
                .lights
                .iter()
                .filter(|(_, f)| *f)
                .map(|(p, _)| *p)
                .collect();
            flashing.sort_by(|a, b| a[1].total_cmp(&b[1]));
            let expected: Vec<usize> = flashing.iter().map(|p| usize::from(p[0] > 0.0)).collect();
            assert_eq!(
                expected, layout_sides[configuration as usize],
                "configuration {configuration}"
            );

            let runs = light_runs(&trace);
            for &(side, first, length, at_end) in &runs {
                assert!(
                    at_end || length >= hold,
                    "{sample:?}: side {side} lit for {length} cycles from {first}"
                );
            }
            assert!(
                runs.len() >= 2,
                "{sample:?}: {} flashes seen ({runs:?})",
                runs.len()
            );
            let sides: Vec<usize> = runs.iter().map(|&(side, ..)| side).collect();
            assert_eq!(sides[..2], expected[..], "{sample:?}: runs {runs:?}");
        }
    }
}

/// Runs each task's scripted policy on seeds `0..SEEDS` of the task in its default
/// configuration (`TaskConfig::new`, the default IR mapping).
fn run_default(kind: &'static str, variant: Option<u32>) -> Vec<(Sample, Outcome)> {
    let task = TaskConfig::shipped(kind).unwrap();
    let outcomes = run_on(&task, &mut Scripted::for_task(kind, &task), variant);
    assert_coherent(kind, &outcomes);
    outcomes
}

#[test]
fn the_default_configuration_is_solvable_too() {
    // The default IR mapping (model 4's average table) reads a wall 9 cm away as about 0.25,
    // close to the scripted policies' "nothing there" threshold, so a robot started off the
    // centre line beside a turn's opening can take the far wall for a second opening; the
    // counts here are lower. Measured, of 200 samples each: follow wall 200, turn left 180,
    // turn right 177, exit room 175.
    for (kind, floor) in [
        ("follow_wall", 197),
        ("turn_left", 177),
        ("turn_right", 174),
        ("exit_room", 172),
    ] {
        assert_solved(&format!("default {kind}"), &run_default(kind, None), floor);
    }
    // Per light configuration. Measured: 200 of 200 in each.
    for (configuration, floor) in [(0, 197), (1, 197), (2, 197), (3, 197)] {
        assert_solved(
            &format!("default solve_maze configuration {configuration}"),
            &run_default("solve_maze", Some(configuration)),
            floor,
        );
    }
    // Overall and per start branch. Measured: 170 of 200; 44 of 55, 43 of 46, 48 of 59 and 35
    // of 40.
    let back = run_default("return_room", None);
    assert_solved("default return_room", &back, 167);
    for (branch, floor) in [(0, 42), (1, 41), (2, 46), (3, 33)] {
        assert_solved(
            &format!("default return_room branch {branch}"),
            &of_variant(&back, branch),
            floor,
        );
    }
    // Per stage and per light configuration. Measured: 185 left the room, 161 reached the
    // teammate, 137 brought it back; 39 of 55, 29 of 46, 41 of 59 and 28 of 40.
    let rescue = run_default("rescue", None);
    assert_rescue_stages("default rescue", &rescue, [182, 158, 134]);
    for (configuration, floor) in [(0, 37), (1, 27), (2, 39), (3, 26)] {
        assert_solved(
            &format!("default rescue configuration {configuration}"),
            &of_variant(&rescue, configuration),
            floor,
        );
    }
}

#[test]
fn a_rescue_that_ends_on_wrong_branches_stops_a_wall_following_search() {
    // The room exiter follows walls, so past the exit it searches the maze branch after branch,
    // turning round at each dead end. By default a rescue sample lets it.
    let open = run("rescue", &mut exiter(), None);
    let searched_on = |outcomes: &[(Sample, Outcome)]| {
        outcomes
            .iter()
            .filter(|(_, o)| o.ending == Ending::WrongBranch)
            .count()
    };
    assert_eq!(
        searched_on(&open),
        0,
        "the default rescue has no wrong branch"
    );
    let reached_open = open.iter().filter(|(_, o)| o.stage >= 2).count();

    let mut strict_task = spec_task("rescue");
    strict_task.end_on_wrong_branch = true;
    let strict = run_on(&strict_task, &mut exiter(), None);
    let reached_strict = strict.iter().filter(|(_, o)| o.stage >= 2).count();
    // Measured: 79 of 200 end in a wrong branch, and 12 samples reach the teammate against
    // 40 with the search allowed.
    assert_count(
        "rescue by the room exiter, ending on wrong branches",
        &strict,
        |o| o.ending == Ending::WrongBranch,
        76,
    );
    assert!(
        reached_strict * 2 <= reached_open,
        "the teammate was reached {reached_strict} times with wrong branches ending the \
         sample, {reached_open} times without"
    );

    // The scripted rescuer reads the flashes and takes no wrong branch, so it still solves.
    // Measured: as without the rule, 186, 183 and 180.
    let rescued = run_on(&strict_task, &mut rescuer(), None);
    assert_coherent("rescue", &rescued);
    assert_rescue_stages("rescue ending on wrong branches", &rescued, [183, 180, 177]);
}

#[test]
fn the_rescue_time_bonus_adds_the_time_left_to_solved_samples_only() {
    let plain_task = spec_task("rescue");
    let mut bonus_task = plain_task.clone();
    bonus_task.rescue_time_bonus = true;
    let plain = run_on(&plain_task, &mut rescuer(), None);
    let bonus = run_on(&bonus_task, &mut rescuer(), None);
    let max_cycles = plain_task.max_cycles() as f32;
    let mut n_solved = 0;
    for ((sample, without), (_, with)) in plain.iter().zip(&bonus) {
        // The bonus changes the score, never the trajectory.
        assert_eq!(
            (without.ending, without.cycles),
            (with.ending, with.cycles),
            "seed {}",
            sample.seed
        );
        let expected = if without.solved {
            n_solved += 1;
            without.fitness + (max_cycles - without.cycles as f32) / max_cycles
        } else {
            without.fitness
        };
        assert!(
            (with.fitness - expected).abs() < 1e-5,
            "seed {}: {} with the bonus, {} without, solved {}",
            sample.seed,
            with.fitness,
            without.fitness,
            without.solved
        );
    }
    assert!(n_solved > 0 && n_solved < plain.len(), "{n_solved} solved");
}

#[test]
fn with_wrong_branches_judged_at_their_ends_a_wrong_turn_ends_at_the_dead_end() {
    // Against the lights the solver turns into a wrong branch and drives on to its dead end.
    // hevo's default ends the sample in the branch's first cell; the authors' rule only once
    // the robot reaches the central half of that branch's end cell, further on.
    let strict_task = spec_task("solve_maze");
    let mut lenient_task = strict_task.clone();
    lenient_task.wrong_branch_at_end_only = true;
    for configuration in 0..4 {
        let strict = run_on(
            &strict_task,
            &mut SwappedLights(solver()),
            Some(configuration),
        );
        let lenient = run_on(
            &lenient_task,
            &mut SwappedLights(solver()),
            Some(configuration),
        );
        assert_coherent("solve_maze", &lenient);
        let mut n_later = 0;
        for ((sample, at_entry), (_, at_end)) in strict.iter().zip(&lenient) {
            assert!(
                !at_end.solved,
                "seed {}: solved against the lights",
                sample.seed
            );
            if at_entry.ending == Ending::WrongBranch && at_end.ending == Ending::WrongBranch {
                assert!(
                    at_end.cycles > at_entry.cycles,
                    "seed {}: ended after {} cycles at the branch end, {} at its entry",
                    sample.seed,
                    at_end.cycles,
                    at_entry.cycles
                );
                n_later += 1;
            }
        }
        // Measured: every sample of every configuration, 200 of 200.
        assert!(
            n_later >= 197,
            "configuration {configuration}: {n_later} of {} wrong branches ended at their dead \
             end, below the floor of 197",
            strict.len()
        );
    }
}
