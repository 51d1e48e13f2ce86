//! The fitness functions end to end, against docs/model.md section 7 (and the paper's f1, f2
//! and f3): fixed wheel commands and the scripted policies drive real samples, and each test
//! computes the expected fitness itself, from the formula written out below and from the
//! trace's own geometry (where the robot was, for how many cycles), never from the fitness
//! code. The maze's cells and paths are the table of docs/model.md 5.4 written out by hand;
//! the corridor distance is the rule of docs/model.md 5.1.
//!
//! f1 (exit room): exited 5 + (max - spent) / max; else (D - d) / D clamped to [0, 1].
//! f2 (solve maze, return to room): solved 1 + (max - spent) / max; wrong branch or collision
//! P / 3; timeout 0. Corridor fitness: as f2, but a timeout scores P / 2.
//! f3 (rescue): the sum over the sub-tasks reached of correct cycles / cycles.

use hevo_scripted::{
    CorridorFollower, MazeSolver, Rescuer, Returner, RoomExiter, TurnSide, Turner,
};
use hevo_sim_core::RectKind;
use hevo_sim_core::{Ending, Evaluator, Policy, Sample, TaskConfig, Trace};
use hevo_sim_core::{InputGroup, SensorFrame};
use std::collections::BTreeSet;

use crate::support::Fixed;

/// Side of a corridor cell, metres (docs/model.md 5.1).
const CELL: f32 = 0.30;

/// Swaps the light inputs, so a maze solver turns against the lights into a wrong branch.
#[derive(Debug)]
struct AgainstTheLights(MazeSolver);

impl Policy for AgainstTheLights {
    fn reset(&mut self) {
        self.0.reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let mut swapped = *frame;
        swapped.values_mut(InputGroup::LIGHT).reverse();
        self.0.step(&swapped, dt)
    }
}

fn traced(task: &TaskConfig, policy: &mut impl Policy, sample: Sample) -> Trace {
    let evaluator = Evaluator::new(task.clone()).expect("the paper's tasks are valid");
    let trace = evaluator.evaluate_traced(policy, sample);
    // spentCycles is the number of cycles run, the last one included: one trace entry each.
    assert_eq!(
        trace.cycles.len(),
        trace.outcome.cycles as usize,
        "{sample:?}"
    );
    trace
}

/// The grid cell holding a point: cell (i, j) is the 0.30 m square centred on (0.3 i, 0.3 j).
fn grid_cell(p: [f32; 2]) -> [i32; 2] {
    [
        (p[0] / CELL + 0.5).floor() as i32,
        (p[1] / CELL + 0.5).floor() as i32,
    ]
}

fn centre(cell: [i32; 2]) -> [f32; 2] {
    [cell[0] as f32 * CELL, cell[1] as f32 * CELL]
}

/// Corridor distance (docs/model.md 5.1) from a point to the last cell of `path` (consecutive
/// cells adjacent): straight to the centre of the point's cell or of a neighbour, plus 0.30 m per
/// cell step from there to the goal, whichever is shortest. Only path cells are tried: going
/// through a cell off the path is never shorter (it is one step further from the goal than the
/// path cell it joins, and at most one step from it). The point must be on the path or beside it.
fn corridor_distance(p: [f32; 2], path: &[[i32; 2]]) -> f32 {
    let own = grid_cell(p);
    let steps_left = |j: usize| (path.len() - 1 - j) as f32 * CELL;
    path.iter()
        .enumerate()
        .filter(|(_, c)| (c[0] - own[0]).abs() + (c[1] - own[1]).abs() <= 1)
        .map(|(j, &c)| {
            let [cx, cy] = centre(c);
            (p[0] - cx).hypot(p[1] - cy) + steps_left(j)
        })
        .reduce(f32::min)
        .unwrap_or_else(|| panic!("{p:?} (cell {own:?}) is neither on nor beside {path:?}"))
}

/// Progress P = (T - C) / T clamped to [0, 1]: T the corridor distance from the first cell's
/// centre, C from where the robot ended.
fn progress(end: [f32; 2], path: &[[i32; 2]]) -> f32 {
    let total = corridor_distance(centre(path[0]), path);
    ((total - corridor_distance(end, path)) / total).clamp(0.0, 1.0)
}

/// f2 and the corridor fitness, written out (docs/model.md 7).
fn expected_cells_fitness(maze_task: bool, ending: Ending, spent: u32, max: u32, p: f32) -> f32 {
    let max_f = max as f32;
    match ending {
        Ending::Solved => 1.0 + (max_f - spent as f32) / max_f,
        Ending::WrongBranch | Ending::Collision => p / 3.0,
        Ending::Timeout if maze_task => 0.0,
        Ending::Timeout => p / 2.0,
    }
}

/// The double T-maze's cells (docs/model.md 5.4): the stem from (0, -5) up to (0, -1), the
/// cross corridor from (-3, -1) to (3, -1), and at each end a branch up to (±3, 1) and one
/// down to (±3, -3).
fn maze_cells() -> BTreeSet<[i32; 2]> {
    let mut cells = BTreeSet::new();
    cells.extend((-5..=-1).map(|y| [0, y]));
    cells.extend((-3..=3).map(|x| [x, -1]));
    for x in [-3, 3] {
        cells.extend([[x, 1], [x, 0], [x, -2], [x, -3]]);
    }
    cells
}

/// The path of a light configuration (docs/model.md 5.4): up the stem, then right (0, 1) or
/// left (2, 3) at the first junction, then up (0, 2) or down (1, 3) the branch: a right light
/// in row 1 means right, and at the second junction a light on the turn's side.
fn maze_path(configuration: u32) -> Vec<[i32; 2]> {
    let side = if configuration < 2 { 1 } else { -1 };
    let branch = if configuration.is_multiple_of(2) {
        1
    } else {
        -1
    };
    let mut path: Vec<[i32; 2]> = (-5..=-1).map(|y| [0, y]).collect();
    path.extend((1..=3).map(|i| [side * i, -1]));
    path.extend((1..=2).map(|i| [side * 3, -1 + branch * i]));
    path
}

/// Checks the judge's ending against the trace: a timeout ran every cycle, a collision's last
/// move was undone, a solved cell task ended in the goal cell, a wrong branch off the path.
fn assert_ending_fits_the_trace(trace: &Trace, max: u32, path: &[[i32; 2]]) {
    let n = trace.cycles.len() as u32;
    let end = grid_cell(trace.final_robot.position());
    let context = format!("{:?}: ended in cell {end:?}", trace.sample);
    match trace.outcome.ending {
        Ending::Timeout => assert_eq!(n, max, "{context}"),
        Ending::Collision => {
            assert!(trace.cycles.last().is_some_and(|c| c.collided), "{context}")
        }
        Ending::Solved => assert_eq!(Some(&end), path.last(), "{context}"),
        Ending::WrongBranch => assert!(!path.contains(&end), "{context}"),
    }
    if trace.outcome.ending != Ending::Timeout {
        assert!(
            n < max || trace.outcome.ending == Ending::Solved,
            "{context}"
        );
    }
}

/// Runs `policy` on the samples and checks each fitness against f2 or the corridor fitness;
/// returns the endings seen.
fn check_cells_task(
    task: &TaskConfig,
    policy: &mut impl Policy,
    samples: &[Sample],
    path_of: &dyn Fn(&Trace) -> Vec<[i32; 2]>,
) -> Vec<Ending> {
    let maze_task = matches!(task.name(), "solve_maze" | "return_room");
    let max = task.max_cycles();
    samples
        .iter()
        .map(|&sample| {
            let trace = traced(task, policy, sample);
            let path = path_of(&trace);
            assert_ending_fits_the_trace(&trace, max, &path);
            let o = &trace.outcome;
            let p = progress(trace.final_robot.position(), &path);
            let expected = expected_cells_fitness(maze_task, o.ending, o.cycles, max, p);
            assert!(
                (o.fitness - expected).abs() <= 1e-5,
                "{} {sample:?}: {:?} after {} cycles at {:?}, progress {p}: fitness {}, \
                 expected {expected}",
                task.name(),
                o.ending,
                o.cycles,
                trace.final_robot.position(),
                o.fitness
            );
            o.ending
        })
        .collect()
}

fn samples(seeds: std::ops::Range<u64>, variant: Option<u32>) -> Vec<Sample> {
    seeds.map(|seed| Sample { seed, variant }).collect()
}

fn assert_seen(kind: &'static str, endings: &[Ending], wanted: &[Ending]) {
    for ending in wanted {
        assert!(
            endings.contains(ending),
            "{kind}: no {ending:?} among {endings:?}"
        );
    }
}

#[test]
fn maze_paths_written_out_are_the_documented_ones() {
    // The hand-written table of docs/model.md 5.4: 10 cells, 2.70 m of corridor distance, each
    // path's cells in the maze, and the four goals the four branch ends.
    let cells = maze_cells();
    assert_eq!(cells.len(), 19);
    let goals: Vec<[i32; 2]> = (0..4).map(|c| *maze_path(c).last().unwrap()).collect();
    assert_eq!(goals, [[3, 1], [3, -3], [-3, 1], [-3, -3]]);
    for configuration in 0..4 {
        let path = maze_path(configuration);
        assert_eq!(path.len(), 10);
        assert!(path.iter().all(|c| cells.contains(c)));
        let total = corridor_distance(centre(path[0]), &path);
        assert!((total - 2.7).abs() < 1e-5, "{total}");
    }
}

#[test]
fn f2_in_the_maze_is_the_formula_for_every_ending() {
    let task = TaskConfig::shipped("solve_maze").unwrap();
    let path_of = |trace: &Trace| maze_path(trace.outcome.variant);
    let mut endings = Vec::new();
    for configuration in 0..4 {
        let some = samples(0..3, Some(configuration));
        endings.extend(check_cells_task(
            &task,
            &mut MazeSolver::for_task(&task),
            &some,
            &path_of,
        ));
        endings.extend(check_cells_task(
            &task,
            &mut AgainstTheLights(MazeSolver::for_task(&task)),
            &some,
            &path_of,
        ));
        // Straight on until a wall; or 0.3-0.4 m up the stem and a wait for the time to run
        // out, which scores 0 however far the robot came.
        endings.extend(check_cells_task(
            &task,
            &mut Fixed::straight(),
            &some,
            &path_of,
        ));
        endings.extend(check_cells_task(
            &task,
            &mut Fixed::new([1.0, 1.0], 35),
            &some,
            &path_of,
        ));
    }
    assert_seen(
        "solve_maze",
        &endings,
        &[
            Ending::Solved,
            Ending::WrongBranch,
            Ending::Collision,
            Ending::Timeout,
        ],
    );
}

#[test]
fn a_maze_timeout_scores_zero_after_real_progress() {
    // The stopped driver has come some way up the stem: progress above 0, fitness 0 (a
    // corridor task would give half the progress).
    let task = TaskConfig::shipped("solve_maze").unwrap();
    let mut n_timeouts = 0;
    for sample in samples(0..6, Some(0)) {
        let trace = traced(&task, &mut Fixed::new([1.0, 1.0], 25), sample);
        if trace.outcome.ending != Ending::Timeout {
            continue;
        }
        n_timeouts += 1;
        let p = progress(trace.final_robot.position(), &maze_path(0));
        assert!(p > 0.05, "{sample:?}: progress {p}");
        assert_eq!(trace.outcome.fitness, 0.0, "{sample:?}");
    }
    assert!(n_timeouts >= 3, "{n_timeouts} timeouts");
}

#[test]
fn f2_on_the_way_back_measures_progress_towards_the_entrance() {
    let task = TaskConfig::shipped("return_room").unwrap();
    // Start branch k is configuration k's goal; the way back is its path reversed.
    let path_of = |trace: &Trace| {
        let mut path = maze_path(trace.outcome.variant);
        path.reverse();
        path
    };
    let mut endings = Vec::new();
    let some = samples(0..8, None);
    endings.extend(check_cells_task(
        &task,
        &mut Returner::for_task(&task),
        &some,
        &path_of,
    ));
    endings.extend(check_cells_task(
        &task,
        &mut Fixed::straight(),
        &some,
        &path_of,
    ));
    endings.extend(check_cells_task(
        &task,
        &mut Fixed::spin(),
        &some[..2],
        &path_of,
    ));
    assert_seen(
        "return_room",
        &endings,
        &[Ending::Solved, Ending::Collision, Ending::Timeout],
    );
}

/// A corridor's path from its goal cell (docs/model.md 5.3): up from (0, 0) to the turn cell,
/// then sideways to the goal; a straight corridor only goes up.
fn corridor_path(trace: &Trace) -> Vec<[i32; 2]> {
    let goal = grid_cell(trace.goal.expect("cell tasks name their goal"));
    let mut path: Vec<[i32; 2]> = (0..=goal[1]).map(|y| [0, y]).collect();
    let step = goal[0].signum();
    path.extend((1..=goal[0].abs()).map(|i| [step * i, goal[1]]));
    path
}

#[test]
fn corridor_fitness_is_the_formula_for_every_ending() {
    let follow = TaskConfig::shipped("follow_wall").unwrap();
    let mut endings = Vec::new();
    let some = samples(0..8, None);
    endings.extend(check_cells_task(
        &follow,
        &mut CorridorFollower::for_task(&follow),
        &some,
        &corridor_path,
    ));
    endings.extend(check_cells_task(
        &follow,
        &mut Fixed::straight(),
        &some,
        &corridor_path,
    ));
    // 0.3-0.4 m up the corridor, then a wait: a timeout with half the progress.
    endings.extend(check_cells_task(
        &follow,
        &mut Fixed::new([1.0, 1.0], 35),
        &some,
        &corridor_path,
    ));
    assert_seen(
        "follow_wall",
        &endings,
        &[Ending::Solved, Ending::Collision, Ending::Timeout],
    );

    for (kind, side, wrong) in [
        ("turn_left", TurnSide::Left, TurnSide::Right),
        ("turn_right", TurnSide::Right, TurnSide::Left),
    ] {
        let task = TaskConfig::shipped(kind).unwrap();
        let mut endings = Vec::new();
        let some = samples(0..10, None);
        for policy in [side, wrong] {
            endings.extend(check_cells_task(
                &task,
                &mut Turner::for_task(policy, &task),
                &some,
                &corridor_path,
            ));
        }
        endings.extend(check_cells_task(
            &task,
            &mut Fixed::straight(),
            &some,
            &corridor_path,
        ));
        endings.extend(check_cells_task(
            &task,
            &mut Fixed::new([1.0, 1.0], 20),
            &some[..4],
            &corridor_path,
        ));
        assert_seen(
            kind,
            &endings,
            &[
                Ending::Solved,
                Ending::WrongBranch,
                Ending::Collision,
                Ending::Timeout,
            ],
        );
    }
}

#[test]
fn a_corridor_timeout_scores_half_the_progress() {
    let task = TaskConfig::shipped("follow_wall").unwrap();
    let mut n_timeouts = 0;
    for sample in samples(0..6, None) {
        let trace = traced(&task, &mut Fixed::new([1.0, 1.0], 25), sample);
        if trace.outcome.ending != Ending::Timeout {
            continue;
        }
        n_timeouts += 1;
        let p = progress(trace.final_robot.position(), &corridor_path(&trace));
        assert!(p > 0.05, "{sample:?}: progress {p}");
        assert!(
            (trace.outcome.fitness - p / 2.0).abs() <= 1e-5,
            "{sample:?}: fitness {}, progress {p}",
            trace.outcome.fitness
        );
    }
    assert!(n_timeouts >= 3, "{n_timeouts} timeouts");
}

/// The stand-alone room's centre and its distance D to the exit's centre, from the walls: the
/// walls' bounding box is the interior plus a wall thickness all round plus the exit's
/// corridor stub outwards, so the interior's centre is the box's centre moved back half a stub.
fn room_centre_and_exit_distance(task: &TaskConfig, trace: &Trace) -> ([f32; 2], f32) {
    let (exit, outward) = trace.exit.expect("the room's trace names its exit");
    let corners: Vec<[f32; 2]> = trace
        .rects
        .iter()
        .filter(|r| r.kind == RectKind::Wall)
        .flat_map(|r| r.corners())
        .collect();
    let min = |axis: usize| {
        corners
            .iter()
            .map(|c| c[axis])
            .fold(f32::INFINITY, f32::min)
    };
    let max = |axis: usize| {
        corners
            .iter()
            .map(|c| c[axis])
            .fold(f32::NEG_INFINITY, f32::max)
    };
    let stub = task.params.room.exit_corridor_length;
    let centre = [
        0.5 * (min(0) + max(0)) - 0.5 * stub * outward[0],
        0.5 * (min(1) + max(1)) - 0.5 * stub * outward[1],
    ];
    // The exit's centre lies on the exit wall's inner face: half the interior's depth out.
    let extent = [max(0) - min(0), max(1) - min(1)];
    let depth = (extent[0] * outward[0]).abs() + (extent[1] * outward[1]).abs()
        - 2.0 * task.params.room.wall_thickness
        - stub;
    let out = (exit[0] - centre[0]) * outward[0] + (exit[1] - centre[1]) * outward[1];
    assert!(
        (out - 0.5 * depth).abs() < 1e-4,
        "{:?}: the exit is {out} out from the centre of a room {depth} deep",
        trace.sample
    );
    (centre, (exit[0] - centre[0]).hypot(exit[1] - centre[1]))
}

#[test]
fn f1_is_five_plus_the_time_left_or_the_share_of_the_way_to_the_exit() {
    let task = TaskConfig::shipped("exit_room").unwrap();
    let max = task.max_cycles() as f32;
    let mut endings = Vec::new();
    for sample in samples(0..6, None) {
        for run in 0..4 {
            let trace = match run {
                0 => traced(&task, &mut RoomExiter::for_task(&task), sample),
                1 => traced(&task, &mut Fixed::straight(), sample),
                2 => traced(&task, &mut Fixed::spin(), sample),
                _ => traced(&task, &mut Fixed::new([1.0, 1.0], 20), sample),
            };
            let o = &trace.outcome;
            let (exit, outward) = trace.exit.expect("the room's trace names its exit");
            let (_, to_exit) = room_centre_and_exit_distance(&task, &trace);
            let beyond =
                |p: [f32; 2]| (p[0] - exit[0]) * outward[0] + (p[1] - exit[1]) * outward[1];
            let expected = if o.ending == Ending::Solved {
                // Solved: the centre a body radius beyond the wall's outer face.
                assert!(
                    beyond(trace.final_robot.position())
                        > task.params.room.wall_thickness + task.params.robot.radius,
                    "{sample:?}"
                );
                5.0 + (max - o.cycles as f32) / max
            } else {
                // The closest the centre came to the exit's centre, the start included.
                let closest = trace
                    .cycles
                    .iter()
                    .map(|c| c.robot.position())
                    .chain([trace.final_robot.position()])
                    .map(|p| (p[0] - exit[0]).hypot(p[1] - exit[1]))
                    .fold(f32::INFINITY, f32::min);
                ((to_exit - closest) / to_exit).clamp(0.0, 1.0)
            };
            assert!(
                (o.fitness - expected).abs() <= 1e-5,
                "{sample:?}: {:?} after {} cycles: f1 {}, expected {expected}",
                o.ending,
                o.cycles,
                o.fitness
            );
            endings.push(o.ending);
        }
    }
    assert_seen(
        "exit_room",
        &endings,
        &[Ending::Solved, Ending::Collision, Ending::Timeout],
    );
}

/// The rescuer's driving, with the root's choice reported on a fixed schedule that has nothing
/// to do with where the robot is, and recorded cycle by cycle.
#[derive(Debug)]
struct ScheduledChoice {
    inner: Rescuer,
    schedule: fn(u32, usize) -> usize,
    cycle: u32,
    reported: Vec<usize>,
}

impl Policy for ScheduledChoice {
    fn reset(&mut self) {
        self.inner.reset();
        self.cycle = 0;
        self.reported.clear();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let wheels = self.inner.step(frame, dt);
        self.reported
            .push((self.schedule)(self.cycle, self.inner.phase()));
        self.cycle += 1;
        wheels
    }

    fn root_choice(&self) -> Option<usize> {
        self.reported.last().copied()
    }

    fn active_path(&self) -> &[usize] {
        self.inner.active_path()
    }

    fn n_nodes(&self) -> usize {
        self.inner.n_nodes()
    }
}

/// The sub-task in force in each cycle of a rescue trace, from its geometry (docs/model.md 7):
/// return once the teammate follows (it starts when the robot, after a move, is within 0.15 m
/// of it, so from the next cycle on), else solve maze when the robot's centre is in a maze
/// cell, else exit room.
fn ground_truth(trace: &Trace, near_range: f32) -> Vec<usize> {
    let cells = maze_cells();
    let mut following = false;
    let n = trace.cycles.len();
    let mut truth = Vec::with_capacity(n);
    for (i, cycle) in trace.cycles.iter().enumerate() {
        let robot = cycle.robot.position();
        truth.push(if following {
            2
        } else if cells.contains(&grid_cell(robot)) {
            1
        } else {
            0
        });
        let after = trace
            .cycles
            .get(i + 1)
            .map_or(trace.final_robot.position(), |c| c.robot.position());
        let mate = cycle.teammate.expect("the rescue has a teammate");
        following |= (mate.x - after[0]).hypot(mate.y - after[1]) < near_range;
    }
    truth
}

#[test]
fn f3_is_the_sum_of_each_sub_tasks_share_of_correct_choices() {
    let task = TaskConfig::shipped("rescue").unwrap();
    let schedules: [fn(u32, usize) -> usize; 3] = [
        // Changes child every 50 cycles, whatever happens.
        |cycle, _| (cycle as usize / 50) % 3,
        // The rescuer's own phase, but wrong every fourth cycle.
        |cycle, phase| {
            if cycle % 4 == 3 {
                (phase + 1) % 3
            } else {
                phase
            }
        },
        // The rescuer's own phase.
        |_, phase| phase,
    ];
    let mut phases_reached = BTreeSet::new();
    for schedule in schedules {
        let mut policy = ScheduledChoice {
            inner: Rescuer::for_task(&task),
            schedule,
            cycle: 0,
            reported: Vec::new(),
        };
        for sample in samples(0..4, None) {
            let trace = traced(&task, &mut policy, sample);
            let truth = ground_truth(&trace, task.params.robot.near_robot_range);
            let mut cycles = [0u32; 3];
            let mut correct = [0u32; 3];
            for (&sub_task, &chosen) in truth.iter().zip(&policy.reported) {
                cycles[sub_task] += 1;
                correct[sub_task] += u32::from(chosen == sub_task);
            }
            let o = &trace.outcome;
            assert_eq!(o.sub_task_choices.cycles[..3], cycles, "{sample:?}");
            assert_eq!(o.sub_task_choices.correct[..3], correct, "{sample:?}");
            // Sub-tasks in order, each reached one's share; the same f32 operations as any
            // careful implementation, so the sum is exact.
            let expected: f32 = (0..3)
                .filter(|&s| cycles[s] > 0)
                .map(|s| correct[s] as f32 / cycles[s] as f32)
                .fold(0.0, |sum, share| sum + share);
            assert_eq!(
                o.fitness, expected,
                "{sample:?}: cycles {cycles:?}, correct {correct:?}"
            );
            phases_reached.extend((0..3).filter(|&s| cycles[s] > 0));
        }
    }
    assert_eq!(phases_reached.len(), 3, "every sub-task is met");
}
