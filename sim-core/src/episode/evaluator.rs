//! Evaluation of one policy on one seeded sample: the control loop (sense, decide, move, judge)
//! and the task's fitness. `Evaluator` is built once per task and shared by reference between
//! threads; each call owns its own world and random streams, so results depend only on
//! (policy, task, seed, variant). A second entry point records a per-cycle trace for replays.

use super::setup::{self, Statics};
use crate::body::{Arc, Pose, move_or_collide, noisy_speed, wheel_speed};
use crate::config::ConfigError;
use crate::geometry::scene::Scene;
use crate::math::rng::{SimRng, Stream, stream_rng};
use crate::math::trig;
use crate::network::Policy;
use crate::outcome::{
    Ending, N_SUB_TASKS, NodeUse, Outcome, Sample, SubTaskChoices, Trace, TraceCycle,
};
use crate::scenario::blocks::{
    self, CycleView, EndView, Motion, TeammateBehaviour, TeammateView, Tracked,
};
use crate::scenario::{Scenario, ScenarioError, ending_slot};
use crate::sensors::frame::{InputGroup, N_GROUPS, SensorFrame};
use crate::sensors::kinds::ir_cones;
use crate::sensors::{IrCone, SenseView, Sensor, SensorRun};
use crate::task::TaskConfig;
use crate::world::lights::{LiveLight, trigger_lights};
use crate::world::{Environment, Ground};

/// Receives each cycle; the plain evaluation records nothing and compiles to nothing.
trait Recorder {
    fn record(&mut self, make: impl FnOnce() -> TraceCycle);
}

impl Recorder for () {
    #[inline(always)]
    fn record(&mut self, _make: impl FnOnce() -> TraceCycle) {}
}

impl Recorder for Vec<TraceCycle> {
    fn record(&mut self, make: impl FnOnce() -> TraceCycle) {
        self.push(make());
    }
}

/// Errors in a task configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaskError {
    /// A number out of range, or an option where it does not apply.
    #[error("invalid task configuration: {0}")]
    Config(#[from] ConfigError),
    /// The scenario's worlds, as the task builds them, break a rule of every world (a start
    /// touching a solid): the file, key and line.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

/// Samples per variant whose worlds [`Evaluator::new`] builds to check their starts: a start
/// that touches a solid is refused before any evaluation (every world's start, in the tests of
/// the shipped and example scenarios).
const START_CHECK_SEEDS: u64 = 8;

/// Evaluates policies on samples of one task. Cheap to share between threads (`&Evaluator` is
/// all a thread needs).
#[derive(Debug)]
pub struct Evaluator {
    task: TaskConfig,
    statics: Statics,
    /// By input group, the sensor compiled, if the scenario's robot carries it and anything in
    /// the scenario can excite it.
    sensors: [Option<Box<dyn Sensor>>; N_GROUPS],
}

impl Evaluator {
    /// Validates the task and builds what all its samples share; refuses a scenario whose
    /// robot starts touching a solid in the worlds of the first seeds ([`Evaluator::check_starts`]).
    pub fn new(task: TaskConfig) -> Result<Evaluator, TaskError> {
        let evaluator = Evaluator::for_drawing(task)?;
        evaluator.check_starts(START_CHECK_SEEDS)?;
        Ok(evaluator)
    }

    /// [`Evaluator::new`] without the check of the starts: for drawing a world, the refused
    /// ones included, to show what is wrong with them.
    pub fn for_drawing(task: TaskConfig) -> Result<Evaluator, TaskError> {
        task.validate()?;
        let carried = task.scenario.sensors;
        let sensed_world = task.scenario.sensed_world();
        let sensors = InputGroup::ALL.map(|group| {
            carried
                .carries(group)
                .then(|| (group.kind().compile)(&task.params, &sensed_world))
                .flatten()
        });
        Ok(Evaluator {
            statics: Statics::new(&task),
            task,
            sensors,
        })
    }

    /// Refuses a scenario whose robot starts touching a solid or in a region it forbids: it
    /// would end in its first cycle, every sample, and evolution would go on regardless.
    /// Checked on the worlds of seeds `0..seeds` of every variant, as the task (with its
    /// overrides) builds them.
    pub fn check_starts(&self, seeds: u64) -> Result<(), ScenarioError> {
        let scenario = &self.task.scenario;
        let radius = self.task.params.robot.radius;
        for variant in 0..scenario.n_variants() {
            for seed in 0..seeds {
                let sample = Sample {
                    seed,
                    variant: (scenario.n_variants() > 1).then_some(variant),
                };
                let env = self.environment(sample);
                if env.scene.disc_hits(env.start.position(), radius) {
                    let start = env.start;
                    let path = match &scenario.place.at {
                        crate::scenario::PlaceAt::VariantStart if scenario.n_variants() > 1 => {
                            format!("variant[{variant}].start")
                        }
                        _ => "place".to_string(),
                    };
                    return Err(scenario.refusal(
                        &path,
                        format!(
                            "the robot starts touching a solid: at ({:.3}, {:.3}) m in variant \
                             {variant}, seed {seed}, a robot of radius {radius} m overlaps a \
                             wall or obstacle (`hevo scenario draw --variant {variant} --seed \
                             {seed}` shows it)",
                            start.x, start.y
                        ),
                    ));
                }
                if let Some(forbidden) = &scenario.forbidden {
                    let teammate = env
                        .teammate
                        .map(|(pose, following)| TeammateView { pose, following });
                    let view = CycleView::new(
                        &env.start,
                        teammate,
                        &env.ground,
                        scenario,
                        &self.task.params,
                        self.task.max_cycles(),
                    );
                    if forbidden.holds(&view) {
                        return Err(scenario.refusal(
                            "end.forbidden",
                            format!(
                                "the robot starts where the scenario forbids it to go: at \
                                 ({:.3}, {:.3}) m in variant {variant}, seed {seed}",
                                env.start.x, env.start.y
                            ),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// The task.
    pub fn task(&self) -> &TaskConfig {
        &self.task
    }

    /// Runs one sample.
    pub fn evaluate(&self, policy: &mut impl Policy, sample: Sample) -> Outcome {
        self.run(policy, sample, &mut ()).0
    }

    /// Runs one sample and records every cycle.
    pub fn evaluate_traced(&self, policy: &mut impl Policy, sample: Sample) -> Trace {
        let mut cycles = Vec::new();
        let (outcome, env, final_robot) = self.run(policy, sample, &mut cycles);
        let goal = env.ground.goal.as_ref().map(|g| g.map.center(g.goal));
        let exit = env
            .ground
            .room
            .as_ref()
            .map(|room| (room.exit_center, room.exit_outward));
        let scenario = &self.task.scenario;
        Trace {
            scenario: scenario.name().to_string(),
            variant_label: scenario.variant_label(outcome.variant),
            has_phases: scenario.has_phases(),
            sample,
            rects: env.scene.rects().to_vec(),
            lights: env.lights.iter().map(|l| (l.position, l.flashes)).collect(),
            goal,
            exit,
            cycles,
            final_robot,
            outcome,
        }
    }

    /// The world a sample starts in, built from its environment stream as its evaluation
    /// builds it: for pictures of a scenario (its named regions, `env::regions`).
    pub fn environment(&self, sample: Sample) -> Environment {
        let mut env_rng = stream_rng(sample.seed, Stream::Environment);
        setup::build(&self.task, &self.statics, sample.variant, &mut env_rng)
    }

    /// The IR sensors' cones at a pose: for each sensor its position, the directions of its two
    /// boundary rays, and the range; for drawing.
    pub fn ir_cones(&self, pose: &Pose) -> Vec<IrCone> {
        ir_cones(&self.task.params, pose)
    }

    fn run<R: Recorder>(
        &self,
        policy: &mut impl Policy,
        sample: Sample,
        recorder: &mut R,
    ) -> (Outcome, Environment, Pose) {
        let dt = self.task.params.robot.cycle_seconds;
        policy.reset();
        let mut run = SampleRun::new(
            self,
            sample,
            policy.n_nodes(),
            phase_children(&self.task.scenario, policy),
        );
        let ending = loop {
            let frame = run.sense();
            let wheels = policy.step(&frame, dt);
            run.count_decision(policy.active_path(), policy.root_choice());
            let (before, collided) = run.move_robot(wheels);
            recorder.record(|| TraceCycle {
                robot: before,
                teammate: run.teammate.as_ref().map(|m| m.pose),
                frame,
                wheels,
                active_path: policy.active_path().iter().map(|&n| n as u16).collect(),
                collided,
                lit_lights: run.lit_mask,
                sub_task: run.sub_task.unwrap_or(0),
            });
            if let Some(ending) = run.finish_cycle(&before, collided) {
                break ending;
            }
        };
        run.finish(ending)
    }
}

/// One sample in progress: its world, random streams, robot, teammate, lights and judge, and
/// the counts its outcome reports. The control loop is split into the steps around the
/// controller (sense, count the decision, move, the rest of the cycle) so that the scalar loop
/// above and the lockstep evaluator, which steps the controllers of many samples together, run
/// the very same per-sample code.
#[derive(Debug)]
pub(crate) struct SampleRun<'e> {
    evaluator: &'e Evaluator,
    env: Environment,
    /// By input group, the sample's reading of the robot's sensor (none where the evaluator
    /// compiled none).
    sensor_runs: [Option<Box<dyn SensorRun + 'e>>; N_GROUPS],
    noise: SimRng,
    robot: Pose,
    teammate: Option<Teammate>,
    lights: Vec<LiveLight>,
    /// Each light's position, by index: what the light sensor sees of the lights.
    light_positions: Vec<[f32; 2]>,
    judge: Judge<'e>,
    active_cycles: Vec<u32>,
    activations: Vec<u32>,
    /// Per node, the last cycle (a `cycles_run`) it was active in, `u32::MAX` before any: a
    /// node active now whose last cycle is not the one before has been switched on.
    last_active_cycle: Vec<u32>,
    collided_ever: bool,
    /// Cycles begun, the current one included.
    cycles_run: u32,
    sub_task_choices: SubTaskChoices,
    /// The current cycle's rescue sub-task, from `sense`.
    sub_task: Option<u8>,
    /// The lights lit in the current cycle, from `sense`.
    lit_mask: u32,
}

impl<'e> SampleRun<'e> {
    /// Builds the sample's world and streams, for a policy of `n_nodes` nodes whose root's
    /// phase children are `phase_child`. The policy itself must be reset by the caller.
    pub(crate) fn new(
        evaluator: &'e Evaluator,
        sample: Sample,
        n_nodes: usize,
        phase_child: [usize; N_SUB_TASKS],
    ) -> SampleRun<'e> {
        let task = &evaluator.task;
        let mut env = evaluator.environment(sample);
        let mut setup = stream_rng(sample.seed, Stream::SensorSetup);
        // Started in registry order: the order they draw from the setup stream.
        let sensor_runs = std::array::from_fn(|group| {
            evaluator.sensors[group]
                .as_ref()
                .map(|sensor| sensor.start(&mut setup))
        });
        let noise: SimRng = stream_rng(sample.seed, Stream::Noise);
        let robot = env.start;
        let behaviour = task
            .scenario
            .teammate
            .as_ref()
            .map_or(blocks::BEHAVIOURS[0], |plan| plan.behaviour);
        let teammate = env.teammate.map(|(pose, following)| {
            Teammate::new(pose, following, behaviour, sample.seed, task.max_cycles())
        });
        let lights: Vec<LiveLight> = env.lights.iter().map(LiveLight::new).collect();
        let light_positions = env.lights.iter().map(|spec| spec.position).collect();
        // The judge keeps the ground truth for the sample's length; `finish` hands it back.
        let ground = std::mem::take(&mut env.ground);
        let judge = Judge::new(
            task,
            ground,
            robot,
            teammate.as_ref().map(Teammate::view),
            phase_child,
        );
        SampleRun {
            evaluator,
            env,
            sensor_runs,
            noise,
            robot,
            teammate,
            lights,
            light_positions,
            judge,
            active_cycles: vec![0; n_nodes],
            activations: vec![0; n_nodes],
            last_active_cycle: vec![u32::MAX; n_nodes],
            collided_ever: false,
            cycles_run: 0,
            sub_task_choices: SubTaskChoices::default(),
            sub_task: None,
            lit_mask: 0,
        }
    }

    /// Begins a cycle: reads every sensor at the robot's pose and notes the sub-task in force.
    #[inline]
    pub(crate) fn sense(&mut self) -> SensorFrame {
        self.sense_at(trig::sin_cos(self.robot.heading))
    }

    /// The robot's heading, whose sine and cosine [`SampleRun::sense_at`] takes.
    #[inline]
    pub(crate) fn heading(&self) -> f32 {
        self.robot.heading
    }

    /// [`SampleRun::sense`], given the sine and cosine of the robot's heading.
    #[inline]
    pub(crate) fn sense_at(&mut self, (sin_heading, cos_heading): (f32, f32)) -> SensorFrame {
        let robot = self.robot;
        self.cycles_run += 1;
        // Each light's state this cycle, before it counts the cycle down.
        let mut lit_mask = 0u32;
        for (light_idx, light) in self.lights.iter_mut().enumerate() {
            if light.lit() {
                lit_mask |= 1 << light_idx;
            }
            light.count_down();
        }
        let view = SenseView {
            robot: &robot,
            sin_heading,
            cos_heading,
            scene: &self.env.scene,
            lights: &self.light_positions,
            lit_mask,
            teammate: self.teammate.as_ref().map(|mate| &mate.pose),
        };
        let mut frame = SensorFrame::default();
        // A loop over a constant number of groups, which the compiler unrolls: one call site
        // per sensor, and each group's place in the frame a constant.
        for (group, run) in InputGroup::ALL.into_iter().zip(&mut self.sensor_runs) {
            if let Some(run) = run {
                run.read(&view, &mut self.noise, frame.values_mut(group));
            }
        }
        self.lit_mask = lit_mask;
        self.sub_task = self
            .judge
            .phase(&robot, self.teammate.as_ref().map(Teammate::view));
        frame
    }

    /// Counts the controller's decision of this cycle: which nodes drove, and whether the root
    /// chose the child the sub-task in force asks for.
    #[inline]
    pub(crate) fn count_decision(&mut self, active_path: &[usize], root_choice: Option<usize>) {
        // Only the path's nodes are touched, so a big tree costs no more than a small one.
        let cycle = self.cycles_run;
        for &node in active_path {
            if let (Some(count), Some(activations), Some(last)) = (
                self.active_cycles.get_mut(node),
                self.activations.get_mut(node),
                self.last_active_cycle.get_mut(node),
            ) {
                *count += 1;
                if *last != cycle {
                    *activations += u32::from(*last != cycle.wrapping_sub(1));
                    *last = cycle;
                }
            }
        }
        if let Some(sub_task) = self.sub_task {
            self.sub_task_choices.cycles[sub_task as usize] += 1;
            if root_choice == Some(self.judge.phase_child[sub_task as usize]) {
                self.sub_task_choices.correct[sub_task as usize] += 1;
            }
        }
    }

    /// Moves the robot by the wheel outputs, with noise, unless the move would touch a solid.
    /// Returns the pose before the move and whether it was undone.
    #[inline]
    pub(crate) fn move_robot(&mut self, wheels: [f32; 2]) -> (Pose, bool) {
        let arc = self.plan_move(wheels);
        let (sin_half_turn, _) = trig::sin_cos(arc.half_turn);
        self.finish_move(&arc, sin_half_turn, trig::sin_cos(arc.mid_heading))
    }

    /// The first half of [`SampleRun::move_robot`]: the wheel speeds with their noise (drawn
    /// here) and the arc they drive, up to its sines.
    #[inline]
    pub(crate) fn plan_move(&mut self, wheels: [f32; 2]) -> Arc {
        let robot_config = &self.evaluator.task.params.robot;
        let left = noisy_speed(
            wheel_speed(wheels[0], robot_config.v_max),
            robot_config,
            &mut self.noise,
        );
        let right = noisy_speed(
            wheel_speed(wheels[1], robot_config.v_max),
            robot_config,
            &mut self.noise,
        );
        Arc::of(&self.robot, left, right, robot_config)
    }

    /// The second half: the arc's end from its sines (`sin(half_turn)`, and the sine and
    /// cosine of the mid-arc heading), unless it touches a solid.
    #[inline]
    pub(crate) fn finish_move(
        &mut self,
        arc: &Arc,
        sin_half_turn: f32,
        mid: (f32, f32),
    ) -> (Pose, bool) {
        let robot_config = &self.evaluator.task.params.robot;
        let before = self.robot;
        let next = arc.end_pose(&self.robot, sin_half_turn, mid);
        let collided = move_or_collide(&mut self.robot, next, robot_config.radius, &self.env.scene);
        self.collided_ever |= collided;
        (before, collided)
    }

    /// Ends the cycle after the move: lights fire, the teammate moves, and the judge rules.
    /// Returns the sample's ending if it ended in this cycle (its cycle limit included).
    #[inline]
    pub(crate) fn finish_cycle(&mut self, before: &Pose, collided: bool) -> Option<Ending> {
        let task = &self.evaluator.task;
        let robot_config = &task.params.robot;
        let cycle = self.cycles_run - 1;
        trigger_lights(
            &mut self.lights,
            before,
            &self.robot,
            cycle,
            task.params.light.flash_cycles,
        );
        if let Some(mate) = self.teammate.as_mut() {
            mate.update(
                &self.robot,
                robot_config.v_max * robot_config.cycle_seconds,
                robot_config.near_robot_range,
                &self.env.scene,
                robot_config.radius,
            );
        }
        if collided && task.end_on_collision {
            return Some(Ending::Collision);
        }
        if let Some(end) = self
            .judge
            .check(&self.robot, self.teammate.as_ref().map(Teammate::view))
        {
            return Some(end);
        }
        (self.cycles_run >= task.max_cycles()).then_some(Ending::Timeout)
    }

    /// The sample's outcome, its world (for a trace) and the robot's final pose.
    pub(crate) fn finish(self, ending: Ending) -> (Outcome, Environment, Pose) {
        let judge = self.judge;
        let fitness = judge.fitness(
            ending,
            self.cycles_run,
            &self.robot,
            self.teammate.as_ref().map(Teammate::view),
            &self.sub_task_choices,
        );
        let stage = judge.stage(ending);
        let mut env = self.env;
        let outcome = Outcome {
            fitness,
            solved: ending == Ending::Solved,
            collided: self.collided_ever,
            ending,
            cycles: self.cycles_run,
            stage,
            variant: env.variant,
            node_use: NodeUse {
                active_cycles: self.active_cycles,
                activations: self.activations,
            },
            sub_task_choices: self.sub_task_choices,
        };
        env.ground = judge.ground;
        (outcome, env, self.robot)
    }
}

/// The other robot: met when the robot comes within the near-robot range, moving as its
/// behaviour ([`blocks::teammates`]) says before and after.
#[derive(Debug)]
struct Teammate {
    pose: Pose,
    /// Whether it has been met (and so, unless fixed, follows).
    following: bool,
    motion: Box<dyn Motion>,
}

impl Teammate {
    fn new(
        mut pose: Pose,
        following: bool,
        behaviour: &dyn TeammateBehaviour,
        sample_seed: u64,
        max_cycles: u32,
    ) -> Teammate {
        let motion = behaviour.start(&mut pose, sample_seed, max_cycles);
        Teammate {
            pose,
            following,
            motion,
        }
    }

    fn view(&self) -> TeammateView {
        TeammateView {
            pose: self.pose,
            following: self.following,
        }
    }

    fn update(&mut self, robot: &Pose, step: f32, near_range: f32, scene: &Scene, radius: f32) {
        if !self.following {
            if self.pose.distance_to(robot.position()) < near_range {
                self.following = true;
            } else {
                self.motion.before_met(&mut self.pose, step, scene, radius);
                return;
            }
        }
        self.motion.after_met(&mut self.pose, robot, step);
    }
}

/// The scenario's bookkeeping of a sample: what each quantity keeps, which stages it has
/// reached, which child each phase asks for.
#[derive(Debug)]
struct Judge<'a> {
    task: &'a TaskConfig,
    scenario: &'a Scenario,
    /// The task's cycle limit, found once.
    max_cycles: u32,
    /// The sample's ground truth, owned for the sample's length.
    ground: Ground,
    /// What each of the scenario's quantities keeps, by index.
    tracked: Vec<Tracked>,
    /// Which stages have been reached.
    reached: [bool; 8],
    /// The child each phase asks for, as an output index of the root.
    phase_child: [usize; N_SUB_TASKS],
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
    fn new(
        task: &'a TaskConfig,
        ground: Ground,
        start: Pose,
        teammate: Option<TeammateView>,
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
        );
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
    fn view<'v>(&'v self, robot: &'v Pose, teammate: Option<TeammateView>) -> CycleView<'v> {
        CycleView::new(
            robot,
            teammate,
            &self.ground,
            self.scenario,
            &self.task.params,
            self.max_cycles,
        )
    }

    /// The phase of the derived fitness in force, if the scenario has phases.
    #[inline]
    fn phase(&self, robot: &Pose, teammate: Option<TeammateView>) -> Option<u8> {
        if self.scenario.phases.is_empty() {
            return None;
        }
        let view = self.view(robot, teammate);
        self.scenario
            .phases
            .iter()
            .position(|phase| phase.when.holds(&view))
            .map(|idx| idx as u8)
    }

    /// After a cycle's move: the quantities observe, stages are reached, and the sample ends
    /// if it took a wrong branch, entered a forbidden region, or is solved.
    #[inline]
    fn check(&mut self, robot: &Pose, teammate: Option<TeammateView>) -> Option<Ending> {
        let (scenario, task) = (self.scenario, self.task);
        let view = CycleView::new(
            robot,
            teammate,
            &self.ground,
            scenario,
            &task.params,
            self.max_cycles,
        );
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

    fn fitness(
        &self,
        ending: Ending,
        cycles: u32,
        robot: &Pose,
        teammate: Option<TeammateView>,
        sub_task_choices: &SubTaskChoices,
    ) -> f32 {
        let end = EndView {
            cycle: self.view(robot, teammate),
            cycles,
            sub_task_choices,
        };
        let value_of = |idx: usize| {
            self.scenario.quantities[idx]
                .1
                .value(&self.tracked[idx], &end)
        };
        let slot = match ending {
            Ending::Solved => ending_slot::SOLVED,
            Ending::WrongBranch => ending_slot::WRONG_BRANCH,
            Ending::Collision => ending_slot::COLLISION,
            Ending::Timeout => ending_slot::TIMEOUT,
        };
        let fitness = self.scenario.fitness[slot].eval(&value_of);
        // The authors' code rewards finishing: a solved derived fitness earns the time bonus.
        if self.task.rescue_time_bonus && ending == Ending::Solved {
            fitness + blocks::quantities::time_bonus(cycles, self.max_cycles)
        } else {
            fitness
        }
    }

    fn stage(&self, ending: Ending) -> u8 {
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
            assert_eq!(judge.check(&at(0.0, y), None), None);
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
        assert_eq!(judge.check(&at(0.0, 0.5 + 0.137), None), None);
        assert_eq!(
            judge.check(&at(0.0, 0.5 + 0.138), None),
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
        assert_eq!(judge.phase(&at(0.0, -0.2), Some(waiting)), Some(0));
        assert_eq!(judge.phase(&at(0.0, 0.1), Some(waiting)), Some(1));
        assert_eq!(judge.phase(&at(0.0, -0.2), Some(following)), Some(2));
        assert_eq!(judge.phase(&at(0.0, 0.1), Some(following)), Some(2));
        // The boundary of the first cell, half a cell below its centre.
        assert_eq!(judge.phase(&at(0.0, -0.1499), Some(waiting)), Some(1));
        assert_eq!(judge.phase(&at(0.0, -0.1501), Some(waiting)), Some(0));
        // Other tasks have no sub-tasks.
        let solve_maze = shipped("solve_maze");
        assert_eq!(
            self::judge(&solve_maze, &ground, origin()).phase(&origin(), None),
            None
        );
    }
}
