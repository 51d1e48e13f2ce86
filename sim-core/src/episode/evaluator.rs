//! Evaluation of one policy on one seeded sample: the control loop (sense, decide, move, judge;
//! the judge and the task's fitness are [`super::judge`]). `Evaluator` is built once per task
//! and shared by reference between threads; each call owns its own world and random streams,
//! so results depend only on (policy, task, seed, variant). A second entry point records a
//! per-cycle trace for replays.

use super::judge::{Judge, phase_children};
use super::setup::{self, Statics};
use super::stepping::{Episode, Recorder};
use super::team::Team;
use crate::body::{Arc, Pose, move_or_collide, noisy_speed, wheel_speed};
use crate::config::ConfigError;
use crate::geometry::bodies::{Bodies, Disc, MoverPath, PathMode, leg_meets_solid, overlaps_any};
use crate::geometry::items::{ITEM_RADIUS, ItemState, Items};
use crate::geometry::reach::Reach;
use crate::geometry::scene::Scene;
use crate::math::rng::{SimRng, Stream, stream_rng};
use crate::math::trig;
use crate::network::Policy;
use crate::outcome::{
    CycleItem, Ending, N_SUB_TASKS, NodeUse, Outcome, Sample, SubTaskChoices, Trace, TracedBox,
    TracedItem, TracedMover,
};
use crate::scenario::blocks::{self, CycleView, Motion, TeammateBehaviour, TeammateView};
use crate::scenario::{Scenario, ScenarioError};
use crate::sensors::frame::{InputGroup, N_GROUPS, SensorFrame};
use crate::sensors::kinds::ir_cones;
use crate::sensors::{IrCone, SenseView, Sensor, SensorRun};
use crate::task::TaskConfig;
use crate::world::Environment;
use crate::world::lights::{LiveLight, trigger_lights};

/// Errors in a task configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TaskError {
    /// A number out of range, or an option where it does not apply.
    #[error("invalid task configuration: {0}")]
    Config(ConfigError),
    /// The scenario's worlds, as the task builds them, break a rule of every world (a start
    /// touching a solid): the file, key and line.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
}

// By hand rather than `#[from]`, which would also make the cause a `source()` that `{:#}`
// prints a second time after the message.
impl From<ConfigError> for TaskError {
    fn from(error: ConfigError) -> Self {
        TaskError::Config(error)
    }
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

/// Why a start lies outside its world, if it does: not a finite point, or in a map world
/// outside every open cell (a map has walls only between open and solid cells, so a start in
/// a solid cell touches none and would run every sample to its limit).
fn start_outside_the_world(scenario: &Scenario, [x, y]: [f32; 2]) -> Option<&'static str> {
    if !(x.is_finite() && y.is_finite()) {
        return Some("at no point");
    }
    let map = scenario
        .map
        .as_ref()
        .filter(|_| scenario.world.is_map_alone())?;
    map.map
        .cell_at([x, y])
        .is_none()
        .then_some("outside every open cell of the map")
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

    /// Refuses a scenario whose robot starts outside its world, touching a solid or in a
    /// region it forbids: it would end in its first cycle (or never move on), every sample,
    /// and evolution would go on regardless.
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
                if let Some(why) = start_outside_the_world(scenario, env.start.position()) {
                    return Err(scenario.refusal(
                        "place",
                        format!(
                            "the robot starts {why}: at ({:.3}, {:.3}) m in variant {variant}, \
                             seed {seed} (`hevo scenario draw --variant {variant} --seed {seed}` \
                             shows it)",
                            env.start.x, env.start.y
                        ),
                    ));
                }
                self.check_team_starts(&env, variant, seed)?;
                self.check_items(&env, variant, seed)?;
                self.check_bodies(&env, variant, seed)?;
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

    /// Refuses a mover whose path leaves the world or whose leg a wall crosses (for the mover's
    /// disc, swept along the leg), a robot or item that starts on a mover's start (the focal
    /// robot's fixed start, or a region with no room clear of it), and a box that starts
    /// touching a solid, a robot, an item, a mover or another box.
    fn check_bodies(
        &self,
        env: &Environment,
        variant: u32,
        seed: u64,
    ) -> Result<(), ScenarioError> {
        let scenario = &self.task.scenario;
        if !scenario.has_bodies() {
            return Ok(());
        }
        let radius = self.task.params.robot.radius;
        // The walls' bounds: a waypoint beyond them is outside the world.
        let [x0, y0, x1, y1] = reach_bounds(&env.scene, &[], 0.0);
        let in_sample = format!("in variant {variant}, seed {seed}");
        for (mover_idx, path) in scenario.movers.iter().enumerate() {
            let key = |point_idx: usize| format!("movers[{mover_idx}].path[{point_idx}]");
            for (point_idx, &[x, y]) in path.points.iter().enumerate() {
                let outside = !((x0..=x1).contains(&x) && (y0..=y1).contains(&y))
                    || start_outside_the_world(scenario, [x, y]).is_some();
                if outside {
                    return Err(scenario.refusal(
                        &key(point_idx),
                        format!(
                            "the waypoint ({x}, {y}) m of mover '{}' lies outside the world \
                             {in_sample}",
                            path.name
                        ),
                    ));
                }
            }
            for (leg_idx, (from, to)) in path.legs().enumerate() {
                if leg_meets_solid(&env.scene, from, to, path.radius) {
                    return Err(scenario.refusal(
                        &key(leg_idx),
                        format!(
                            "the leg of mover '{}' from ({}, {}) to ({}, {}) m passes within its \
                             radius ({} m) of a wall or obstacle {in_sample}",
                            path.name, from[0], from[1], to[0], to[1], path.radius
                        ),
                    ));
                }
            }
            let start = path.start_disc();
            if start.overlaps(env.start.position(), radius) {
                return Err(scenario.refusal(
                    "place",
                    format!(
                        "the robot starts on mover '{}' at ({:.3}, {:.3}) m {in_sample}; move the \
                         start or the mover's `start`",
                        path.name, env.start.x, env.start.y
                    ),
                ));
            }
        }
        let group_of = member_groups(&scenario.box_groups, |group| group.count);
        let mover_starts: Vec<Disc> = scenario.movers.iter().map(MoverPath::start_disc).collect();
        for (box_idx, (disc, (group_idx, group))) in env.boxes.iter().zip(group_of).enumerate() {
            let touches_robot = std::iter::once(&env.start)
                .chain(&env.team)
                .any(|robot| disc.overlaps(robot.position(), radius));
            let touches_item = env
                .items
                .iter()
                .any(|&item| disc.overlaps(item, ITEM_RADIUS));
            let touching = if touches_robot {
                Some("a robot")
            } else if touches_item {
                Some("an item")
            } else if overlaps_any(&mover_starts, disc.center, disc.radius) {
                Some("a mover")
            } else if overlaps_any(&env.boxes[..box_idx], disc.center, disc.radius) {
                Some("another box")
            } else if env.scene.disc_hits_wide(disc.center, disc.radius) {
                Some("a solid")
            } else {
                None
            };
            if let Some(touching) = touching {
                return Err(scenario.refusal(
                    &format!("boxes[{group_idx}].region"),
                    format!(
                        "the region '{}' has no room for the {} boxes of group '{}' clear of \
                         walls, robots, items, movers and each other: one stands touching \
                         {touching} at ({:.3}, {:.3}) m {in_sample}; give the group a larger region \
                         or fewer boxes",
                        scenario.file.box_groups[group_idx].region,
                        group.count,
                        group.name,
                        disc.center[0],
                        disc.center[1]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses a team robot that starts touching a solid or another robot: its region had no
    /// room clear of them in [`setup`]'s tries.
    fn check_team_starts(
        &self,
        env: &Environment,
        variant: u32,
        seed: u64,
    ) -> Result<(), ScenarioError> {
        let scenario = &self.task.scenario;
        let radius = self.task.params.robot.radius;
        let group_of = member_groups(&scenario.robot_groups, |group| group.count);
        for ((member, pose), (group_idx, group)) in env.team.iter().enumerate().zip(group_of) {
            let earlier = std::iter::once(&env.start).chain(&env.team[..member]);
            let touches_robot = earlier
                .into_iter()
                .any(|other| other.distance_to(pose.position()) < 2.0 * radius)
                || touches_a_mover(scenario, pose.position(), radius);
            if touches_robot || env.scene.disc_hits(pose.position(), radius) {
                return Err(scenario.refusal(
                    &format!("robots[{group_idx}].region"),
                    format!(
                        "the region '{}' has no room for the {} robots of group '{}' clear of \
                         walls, movers and each other: one starts touching {} at ({:.3}, {:.3}) m \
                         in variant {variant}, seed {seed}; give the group a larger region or \
                         fewer robots",
                        scenario.file.robot_groups[group_idx].region,
                        group.count,
                        group.name,
                        if touches_robot {
                            "another robot or a mover"
                        } else {
                            "a solid"
                        },
                        pose.x,
                        pose.y
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses an item that starts touching a solid or a robot (its region had no room clear
    /// of them in [`setup`]'s tries), and a nest where no robot's centre can be without
    /// touching a solid (a `[regions]` rectangle tried on a grid of 17 by 17 points; a map
    /// region's cells and the room are open).
    fn check_items(&self, env: &Environment, variant: u32, seed: u64) -> Result<(), ScenarioError> {
        let scenario = &self.task.scenario;
        let radius = self.task.params.robot.radius;
        for (&at, (group_idx, group)) in env
            .items
            .iter()
            .zip(member_groups(&scenario.object_groups, |group| group.count))
        {
            let touches_robot = std::iter::once(&env.start)
                .chain(&env.team)
                .any(|robot| robot.distance_to(at) <= radius + ITEM_RADIUS)
                || touches_a_mover(scenario, at, ITEM_RADIUS);
            if touches_robot || env.scene.disc_hits(at, ITEM_RADIUS) {
                return Err(scenario.refusal(
                    &format!("objects[{group_idx}].region"),
                    format!(
                        "the region '{}' has no room for the {} items of group '{}' clear of \
                         walls, robots and each other: one lies touching {} at ({:.3}, {:.3}) m \
                         in variant {variant}, seed {seed}; give the group a larger region or \
                         fewer items",
                        scenario.file.object_groups[group_idx].region,
                        group.count,
                        group.name,
                        if touches_robot {
                            "a robot or a mover"
                        } else {
                            "a solid"
                        },
                        at[0],
                        at[1]
                    ),
                ));
            }
        }
        if let Some(nest) = &scenario.nest
            && let crate::scenario::blocks::atoms::RegionTest::Rect(nest_rect) = nest.test
        {
            let [x0, y0, x1, y1] = nest_rect;
            const STEPS: u16 = 16;
            let mut grid = (0..=STEPS).flat_map(|i| {
                (0..=STEPS).map(move |j| {
                    let (u, v) = (
                        f32::from(i) / f32::from(STEPS),
                        f32::from(j) / f32::from(STEPS),
                    );
                    [x0 + u * (x1 - x0), y0 + v * (y1 - y0)]
                })
            });
            if !grid.any(|at| !env.scene.disc_hits(at, radius)) {
                return Err(scenario.refusal(
                    "nest.region",
                    format!(
                        "no robot can reach the nest '{}': every point of it lies within a \
                         robot's radius ({radius} m) of a solid in variant {variant}, seed \
                         {seed}; move it clear of the walls",
                        nest.name
                    ),
                ));
            }
            // Somewhere in the nest must be reachable from where the robots start, and so
            // must every item.
            let starts: Vec<[f32; 2]> = std::iter::once(&env.start)
                .chain(&env.team)
                .map(Pose::position)
                .collect();
            let reach = Reach::flood(
                &env.scene,
                radius,
                reach_bounds(
                    &env.scene,
                    &[&starts, &env.items, &[[x0, y0], [x1, y1]]],
                    radius,
                ),
                &starts,
            );
            if !reach.enters(nest_rect) {
                return Err(scenario.refusal(
                    "nest.region",
                    format!(
                        "no robot can reach the nest '{}' from where the robots start: walls \
                         close it off in variant {variant}, seed {seed} (`hevo scenario draw \
                         --variant {variant} --seed {seed}` shows it)",
                        nest.name
                    ),
                ));
            }
            for (&at, (group_idx, _)) in env
                .items
                .iter()
                .zip(member_groups(&scenario.object_groups, |group| group.count))
            {
                if !reach.comes_within(at, radius + ITEM_RADIUS) {
                    return Err(scenario.refusal(
                        &format!("objects[{group_idx}].region"),
                        format!(
                            "no robot can reach the item at ({:.3}, {:.3}) m from where the \
                             robots start: walls close it off in variant {variant}, seed {seed}",
                            at[0], at[1]
                        ),
                    ));
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
        self.run(policy, sample, &mut ()).outcome
    }

    /// Runs one sample and records every cycle.
    pub fn evaluate_traced(&self, policy: &mut impl Policy, sample: Sample) -> Trace {
        let mut cycles = Vec::new();
        let Finished {
            outcome,
            env,
            robot: final_robot,
            team: final_team,
            items,
            bodies,
        } = self.run(policy, sample, &mut cycles);
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
            team_groups: scenario
                .robot_groups
                .iter()
                .map(|group| (group.name.clone(), group.count))
                .collect(),
            items: items.map_or_else(Vec::new, |items| traced_items(&env.items, &items)),
            movers: bodies.as_ref().map_or_else(Vec::new, |bodies| {
                traced_movers(&scenario.movers, bodies.movers().discs())
            }),
            boxes: bodies.as_ref().map_or_else(Vec::new, |bodies| {
                traced_boxes(&env.boxes, bodies.boxes().discs())
            }),
            final_robot,
            final_team,
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
    ) -> Finished {
        let dt = self.task.params.robot.cycle_seconds;
        policy.reset();
        let mut episode = Episode::for_policy(
            self,
            sample,
            policy.n_nodes(),
            phase_children(&self.task.scenario, policy),
        );
        episode.drive_team_with(policy);
        let ending = loop {
            let wheels = policy.step(episode.frame(), dt);
            if let Some(ending) =
                episode.cycle(wheels, policy.active_path(), policy.root_choice(), recorder)
            {
                break ending;
            }
        };
        episode.finish(ending)
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
    /// A team's other robots, in scenarios with `[[robots]]`.
    team: Option<Team<'e>>,
    /// The items, in scenarios with `[[objects]]`.
    items: Option<Items>,
    /// The movers and boxes, in scenarios with `[[movers]]` or `[[boxes]]`.
    bodies: Option<Bodies>,
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
    /// The wheel speeds driven in the current cycle (noise included), m/s, from `plan_move`.
    wheel_speeds: [f32; 2],
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
        let team = Team::new(task, &evaluator.sensors, sample, &env.team, &robot);
        let items = (!task.scenario.object_groups.is_empty())
            .then(|| Items::new(env.items.clone(), task.scenario.n_robots()));
        let bodies = task
            .scenario
            .has_bodies()
            .then(|| Bodies::new(&task.scenario.movers, env.boxes.clone()));
        let lights: Vec<LiveLight> = env.lights.iter().map(LiveLight::new).collect();
        let light_positions = env.lights.iter().map(|spec| spec.position).collect();
        // The judge keeps the ground truth for the sample's length; `finish` hands it back.
        let ground = std::mem::take(&mut env.ground);
        let judge = Judge::new(
            task,
            ground,
            robot,
            teammate.as_ref().map(Teammate::view),
            team.as_ref().map_or(&[][..], Team::positions),
            items.as_ref(),
            boxes_of(bodies.as_ref()),
            phase_child,
        );
        SampleRun {
            evaluator,
            env,
            sensor_runs,
            noise,
            robot,
            teammate,
            team,
            items,
            bodies,
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
            wheel_speeds: [0.0; 2],
        }
    }

    /// Cycles begun, the current one included.
    #[inline]
    pub(crate) fn cycles_run(&self) -> u32 {
        self.cycles_run
    }

    /// The variant the sample runs.
    pub(crate) fn variant(&self) -> u32 {
        self.env.variant
    }

    /// Gives a team's `evolved` robots their own copies of `policy`.
    pub(crate) fn drive_team_with(&mut self, policy: &dyn Policy) {
        let dt = self.evaluator.task.params.robot.cycle_seconds;
        if let Some(team) = self.team.as_mut() {
            team.drive_with(policy, dt);
        }
    }

    /// A team's other robots' poses, group by group (none without a team).
    pub(crate) fn team_poses(&self) -> Vec<Pose> {
        self.team.as_ref().map_or_else(Vec::new, Team::poses)
    }

    /// The teammate's pose, where the task has one.
    #[inline]
    pub(crate) fn teammate_pose(&self) -> Option<Pose> {
        self.teammate.as_ref().map(|mate| mate.pose)
    }

    /// The lights lit in the current cycle.
    #[inline]
    pub(crate) fn lit_mask(&self) -> u32 {
        self.lit_mask
    }

    /// The current cycle's rescue sub-task, if any.
    #[inline]
    pub(crate) fn sub_task(&self) -> Option<u8> {
        self.sub_task
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
        let cycle = self.cycles_run - 1;
        for (light_idx, light) in self.lights.iter_mut().enumerate() {
            if light.lit(cycle) {
                lit_mask |= 1 << light_idx;
            }
            light.count_down();
        }
        if let Some(team) = self.team.as_mut() {
            team.gather(&robot);
        }
        // What every robot of the sample shares; the focal robot adds its teammate and crowd.
        let shared = SenseView {
            robot: &robot,
            sin_heading,
            cos_heading,
            scene: &self.env.scene,
            lights: &self.light_positions,
            lit_mask,
            teammate: None,
            crowd: None,
            me: 0,
            items: self.items.as_ref(),
            bodies: self.bodies.as_ref().map_or(&[][..], Bodies::discs),
        };
        let view = SenseView {
            teammate: self.teammate.as_ref().map(|mate| &mate.pose),
            crowd: self.team.as_ref().map(Team::crowd),
            ..shared
        };
        let frame = SensorFrame::read(&mut self.sensor_runs, &view, &mut self.noise);
        if let Some(team) = self.team.as_mut() {
            team.sense(&shared);
        }
        self.lit_mask = lit_mask;
        self.sub_task = self.judge.phase(
            &robot,
            self.teammate.as_ref().map(Teammate::view),
            self.team.as_ref().map_or(&[][..], Team::positions),
            self.items.as_ref(),
            boxes_of(self.bodies.as_ref()),
            lit_mask,
        );
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
        self.wheel_speeds = [left, right];
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
        let step = robot_config.v_max * robot_config.cycle_seconds;
        let radius = robot_config.radius;
        let collided = match (&self.team, self.bodies.as_mut()) {
            (Some(team), _) if team.blocks_focal(next.position(), radius, step) => true,
            (_, None) => move_or_collide(&mut self.robot, next, radius, &self.env.scene),
            // Walls first, then the movers and boxes: a box is pushed only by a move that
            // would otherwise stand.
            (team, Some(bodies)) => {
                let scene = &self.env.scene;
                let admitted = !scene.disc_hits(next.position(), radius)
                    && bodies.admit(next.position(), radius, scene, |disc| {
                        team.as_ref()
                            .is_some_and(|team| team.overlaps_robot(disc, 0, &before, step))
                    });
                if admitted {
                    self.robot = next;
                }
                !admitted
            }
        };
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
        if let Some(team) = self.team.as_mut() {
            team.move_members(&self.robot, task, &self.env.scene, self.bodies.as_mut());
        }
        self.move_movers();
        self.move_items();
        if collided && task.end_on_collision {
            return Some(Ending::Collision);
        }
        let team_positions = self.team.as_ref().map_or(&[][..], Team::positions);
        if let Some(end) = self.judge.check(
            &self.robot,
            self.teammate.as_ref().map(Teammate::view),
            team_positions,
            self.items.as_ref(),
            boxes_of(self.bodies.as_ref()),
            self.wheel_speeds,
            self.lit_mask,
        ) {
            return Some(end);
        }
        (self.cycles_run >= task.max_cycles()).then_some(Ending::Timeout)
    }

    /// Every mover and box at the start of the cycle, the movers first (none without).
    pub(crate) fn body_centres(&self) -> Vec<[f32; 2]> {
        self.bodies.as_ref().map_or_else(Vec::new, |bodies| {
            bodies.discs().iter().map(|disc| disc.center).collect()
        })
    }

    /// Every item at the start of the cycle, by item (none without items).
    pub(crate) fn item_places(&self) -> Vec<CycleItem> {
        self.items
            .as_ref()
            .map_or_else(Vec::new, |items| item_places(items).collect())
    }

    /// After every robot's move: the movers advance, each unless a robot or a box is in its
    /// way.
    fn move_movers(&mut self) {
        let Some(bodies) = self.bodies.as_mut() else {
            return;
        };
        let task = &self.evaluator.task;
        let alone = [self.robot.position()];
        let robots = self.team.as_ref().map_or(&alone[..], Team::positions);
        let robot = &task.params.robot;
        bodies.end_cycle(
            &task.scenario.movers,
            robot.cycle_seconds,
            robots,
            robot.radius,
        );
    }

    /// After every robot's move: items are picked up and delivered, robot by robot, the
    /// focal robot first.
    fn move_items(&mut self) {
        let Some(items) = self.items.as_mut() else {
            return;
        };
        let task = &self.evaluator.task;
        let nest = task.scenario.nest.as_ref().expect("items come with a nest");
        let alone = [self.robot.position()];
        let robots = self.team.as_ref().map_or(&alone[..], Team::positions);
        let view = self
            .judge
            .view(&self.robot, self.teammate.as_ref().map(Teammate::view));
        items.step(robots, task.params.robot.radius + ITEM_RADIUS, |at| {
            nest.test.contains(&view, at)
        });
    }

    /// The sample's outcome, its world and every robot's final pose.
    pub(crate) fn finish(self, ending: Ending) -> Finished {
        let judge = self.judge;
        let (fitness, descriptor) = judge.fitness_and_descriptor(
            ending,
            self.cycles_run,
            &self.robot,
            self.teammate.as_ref().map(Teammate::view),
            self.team.as_ref().map_or(&[][..], Team::positions),
            self.items.as_ref(),
            boxes_of(self.bodies.as_ref()),
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
            descriptor,
        };
        env.ground = judge.ground;
        Finished {
            outcome,
            env,
            robot: self.robot,
            team: self.team.as_ref().map_or_else(Vec::new, Team::poses),
            items: self.items,
            bodies: self.bodies,
        }
    }
}

/// An ended sample: its outcome, its world (for a trace) and where every robot ended.
pub(crate) struct Finished {
    pub(crate) outcome: Outcome,
    pub(crate) env: Environment,
    /// The focal robot's final pose.
    pub(crate) robot: Pose,
    /// The team's other robots' final poses, group by group (empty without a team).
    pub(crate) team: Vec<Pose>,
    /// The items as they ended, in a scenario with `[[objects]]`.
    pub(crate) items: Option<Items>,
    /// The movers and boxes as they ended, in a scenario with either.
    pub(crate) bodies: Option<Bodies>,
}

/// Where each item of `items` is now and in which state, by item.
fn item_places(items: &Items) -> impl Iterator<Item = CycleItem> + '_ {
    items
        .positions()
        .iter()
        .zip(items.states())
        .map(|(&at, state)| CycleItem {
            at,
            carried: matches!(state, ItemState::Carried(_)),
            delivered: *state == ItemState::Delivered,
        })
}

/// Each item of a trace: where it started (`starts`) and how it ended (`end`).
fn traced_items(starts: &[[f32; 2]], end: &Items) -> Vec<TracedItem> {
    starts
        .iter()
        .zip(item_places(end))
        .map(|(&start, place)| TracedItem {
            start,
            end: place.at,
            delivered: place.delivered,
            carried: place.carried,
        })
        .collect()
}

/// Where the boxes of `bodies` stand now (none without boxes).
fn boxes_of(bodies: Option<&Bodies>) -> &[Disc] {
    bodies.map_or(&[][..], |bodies| bodies.boxes().discs())
}

/// Whether a disc of `radius` at `at` overlaps a mover's start.
fn touches_a_mover(scenario: &Scenario, at: [f32; 2], radius: f32) -> bool {
    scenario
        .movers
        .iter()
        .any(|path| path.start_disc().overlaps(at, radius))
}

/// Each mover of a trace: its path (`paths`) and where it ended (`end`).
fn traced_movers(paths: &[MoverPath], end: &[Disc]) -> Vec<TracedMover> {
    paths
        .iter()
        .zip(end)
        .map(|(path, disc)| TracedMover {
            name: path.name.clone(),
            radius: path.radius,
            path: path.points.clone(),
            looped: path.mode == PathMode::Loop,
            end: disc.center,
        })
        .collect()
}

/// Each box of a trace: where it started (`starts`) and where it ended (`end`).
fn traced_boxes(starts: &[Disc], end: &[Disc]) -> Vec<TracedBox> {
    starts
        .iter()
        .zip(end)
        .map(|(start, end)| TracedBox {
            radius: start.radius,
            start: start.center,
            end: end.center,
        })
        .collect()
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

/// The rectangle a reach check floods: everything the scene holds and every point of `points`,
/// with two robot radii to spare.
fn reach_bounds(scene: &Scene, points: &[&[[f32; 2]]], radius: f32) -> [f32; 4] {
    let corners = scene.rects().iter().flat_map(|rect| rect.corners());
    let all = corners.chain(points.iter().flat_map(|p| p.iter().copied()));
    let mut bounds = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for [x, y] in all {
        bounds = [
            bounds[0].min(x),
            bounds[1].min(y),
            bounds[2].max(x),
            bounds[3].max(y),
        ];
    }
    let margin = 2.0 * radius;
    [
        bounds[0] - margin,
        bounds[1] - margin,
        bounds[2] + margin,
        bounds[3] + margin,
    ]
}

/// The group of each member of `groups` (robots, items or boxes), with its index, in the
/// order the members are drawn: group by group, `count` of each.
fn member_groups<G>(groups: &[G], count: impl Fn(&G) -> u32) -> impl Iterator<Item = (usize, &G)> {
    groups
        .iter()
        .enumerate()
        .flat_map(move |(group_idx, group)| {
            std::iter::repeat_n((group_idx, group), count(group) as usize)
        })
}
