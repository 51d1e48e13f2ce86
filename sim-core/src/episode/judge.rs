//! The judge of one sample: it keeps what the scenario's fitness quantities track and which
//! stages have been reached, says which phase of a derived fitness is in force, ends the
//! sample on a wrong branch, a forbidden region or the goal, and gives the fitness of its
//! ending, by calling the scenario's compiled blocks.

use crate::body::Pose;
use crate::geometry::bodies::Disc;
use crate::geometry::items::Items;
use crate::network::Policy;
use crate::outcome::{Ending, N_SUB_TASKS, SubTaskChoices};
use crate::scenario::blocks::{self, CycleView, EndView, TeammateView, Tracked};
use crate::scenario::{Scenario, ending_slot};
use crate::task::TaskConfig;
use crate::world::Ground;

/// The scenario's bookkeeping of a sample: what each quantity keeps, which stages it has
/// reached, which child each phase asks for.
#[derive(Debug)]
pub(crate) struct Judge<'a> {
    task: &'a TaskConfig,
    scenario: &'a Scenario,
    /// The task's cycle limit, found once.
    max_cycles: u32,
    /// The sample's ground truth, owned for the sample's length.
    pub(crate) ground: Ground,
    /// What each of the scenario's quantities keeps, by index.
    tracked: Vec<Tracked>,
    /// Which stages have been reached.
    reached: [bool; 8],
    /// The child each phase asks for, as an output index of the root.
    pub(crate) phase_child: [usize; N_SUB_TASKS],
}

/// The child each phase of `scenario` asks for, as an output index of the policy's root: a
/// child named in the scenario is looked up among the root's children, and a name the policy
/// does not know (a scripted policy) asks for the child at the phase's own position.
pub(crate) fn phase_children(scenario: &Scenario, policy: &impl Policy) -> [usize; N_SUB_TASKS] {
    let mut phase_child = [usize::MAX; N_SUB_TASKS];
    for (idx, phase) in scenario.phases.iter().enumerate() {
        phase_child[idx] = match &phase.child {
            crate::scenario::file::ChildRef::Index(child) => *child,
            crate::scenario::file::ChildRef::Name(name) => {
                policy.root_child_index(name).unwrap_or(idx)
            }
        };
    }
    phase_child
}

impl<'a> Judge<'a> {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        task: &'a TaskConfig,
        ground: Ground,
        start: Pose,
        teammate: Option<TeammateView>,
        team: &[[f32; 2]],
        items: Option<&Items>,
        boxes: &[Disc],
        phase_child: [usize; N_SUB_TASKS],
    ) -> Judge<'a> {
        let scenario: &Scenario = &task.scenario;
        let max_cycles = task.max_cycles();
        let view = CycleView::new(
            &start,
            teammate,
            &ground,
            scenario,
            &task.params,
            max_cycles,
        )
        .with_team(team)
        .with_items(items)
        .with_boxes(boxes);
        let tracked = scenario
            .quantities
            .iter()
            .map(|(_, quantity)| quantity.start(&view))
            .collect();
        Judge {
            task,
            scenario,
            max_cycles,
            ground,
            tracked,
            reached: [false; 8],
            phase_child,
        }
    }

    /// What the blocks see of this cycle.
    #[inline]
    pub(crate) fn view<'v>(
        &'v self,
        robot: &'v Pose,
        teammate: Option<TeammateView>,
    ) -> CycleView<'v> {
        CycleView::new(
            robot,
            teammate,
            &self.ground,
            self.scenario,
            &self.task.params,
            self.max_cycles,
        )
    }

    /// The phase of the derived fitness in force, if the scenario has phases, with the team
    /// (the focal robot first) at `team`, the items as `items` say and the lights of
    /// `lit_mask` lit.
    #[inline]
    pub(crate) fn phase(
        &self,
        robot: &Pose,
        teammate: Option<TeammateView>,
        team: &[[f32; 2]],
        items: Option<&Items>,
        boxes: &[Disc],
        lit_mask: u32,
    ) -> Option<u8> {
        if self.scenario.phases.is_empty() {
            return None;
        }
        let view = self
            .view(robot, teammate)
            .with_team(team)
            .with_items(items)
            .with_boxes(boxes)
            .with_lit(lit_mask);
        self.scenario
            .phases
            .iter()
            .position(|phase| phase.when.holds(&view))
            .map(|idx| idx as u8)
    }

    /// After a cycle's move at `wheel_speeds` (m/s, as driven), in a cycle whose lit lights are
    /// `lit_mask`: the quantities observe, stages are reached, and the sample ends if it took a
    /// wrong branch, entered a forbidden region, or is solved.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn check(
        &mut self,
        robot: &Pose,
        teammate: Option<TeammateView>,
        team: &[[f32; 2]],
        items: Option<&Items>,
        boxes: &[Disc],
        wheel_speeds: [f32; 2],
        lit_mask: u32,
    ) -> Option<Ending> {
        let (scenario, task) = (self.scenario, self.task);
        let view = CycleView::new(
            robot,
            teammate,
            &self.ground,
            scenario,
            &task.params,
            self.max_cycles,
        )
        .with_wheel_speeds(wheel_speeds)
        .with_team(team)
        .with_lit(lit_mask)
        .with_items(items)
        .with_boxes(boxes);
        for ((_, quantity), tracked) in scenario.quantities.iter().zip(&mut self.tracked) {
            quantity.observe(tracked, &view);
        }
        for (idx, stage) in scenario.stages.iter().enumerate() {
            if !self.reached[idx] && stage.reached.holds(&view) {
                self.reached[idx] = true;
            }
        }
        if scenario.wrong_branch
            && (scenario.wrong_branch_ends || task.end_on_wrong_branch)
            && let Some(goal) = &self.ground.goal
            && let Some(cell) = view.robot_cell(&goal.map)
            && !goal.on_path[cell]
            && (!task.wrong_branch_at_end_only
                || goal.reached_wrong_end(robot.position(), task.params.robot.radius))
        {
            return Some(Ending::WrongBranch);
        }
        if let Some(forbidden) = &scenario.forbidden
            && forbidden.holds(&view)
        {
            return Some(Ending::WrongBranch);
        }
        scenario.solved.holds(&view).then_some(Ending::Solved)
    }

    /// The fitness of the ending and the behaviour descriptor, from what the quantities kept
    /// and see at the end.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn fitness_and_descriptor(
        &self,
        ending: Ending,
        cycles: u32,
        robot: &Pose,
        teammate: Option<TeammateView>,
        team: &[[f32; 2]],
        items: Option<&Items>,
        boxes: &[Disc],
        sub_task_choices: &SubTaskChoices,
    ) -> (f32, Vec<f32>) {
        let end = EndView {
            cycle: self
                .view(robot, teammate)
                .with_team(team)
                .with_items(items)
                .with_boxes(boxes),
            cycles,
            sub_task_choices,
        };
        let value_of = |idx: usize| {
            self.scenario.quantities[idx]
                .1
                .value(&self.tracked[idx], &end)
        };
        let descriptor = self
            .scenario
            .descriptor
            .iter()
            .map(|&idx| value_of(idx))
            .collect();
        (self.fitness_of(ending, cycles, &value_of), descriptor)
    }

    /// The fitness alone (the tests' view).
    #[cfg(test)]
    pub(crate) fn fitness(
        &self,
        ending: Ending,
        cycles: u32,
        robot: &Pose,
        teammate: Option<TeammateView>,
        sub_task_choices: &SubTaskChoices,
    ) -> f32 {
        self.fitness_and_descriptor(
            ending,
            cycles,
            robot,
            teammate,
            &[],
            None,
            &[],
            sub_task_choices,
        )
        .0
    }

    fn fitness_of(&self, ending: Ending, cycles: u32, value_of: &dyn Fn(usize) -> f32) -> f32 {
        let slot = match ending {
            Ending::Solved => ending_slot::SOLVED,
            Ending::WrongBranch => ending_slot::WRONG_BRANCH,
            Ending::Collision => ending_slot::COLLISION,
            Ending::Timeout => ending_slot::TIMEOUT,
        };
        let fitness = self.scenario.fitness[slot].eval(value_of);
        // The authors' code rewards finishing: a solved derived fitness earns the time bonus.
        if self.task.rescue_time_bonus && ending == Ending::Solved {
            fitness + blocks::quantities::time_bonus(cycles, self.max_cycles)
        } else {
            fitness
        }
    }

    pub(crate) fn stage(&self, ending: Ending) -> u8 {
        if ending == Ending::Solved {
            return self.scenario.max_stage();
        }
        self.reached[..self.scenario.stages.len()]
            .iter()
            .filter(|&&r| r)
            .count() as u8
    }
}

/// The fitness functions checked against docs/model.md section 7 on hand-built situations: each
/// expected value is the formula written out with the situation's own numbers, not a value the
/// code printed.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cells::{Cell, CellMap};
    use crate::world::{self, CellGoal};
    use std::sync::Arc;

    /// Walls on top, right, bottom, left.
    fn cell(at: [i32; 2], walls: [bool; 4]) -> Cell {
        Cell { at, walls }
    }

    /// A T-end corridor of 0.30 m cells: up from (0, 0) to the junction (0, 2), the goal arm to
    /// the left, (-1, 2) and (-2, 2), and a wrong arm to the right, (1, 2) and (2, 2). The
    /// distance table is written out by hand (0.30 m per cell step to the goal's centre), so
    /// only `CellMap`'s cell lookup is the code's.
    fn t_end_goal() -> CellGoal {
        let cells = vec![
            cell([0, 0], [false, true, true, true]),
            cell([0, 1], [false, true, false, true]),
            cell([0, 2], [true, false, false, false]),
            cell([-1, 2], [true, false, true, false]),
            cell([-2, 2], [true, false, true, true]),
            cell([1, 2], [true, false, true, false]),
            cell([2, 2], [true, true, true, false]),
        ];
        let map = Arc::new(CellMap::new(cells, 0.3, 0.1));
        CellGoal {
            map,
            on_path: vec![true, true, true, true, true, false, false],
            goal: 4,
            distances: vec![1.2, 0.9, 0.6, 0.3, 0.0, 0.9, 1.2],
            total_distance: 1.2,
            wrong_ends: vec![6],
        }
    }

    fn origin() -> Pose {
        Pose {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
        }
    }

    fn at(x: f32, y: f32) -> Pose {
        Pose { x, y, heading: 0.0 }
    }

    /// The fitness a cell task's judge gives a sample that ended so, after so many cycles, with
    /// the robot at `end`.
    fn cells_fitness(name: &str, ending: Ending, cycles: u32, end: Pose) -> f32 {
        let goal = t_end_goal();
        let ground = Ground {
            cells: Some(goal.map.clone()),
            goal: Some(goal),
            room: None,
        };
        let task = shipped(name);
        judge(&task, &ground, origin()).fitness(
            ending,
            cycles,
            &end,
            None,
            &SubTaskChoices::default(),
        )
    }

    fn shipped(name: &str) -> TaskConfig {
        TaskConfig::shipped(name).unwrap()
    }

    /// A judge of `task` over `ground`, without lights, whose phases ask for the children in
    /// their order.
    fn judge<'a>(task: &'a TaskConfig, ground: &'a Ground, start: Pose) -> Judge<'a> {
        Judge::new(
            task,
            ground.clone(),
            start,
            None,
            &[],
            None,
            &[],
            std::array::from_fn(|idx| idx),
        )
    }

    /// Choices counted in the first three phases.
    fn choices(cycles: [u32; 3], correct: [u32; 3]) -> SubTaskChoices {
        let mut all = SubTaskChoices::default();
        all.cycles[..3].copy_from_slice(&cycles);
        all.correct[..3].copy_from_slice(&correct);
        all
    }

    fn assert_close(got: f32, expected: f32, what: &str) {
        assert!(
            (got - expected).abs() <= 1e-6,
            "{what}: got {got}, expected {expected}"
        );
    }

    /// Points of the T-end corridor and their corridor distance to the goal by the rule of
    /// docs/model.md 5.1: straight to the centre of the point's cell or of an open neighbour,
    /// then 0.30 m per cell step, whichever is shortest.
    fn progress_cases() -> Vec<(Pose, f32)> {
        vec![
            // In the first cell, 0.10 m up: via (0, 1) 0.20 + 0.90 beats 0.10 + 1.20.
            (at(0.0, 0.1), 0.2 + 0.9),
            // In (0, 1), 0.05 m right of its centre: straight to the junction's centre,
            // hypot(0.05, 0.30) + 0.60, beats 0.05 + 0.90 through its own centre.
            (at(0.05, 0.3), 0.05f32.hypot(0.3) + 0.6),
            // In the junction 0.05 m below its centre: straight to (-1, 2), hypot(0.3, 0.05)
            // + 0.30, beats 0.05 + 0.60.
            (at(0.0, 0.55), 0.3f32.hypot(0.05) + 0.3),
            // In the wrong arm's first cell (1, 2), 0.20 m right of the junction's centre: back
            // through the junction, 0.20 + 0.60, beats 0.10 + 0.90 through its own centre.
            (at(0.2, 0.6), 0.2 + 0.6),
        ]
    }

    #[test]
    fn f2_of_a_solved_sample_is_one_plus_the_share_of_cycles_left() {
        // solve maze and return to room: 1000 cycles.
        for kind in ["solve_maze", "return_room"] {
            for (cycles, expected) in [
                (250, 1.0 + (1000.0 - 250.0) / 1000.0),
                (1, 1.0 + (1000.0 - 1.0) / 1000.0),
                (1000, 1.0),
            ] {
                let got = cells_fitness(kind, Ending::Solved, cycles, at(-0.6, 0.6));
                assert_close(got, expected, &format!("{kind} solved at cycle {cycles}"));
            }
        }
        assert_eq!(
            cells_fitness("solve_maze", Ending::Solved, 250, origin()),
            1.75
        );
    }

    #[test]
    fn f2_of_a_wrong_branch_or_collision_is_a_third_of_the_progress_and_of_a_timeout_zero() {
        for kind in ["solve_maze", "return_room"] {
            for (end, distance) in progress_cases() {
                let progress = (1.2 - distance) / 1.2;
                for ending in [Ending::WrongBranch, Ending::Collision] {
                    let got = cells_fitness(kind, ending, 300, end);
                    assert_close(
                        got,
                        progress / 3.0,
                        &format!("{kind} {ending:?} at {end:?}"),
                    );
                }
                // A timeout scores 0 however far the robot came (paper, f2 (iii)).
                assert_eq!(cells_fitness(kind, Ending::Timeout, 1000, end), 0.0);
            }
        }
    }

    #[test]
    fn corridor_fitness_is_f2_with_half_the_progress_for_a_timeout() {
        // follow wall, turn left, turn right: 400 cycles.
        for kind in ["follow_wall", "turn_left", "turn_right"] {
            for (cycles, expected) in [
                (100, 1.0 + (400.0 - 100.0) / 400.0),
                (399, 1.0 + (400.0 - 399.0) / 400.0),
                (400, 1.0),
            ] {
                let got = cells_fitness(kind, Ending::Solved, cycles, at(-0.6, 0.6));
                assert_close(got, expected, &format!("{kind} solved at cycle {cycles}"));
            }
            for (end, distance) in progress_cases() {
                let progress = (1.2 - distance) / 1.2;
                for ending in [Ending::WrongBranch, Ending::Collision] {
                    let got = cells_fitness(kind, ending, 120, end);
                    assert_close(
                        got,
                        progress / 3.0,
                        &format!("{kind} {ending:?} at {end:?}"),
                    );
                }
                let got = cells_fitness(kind, Ending::Timeout, 400, end);
                assert_close(got, progress / 2.0, &format!("{kind} timeout at {end:?}"));
            }
        }
    }

    #[test]
    fn progress_is_clamped_and_zero_outside_the_cells() {
        for kind in ["solve_maze", "follow_wall"] {
            // Below the first cell's centre the corridor distance exceeds the total: 0, not
            // negative.
            assert_eq!(
                cells_fitness(kind, Ending::Collision, 10, at(0.0, -0.1)),
                0.0
            );
            // Outside every cell the distance is the total: no progress.
            assert_eq!(
                cells_fitness(kind, Ending::Collision, 10, at(5.0, 5.0)),
                0.0
            );
        }
        // At the goal's centre without being judged solved (not a real ending, but the top of
        // the range): progress 1.
        assert_close(
            cells_fitness("solve_maze", Ending::WrongBranch, 10, at(-0.6, 0.6)),
            1.0 / 3.0,
            "progress 1",
        );
    }

    /// A 1.0 m square room centred on the origin with its exit 0.5 m up, on the inner face of
    /// the top wall, opening upwards. Nothing of it is generated.
    fn square_room() -> world::room::Room {
        world::room::Room {
            rects: Vec::new(),
            center: [0.0, 0.0],
            exit_center: [0.0, 0.5],
            exit_outward: [0.0, 1.0],
            start: origin(),
            size: [1.0, 1.0],
        }
    }

    #[test]
    fn f1_is_five_plus_the_time_left_or_the_share_of_the_way_to_the_exit() {
        let ground = Ground {
            room: Some(square_room()),
            ..Ground::default()
        };
        let task = shipped("exit_room");
        let none = SubTaskChoices::default();
        let fitness = |closest: f32, ending: Ending, cycles: u32| {
            let mut judge = judge(&task, &ground, origin());
            let exit = task
                .scenario
                .quantities
                .iter()
                .position(|(name, _)| name == "approach room.exit")
                .expect("f1 approaches the exit");
            judge.tracked[exit].best = closest;
            judge.fitness(ending, cycles, &origin(), None, &none)
        };
        // Exited at cycle 400 of 1000.
        assert_close(
            fitness(0.0, Ending::Solved, 400),
            5.0 + (1000.0 - 400.0) / 1000.0,
            "solved at 400",
        );
        assert_eq!(fitness(0.0, Ending::Solved, 1000), 5.0);
        // Not exited: D = 0.5 m from the centre to the exit; closest approach d.
        for (closest, ending, cycles) in [
            (0.2, Ending::Timeout, 1000),
            (0.2, Ending::Collision, 37),
            (0.45, Ending::Timeout, 1000),
            (0.0, Ending::Collision, 500),
        ] {
            assert_close(
                fitness(closest, ending, cycles),
                (0.5 - closest) / 0.5,
                &format!("closest {closest}, {ending:?}"),
            );
        }
        // Further than the centre: clamped to 0.
        assert_eq!(fitness(0.6, Ending::Timeout, 1000), 0.0);
    }

    #[test]
    fn the_room_judge_keeps_the_closest_approach_from_the_start_on() {
        let task = shipped("exit_room");
        // Starts 0.4 m from the exit, drives to 0.15 m from it, then back.
        let ground = Ground {
            room: Some(square_room()),
            ..Ground::default()
        };
        let mut judge = judge(&task, &ground, at(0.0, 0.1));
        for y in [0.2, 0.3, 0.35, 0.2, 0.0] {
            assert_eq!(
                judge.check(&at(0.0, y), None, &[], None, &[], [0.0; 2], 0),
                None
            );
        }
        let f = judge.fitness(
            Ending::Timeout,
            1000,
            &at(0.0, 0.0),
            None,
            &SubTaskChoices::default(),
        );
        assert_close(f, (0.5 - 0.15) / 0.5, "closest 0.15");
        // A judge whose robot never moves keeps its start's distance, hypot(0.1, 0.4).
        let still = self::judge(&task, &ground, at(0.1, 0.1));
        let f = still.fitness(
            Ending::Timeout,
            1000,
            &at(0.1, 0.1),
            None,
            &SubTaskChoices::default(),
        );
        assert_close(f, (0.5 - 0.1f32.hypot(0.4)) / 0.5, "start");
        // Exited: the centre a body radius beyond the exit wall's outer face, 0.10 + 0.0375 m
        // past the inner face.
        let mut judge = self::judge(&task, &ground, at(0.0, 0.0));
        assert_eq!(
            judge.check(&at(0.0, 0.5 + 0.137), None, &[], None, &[], [0.0; 2], 0),
            None
        );
        assert_eq!(
            judge.check(&at(0.0, 0.5 + 0.138), None, &[], None, &[], [0.0; 2], 0),
            Some(Ending::Solved)
        );
    }

    /// The square room with the T-end corridor's cells above it.
    fn rescue_ground() -> Ground {
        let goal = t_end_goal();
        Ground {
            room: Some(square_room()),
            cells: Some(goal.map.clone()),
            goal: Some(goal),
        }
    }

    /// The rescue's judge, over a hand-built room and maze (f3 does not look at them).
    fn rescue_fitness(
        task: &TaskConfig,
        ending: Ending,
        cycles: u32,
        choices: SubTaskChoices,
    ) -> f32 {
        let ground = rescue_ground();
        judge(task, &ground, origin()).fitness(ending, cycles, &origin(), None, &choices)
    }

    #[test]
    fn f3_sums_each_reached_sub_tasks_share_of_correct_choices() {
        let task = shipped("rescue");
        // 100 cycles in the room (90 right), 300 in the maze (150 right), 200 on the way back
        // (50 right).
        let all_three = choices([100, 300, 200], [90, 150, 50]);
        assert_eq!(
            all_three.shares()[..4],
            [Some(0.9), Some(0.5), Some(0.25), None]
        );
        assert_close(
            all_three.derived_fitness(),
            0.9 + 0.5 + 0.25,
            "three sub-tasks",
        );
        for ending in [Ending::Solved, Ending::Collision, Ending::Timeout] {
            assert_close(
                rescue_fitness(&task, ending, 600, all_three),
                0.9 + 0.5 + 0.25,
                &format!("{ending:?}"),
            );
        }
        // The teammate never found: the return is left out of the sum, not counted as 0 of 0.
        let two = choices([40, 1960, 0], [40, 490, 0]);
        assert_eq!(two.shares()[..3], [Some(1.0), Some(0.25), None]);
        assert_close(
            rescue_fitness(&task, Ending::Timeout, 2000, two),
            1.0 + 0.25,
            "two sub-tasks",
        );
        // Never left the room, always wrong: 0.
        let none_right = choices([2000, 0, 0], [0, 0, 0]);
        assert_eq!(
            rescue_fitness(&task, Ending::Timeout, 2000, none_right),
            0.0
        );
        // Everything right in every sub-task: the maximum, 3.
        let perfect = choices([7, 11, 13], [7, 11, 13]);
        assert_eq!(rescue_fitness(&task, Ending::Solved, 31, perfect), 3.0);
        assert_eq!(SubTaskChoices::default().derived_fitness(), 0.0);
    }

    #[test]
    fn the_rescue_time_bonus_is_the_share_of_cycles_left_of_a_solved_sample() {
        let mut task = shipped("rescue");
        task.rescue_time_bonus = true;
        let choices = choices([100, 300, 200], [90, 150, 50]);
        assert_close(
            rescue_fitness(&task, Ending::Solved, 1500, choices),
            0.9 + 0.5 + 0.25 + (2000.0 - 1500.0) / 2000.0,
            "solved at 1500",
        );
        for ending in [Ending::Collision, Ending::Timeout, Ending::WrongBranch] {
            assert_close(
                rescue_fitness(&task, ending, 1500, choices),
                0.9 + 0.5 + 0.25,
                &format!("{ending:?} earns no bonus"),
            );
        }
    }

    #[test]
    fn the_rescue_sub_task_is_return_once_the_teammate_follows_else_maze_inside_a_cell() {
        let ground = rescue_ground();
        let task = shipped("rescue");
        let judge = self::judge(&task, &ground, origin());
        let waiting = TeammateView {
            pose: at(-0.6, 0.6),
            following: false,
        };
        let following = TeammateView {
            following: true,
            ..waiting
        };
        // (0, 0.1) is in the corridor's first cell, (0, -0.2) below it, outside every cell.
        assert_eq!(
            judge.phase(&at(0.0, -0.2), Some(waiting), &[], None, &[], 0),
            Some(0)
        );
        assert_eq!(
            judge.phase(&at(0.0, 0.1), Some(waiting), &[], None, &[], 0),
            Some(1)
        );
        assert_eq!(
            judge.phase(&at(0.0, -0.2), Some(following), &[], None, &[], 0),
            Some(2)
        );
        assert_eq!(
            judge.phase(&at(0.0, 0.1), Some(following), &[], None, &[], 0),
            Some(2)
        );
        // The boundary of the first cell, half a cell below its centre.
        assert_eq!(
            judge.phase(&at(0.0, -0.1499), Some(waiting), &[], None, &[], 0),
            Some(1)
        );
        assert_eq!(
            judge.phase(&at(0.0, -0.1501), Some(waiting), &[], None, &[], 0),
            Some(0)
        );
        // Other tasks have no sub-tasks.
        let solve_maze = shipped("solve_maze");
        assert_eq!(
            self::judge(&solve_maze, &ground, origin()).phase(&origin(), None, &[], None, &[], 0),
            None
        );
    }
}
