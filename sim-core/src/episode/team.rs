//! A team's other robots in one sample (`[[robots]]`): each has the focal robot's body and
//! sensors, its own sensor setup and noise streams, and its own driver (a reset copy of the
//! controller being evaluated or of a controller file's tree, or a scripted motion). The
//! copies of one controller are a *crew*, stepped eight at a time. Every robot senses at the
//! start of a cycle, all from the same instant: the focal robot first, then the others in
//! group order.
//! They move after the focal robot, in the same order, each against the walls and against
//! every other robot where it stands at that moment; a move that would overlap either (or a
//! mover, or a box it cannot push) is undone, as a move into a wall is. A sample without a team has no `Team` at all, so it runs
//! and draws exactly as before teams existed.

use crate::body::{Arc, Pose, noisy_speed, wheel_speed};
use crate::geometry::bodies::{Bodies, Disc};
use crate::geometry::crowd::Crowd;
use crate::geometry::scene::Scene;
use crate::math::lanes::{LANES, Lanes};
use crate::math::rng::{SimRng, Stream, member_rng, member_seed};
use crate::math::trig;
use crate::network::Policy;
use crate::network::controller::Controller;
use crate::network::lanes::LaneController;
use crate::outcome::Sample;
use crate::scenario::GroupDriver;
use crate::scenario::blocks::{Motion, TeammateBehaviour};
use crate::sensors::frame::{N_FLAT, N_GROUPS, SensorFrame};
use crate::sensors::{SenseView, Sensor, SensorRun};
use crate::task::TaskConfig;

/// What drives one of the other robots.
#[derive(Debug)]
enum Driver {
    /// Copy `copy` of crew `crew`'s controller ([`Team::crews`]).
    Copy {
        /// The crew.
        crew: usize,
        /// The copy, counted over the crew's robots.
        copy: usize,
    },
    /// A scripted motion (`wander`, `fixed`).
    Scripted(Box<dyn Motion>),
}

/// The crew of the team's `evolved` robots, whose controller [`Team::drive_with`] gives.
const EVOLVED_CREW: usize = 0;

/// The copies of one controller that a crew's robots run.
enum Copies {
    /// None given yet ([`Team::drive_with`]): the robots stand still.
    None,
    /// A controller tree, eight robots a [`LaneController`]: copy `k` is lane `k % LANES` of
    /// controller `k / LANES`.
    Lanes(Vec<LaneController>),
    /// A policy that is no tree, one copy a robot.
    Each(Vec<Box<dyn Policy + Send>>),
}

impl Copies {
    /// `n_copies` reset copies of `controller` in [`LaneController`]s, for steps of `dt`.
    fn lanes(controller: &Controller, n_copies: usize, dt: f32) -> Copies {
        Copies::Lanes(
            (0..n_copies.div_ceil(LANES))
                .map(|_| LaneController::new(controller.clone(), dt))
                .collect(),
        )
    }
}

/// The robots that run copies of one controller: the team's `evolved` robots, or the robots
/// of one group that runs a controller file.
#[derive(Debug)]
struct Crew {
    copies: Copies,
    /// Each copy's wheel outputs of the current cycle, by copy.
    wheels: Vec<[f32; 2]>,
}

impl Crew {
    /// A crew of `n_copies` robots running `copies`.
    fn new(copies: Copies, n_copies: usize) -> Crew {
        Crew {
            copies,
            wheels: vec![[0.5; 2]; n_copies],
        }
    }

    /// Whether its robots have a controller (else they stand still).
    fn is_driven(&self) -> bool {
        !matches!(self.copies, Copies::None)
    }

    /// Each copy's wheel outputs for the frame its robot sensed this cycle, given as
    /// (copy, frame) pairs.
    fn decide<'f>(&mut self, frames: impl Iterator<Item = (usize, &'f SensorFrame)>, dt: f32) {
        let n_copies = self.wheels.len();
        match &mut self.copies {
            Copies::None => {}
            Copies::Each(copies) => {
                for (copy, frame) in frames {
                    self.wheels[copy] = copies[copy].step(frame, dt);
                }
            }
            Copies::Lanes(controllers) => {
                let mut frame_lanes: Vec<[Lanes; N_FLAT]> =
                    vec![[Lanes::ZERO; N_FLAT]; controllers.len()];
                for (copy, frame) in frames {
                    let lanes = &mut frame_lanes[copy / LANES];
                    for (input, &value) in lanes.iter_mut().zip(&frame.inputs) {
                        input.0[copy % LANES] = value;
                    }
                }
                for (chunk, (controller, lanes)) in
                    controllers.iter_mut().zip(&frame_lanes).enumerate()
                {
                    let n_live = (n_copies - chunk * LANES).min(LANES);
                    let live = (1 << n_live) - 1;
                    let wheels = controller.step(lanes, live);
                    self.wheels[chunk * LANES..chunk * LANES + n_live]
                        .copy_from_slice(&wheels[..n_live]);
                }
            }
        }
    }
}

impl std::fmt::Debug for Copies {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Copies::None => write!(f, "None"),
            Copies::Lanes(lanes) => write!(f, "Lanes({})", lanes.len()),
            Copies::Each(copies) => write!(f, "Each({})", copies.len()),
        }
    }
}

/// One of the other robots.
#[derive(Debug)]
struct Member<'e> {
    pose: Pose,
    driver: Driver,
    sensor_runs: [Option<Box<dyn SensorRun + 'e>>; N_GROUPS],
    noise: SimRng,
    /// What it sensed at the start of the current cycle.
    frame: SensorFrame,
}

/// The other robots of a team in one sample, and where every robot stands.
#[derive(Debug)]
pub(crate) struct Team<'e> {
    members: Vec<Member<'e>>,
    /// The crews: the `evolved` robots ([`EVOLVED_CREW`]), then one for each group that
    /// runs a controller file, in group order.
    crews: Vec<Crew>,
    /// Every robot at the start of the cycle, the focal robot as robot 0: what the sensors see
    /// and what a move is checked against.
    crowd: Crowd,
    /// Every robot where it stands now, the focal robot first: what the judge's team
    /// quantities see after the cycle's moves.
    positions: Vec<[f32; 2]>,
    /// The robots' radius.
    radius: f32,
}

impl<'e> Team<'e> {
    /// The team of `sample` of `task`, its robots at `starts` (group by group, as the
    /// sample's world drew them), each with its own runs of the evaluator's `sensors`; `None`
    /// when the scenario has no other robots.
    pub(crate) fn new(
        task: &TaskConfig,
        sensors: &'e [Option<Box<dyn Sensor>>; N_GROUPS],
        sample: Sample,
        starts: &[Pose],
        focal: &Pose,
    ) -> Option<Team<'e>> {
        let scenario = &task.scenario;
        if scenario.robot_groups.is_empty() {
            return None;
        }
        let max_cycles = task.max_cycles();
        let dt = task.params.robot.cycle_seconds;
        // The evolved crew has no controller until `drive_with` gives one; a file's crew has
        // its own from the start.
        let mut crews = vec![Crew::new(Copies::None, 0)];
        // Per group: its crew, or its scripted behaviour.
        let roles: Vec<Result<usize, &dyn TeammateBehaviour>> = scenario
            .robot_groups
            .iter()
            .map(|group| match &group.driver {
                GroupDriver::Evolved => Ok(EVOLVED_CREW),
                GroupDriver::File { controller, .. } => {
                    let n_copies = group.count as usize;
                    crews.push(Crew::new(Copies::lanes(controller, n_copies, dt), n_copies));
                    Ok(crews.len() - 1)
                }
                GroupDriver::Scripted(behaviour) => Err(*behaviour),
            })
            .collect();
        let roles = scenario
            .robot_groups
            .iter()
            .zip(roles)
            .flat_map(|(group, role)| std::iter::repeat_n(role, group.count as usize));
        let mut n_copies = vec![0; crews.len()];
        let members: Vec<Member<'e>> = starts
            .iter()
            .zip(roles)
            .enumerate()
            .map(|(member, (&start, role))| {
                let mut pose = start;
                let driver = match role {
                    Ok(crew) => {
                        n_copies[crew] += 1;
                        Driver::Copy {
                            crew,
                            copy: n_copies[crew] - 1,
                        }
                    }
                    Err(behaviour) => Driver::Scripted(behaviour.start(
                        &mut pose,
                        member_seed(sample.seed, member),
                        max_cycles,
                    )),
                };
                let mut setup = member_rng(sample.seed, member, Stream::SensorSetup);
                let sensor_runs = std::array::from_fn(|group| {
                    sensors[group]
                        .as_ref()
                        .map(|sensor| sensor.start(&mut setup))
                });
                Member {
                    pose,
                    driver,
                    sensor_runs,
                    noise: member_rng(sample.seed, member, Stream::Noise),
                    frame: SensorFrame::default(),
                }
            })
            .collect();
        // The evolved crew's size is known once its robots are counted.
        crews[EVOLVED_CREW] = Crew::new(Copies::None, n_copies[EVOLVED_CREW]);
        let mut team = Team {
            members,
            crews,
            crowd: Crowd::default(),
            positions: Vec::new(),
            radius: task.params.robot.radius,
        };
        team.note_positions(focal);
        Some(team)
    }

    /// Gives every `evolved` robot its own reset copy of `policy`, stepped for `dt` seconds
    /// (none where the policy can be neither laned nor copied: those robots stand still).
    pub(crate) fn drive_with(&mut self, policy: &dyn Policy, dt: f32) {
        let crew = &mut self.crews[EVOLVED_CREW];
        let n_evolved = crew.wheels.len();
        crew.copies = match policy.controller() {
            _ if n_evolved == 0 => Copies::None,
            Some(controller) => Copies::lanes(controller, n_evolved, dt),
            None => (0..n_evolved)
                .map(|_| policy.team_copy())
                .collect::<Option<Vec<_>>>()
                .map_or(Copies::None, Copies::Each),
        };
    }

    /// Each crew's wheel outputs for the frames its robots sensed this cycle.
    fn decide(&mut self, dt: f32) {
        for (crew_idx, crew) in self.crews.iter_mut().enumerate() {
            let frames = self
                .members
                .iter()
                .filter_map(|member| match member.driver {
                    Driver::Copy { crew, copy } if crew == crew_idx => Some((copy, &member.frame)),
                    _ => None,
                });
            crew.decide(frames, dt);
        }
    }

    /// Every robot at the start of the cycle, the focal robot as robot 0.
    pub(crate) fn crowd(&self) -> &Crowd {
        &self.crowd
    }

    /// Every robot where it stands now, the focal robot first.
    pub(crate) fn positions(&self) -> &[[f32; 2]] {
        &self.positions
    }

    /// The other robots' poses, group by group.
    pub(crate) fn poses(&self) -> Vec<Pose> {
        self.members.iter().map(|member| member.pose).collect()
    }

    /// Notes where every robot stands at the start of a cycle, before anything senses.
    pub(crate) fn gather(&mut self, focal: &Pose) {
        self.crowd.set(
            std::iter::once(focal.position()).chain(self.members.iter().map(|m| m.pose.position())),
        );
    }

    /// The other robots sense, after the focal robot did with `focal_view` (whose scene,
    /// lights and lit mask they share).
    pub(crate) fn sense(&mut self, focal_view: &SenseView<'_>) {
        let crowd = &self.crowd;
        for (chunk_idx, chunk) in self.members.chunks_mut(LANES).enumerate() {
            // Eight headings' sines at once, each the bits `trig::sin_cos` gives.
            let headings =
                std::array::from_fn(|lane| chunk.get(lane).map_or(0.0, |m| m.pose.heading));
            let (sines, cosines) = trig::sin_cos_lanes(&headings);
            for (lane, member) in chunk.iter_mut().enumerate() {
                let member_idx = chunk_idx * LANES + lane;
                member.sense(
                    focal_view,
                    crowd,
                    member_idx + 1,
                    (sines[lane], cosines[lane]),
                );
            }
        }
    }
}

impl Member<'_> {
    /// Senses as robot `me` of `crowd`, given its heading's sine and cosine.
    fn sense(
        &mut self,
        focal_view: &SenseView<'_>,
        crowd: &Crowd,
        me: usize,
        (sin_heading, cos_heading): (f32, f32),
    ) {
        let robot = self.pose;
        let view = SenseView {
            robot: &robot,
            sin_heading,
            cos_heading,
            teammate: None,
            crowd: Some(crowd),
            me,
            ..*focal_view
        };
        self.frame = SensorFrame::read(&mut self.sensor_runs, &view, &mut self.noise);
    }
}

impl Team<'_> {
    /// Whether a robot of radius `radius` at `at` would overlap another robot where it stands
    /// now; `me` is the moving robot's index (0 the focal robot), `reach` how far any robot
    /// may have moved since the crowd was gathered plus two radii.
    fn blocked(&self, at: [f32; 2], radius: f32, reach: f32, me: usize, focal: &Pose) -> bool {
        let touching = 2.0 * radius;
        self.crowd
            .near(at, reach)
            .filter(|&(idx, _, _)| idx != me)
            .any(|(idx, _, _)| {
                let now = match idx {
                    0 => focal.position(),
                    _ => self.members[idx - 1].pose.position(),
                };
                let (dx, dy) = (now[0] - at[0], now[1] - at[1]);
                dx * dx + dy * dy < touching * touching
            })
    }

    /// Whether `disc` (a pushed box) would overlap a robot other than robot `me` where it
    /// stands now; `reach` as for [`Team::blocked`], less the robots' radius.
    pub(crate) fn overlaps_robot(&self, disc: &Disc, me: usize, focal: &Pose, step: f32) -> bool {
        let radius = self.radius;
        self.crowd
            .near(disc.center, radius + disc.radius + 2.0 * step)
            .filter(|&(idx, _, _)| idx != me)
            .any(|(idx, _, _)| {
                let now = match idx {
                    0 => focal.position(),
                    _ => self.members[idx - 1].pose.position(),
                };
                disc.overlaps(now, radius)
            })
    }

    /// Whether the focal robot, moving to `at`, would overlap another robot (which have not
    /// moved yet in this cycle).
    pub(crate) fn blocks_focal(&self, at: [f32; 2], radius: f32, step: f32) -> bool {
        let focal = Pose {
            x: at[0],
            y: at[1],
            heading: 0.0,
        };
        self.blocked(at, radius, 2.0 * radius + step, 0, &focal)
    }

    /// The other robots decide, then move, in order, each after the focal robot's move to
    /// `focal`, each move also meeting the sample's movers and boxes (`bodies`, where it has
    /// any) as [`Bodies::admit`] says.
    pub(crate) fn move_members(
        &mut self,
        focal: &Pose,
        task: &TaskConfig,
        scene: &Scene,
        mut bodies: Option<&mut Bodies>,
    ) {
        let robot = &task.params.robot;
        let (radius, dt) = (robot.radius, robot.cycle_seconds);
        let step = robot.v_max * dt;
        // Every robot moves at most `step` a cycle: two of them, since the gathering.
        let reach = 2.0 * radius + 2.0 * step;
        self.decide(dt);
        // Where each robot would go: each depends on its own pose, wheels and noise stream
        // only, so all are planned first and the arcs' sines taken eight at a time (the bits
        // `trig::sin_cos` gives); the moves are then checked one after the other.
        let nexts = self.plan_moves(task, scene);
        for (member_idx, next) in nexts.into_iter().enumerate() {
            let Some(next) = next else { continue };
            let member = &self.members[member_idx];
            let scripted = matches!(member.driver, Driver::Scripted(_));
            // A scripted motion checks the walls itself.
            let hits_solid = !scripted && scene.disc_hits(next.position(), radius);
            let me = member_idx + 1;
            let blocked = hits_solid
                || self.blocked(next.position(), radius, reach, me, focal)
                || bodies.as_deref_mut().is_some_and(|bodies| {
                    !bodies.admit(next.position(), radius, scene, |disc| {
                        self.overlaps_robot(disc, me, focal, step)
                    })
                });
            let member = &mut self.members[member_idx];
            match (blocked, scripted) {
                (false, _) => member.pose = next,
                // A scripted walker blocked by a robot keeps the turn it drew, so that it does
                // not push on for ever; a controller's move is undone whole, as against a wall.
                (true, true) => member.pose.heading = next.heading,
                (true, false) => {}
            }
        }
        self.note_positions(focal);
    }

    /// Each robot's next pose, before any check against walls or robots (`None`: an evolved
    /// robot with no controller given, which stands still).
    fn plan_moves(&mut self, task: &TaskConfig, scene: &Scene) -> Vec<Option<Pose>> {
        let robot = &task.params.robot;
        let step = robot.v_max * robot.cycle_seconds;
        let mut nexts = Vec::with_capacity(self.members.len());
        for chunk in self.members.chunks_mut(LANES) {
            let arcs: [Option<Arc>; LANES] = std::array::from_fn(|lane| {
                let member = chunk.get_mut(lane)?;
                let Driver::Copy { crew, copy } = member.driver else {
                    return None;
                };
                let crew = &self.crews[crew];
                crew.is_driven().then(|| {
                    let [left, right] = crew.wheels[copy].map(|wheel| {
                        noisy_speed(wheel_speed(wheel, robot.v_max), robot, &mut member.noise)
                    });
                    Arc::of(&member.pose, left, right, robot)
                })
            });
            let angles = |of: fn(&Arc) -> f32| arcs.map(|arc| arc.as_ref().map_or(0.0, of));
            let (sin_half_turns, _) = trig::sin_cos_lanes(&angles(|arc| arc.half_turn));
            let (sin_mids, cos_mids) = trig::sin_cos_lanes(&angles(|arc| arc.mid_heading));
            for (lane, member) in chunk.iter_mut().enumerate() {
                nexts.push(match (&mut member.driver, &arcs[lane]) {
                    (Driver::Scripted(motion), _) => {
                        let mut next = member.pose;
                        motion.before_met(&mut next, step, scene, robot.radius);
                        Some(next)
                    }
                    (Driver::Copy { .. }, Some(arc)) => Some(arc.end_pose(
                        &member.pose,
                        sin_half_turns[lane],
                        (sin_mids[lane], cos_mids[lane]),
                    )),
                    (Driver::Copy { .. }, None) => None,
                });
            }
        }
        nexts
    }

    fn note_positions(&mut self, focal: &Pose) {
        self.positions.clear();
        self.positions.push(focal.position());
        self.positions
            .extend(self.members.iter().map(|member| member.pose.position()));
    }
}
