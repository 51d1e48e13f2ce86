//! A team's other robots in one sample (`[[robots]]`): each has the focal robot's body and
//! sensors, its own sensor setup and noise streams, and its own driver (a reset copy of the
//! controller being evaluated, or a scripted motion). Every robot senses at the start of a
//! cycle, all from the same instant: the focal robot first, then the others in group order.
//! They move after the focal robot, in the same order, each against the walls and against
//! every other robot where it stands at that moment; a move that would overlap either is
//! undone, as a move into a wall is. A sample without a team has no `Team` at all, so it runs
//! and draws exactly as before teams existed.

use super::evaluator::Evaluator;
use crate::body::{Arc, Pose, noisy_speed, wheel_speed};
use crate::geometry::crowd::Crowd;
use crate::geometry::scene::Scene;
use crate::math::rng::{SimRng, Stream, member_rng, member_seed};
use crate::math::trig;
use crate::network::Policy;
use crate::outcome::Sample;
use crate::scenario::GroupDriver;
use crate::scenario::blocks::Motion;
use crate::sensors::frame::{InputGroup, N_GROUPS, SensorFrame};
use crate::sensors::{SenseView, SensorRun};

/// What drives one of the other robots.
enum Driver {
    /// A copy of the controller being evaluated; `None` until the caller gives one
    /// ([`Team::drive_with`]), and the robot stands still until then.
    Evolved(Option<Box<dyn Policy + Send>>),
    /// A scripted motion (`wander`, `fixed`).
    Scripted(Box<dyn Motion>),
}

impl std::fmt::Debug for Driver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Driver::Evolved(policy) => write!(f, "Evolved(given: {})", policy.is_some()),
            Driver::Scripted(motion) => write!(f, "Scripted({motion:?})"),
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
    /// Every robot at the start of the cycle, the focal robot as robot 0: what the sensors see
    /// and what a move is checked against.
    crowd: Crowd,
    /// Every robot where it stands now, the focal robot first: what the judge's team
    /// quantities see after the cycle's moves.
    positions: Vec<[f32; 2]>,
}

impl<'e> Team<'e> {
    /// The team of `sample`, its robots at `starts` (group by group, as the sample's world
    /// drew them); `None` when the scenario has no other robots.
    pub(crate) fn new(
        evaluator: &'e Evaluator,
        sample: Sample,
        starts: &[Pose],
        focal: &Pose,
    ) -> Option<Team<'e>> {
        let scenario = &evaluator.task().scenario;
        if scenario.robot_groups.is_empty() {
            return None;
        }
        let max_cycles = evaluator.task().max_cycles();
        let drivers = scenario
            .robot_groups
            .iter()
            .flat_map(|group| std::iter::repeat_n(group.driver, group.count as usize));
        let members = starts
            .iter()
            .zip(drivers)
            .enumerate()
            .map(|(member, (&start, driver))| {
                let mut pose = start;
                let driver = match driver {
                    GroupDriver::Evolved => Driver::Evolved(None),
                    GroupDriver::Scripted(behaviour) => Driver::Scripted(behaviour.start(
                        &mut pose,
                        member_seed(sample.seed, member),
                        max_cycles,
                    )),
                };
                let mut setup = member_rng(sample.seed, member, Stream::SensorSetup);
                let sensor_runs = std::array::from_fn(|group| {
                    evaluator
                        .sensor(group)
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
        let mut team = Team {
            members,
            crowd: Crowd::default(),
            positions: Vec::new(),
        };
        team.note_positions(focal);
        Some(team)
    }

    /// Gives every `evolved` robot its own reset copy of `policy` (none where the policy
    /// cannot be copied: those robots then stand still).
    pub(crate) fn drive_with(&mut self, policy: &dyn Policy) {
        for member in &mut self.members {
            if let Driver::Evolved(copy) = &mut member.driver {
                *copy = policy.team_copy();
            }
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
        for (member_idx, member) in self.members.iter_mut().enumerate() {
            let robot = member.pose;
            let (sin_heading, cos_heading) = trig::sin_cos(robot.heading);
            let view = SenseView {
                robot: &robot,
                sin_heading,
                cos_heading,
                teammate: None,
                crowd: Some(crowd),
                me: member_idx + 1,
                ..*focal_view
            };
            let mut frame = SensorFrame::default();
            for (group, run) in InputGroup::ALL.into_iter().zip(&mut member.sensor_runs) {
                if let Some(run) = run {
                    run.read(&view, &mut member.noise, frame.values_mut(group));
                }
            }
            member.frame = frame;
        }
    }

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

    /// The other robots move, in order, each after the focal robot's move to `focal`.
    pub(crate) fn move_members(&mut self, focal: &Pose, evaluator: &Evaluator, scene: &Scene) {
        let robot = &evaluator.task().params.robot;
        let (radius, dt) = (robot.radius, robot.cycle_seconds);
        let step = robot.v_max * dt;
        // Every robot moves at most `step` a cycle: two of them, since the gathering.
        let reach = 2.0 * radius + 2.0 * step;
        for member_idx in 0..self.members.len() {
            let member = &mut self.members[member_idx];
            let before = member.pose;
            let next = match &mut member.driver {
                Driver::Evolved(None) => continue,
                Driver::Evolved(Some(policy)) => {
                    let wheels = policy.step(&member.frame, dt);
                    let left = noisy_speed(
                        wheel_speed(wheels[0], robot.v_max),
                        robot,
                        &mut member.noise,
                    );
                    let right = noisy_speed(
                        wheel_speed(wheels[1], robot.v_max),
                        robot,
                        &mut member.noise,
                    );
                    let arc = Arc::of(&before, left, right, robot);
                    let (sin_half_turn, _) = trig::sin_cos(arc.half_turn);
                    let next = arc.end_pose(&before, sin_half_turn, trig::sin_cos(arc.mid_heading));
                    if scene.disc_hits(next.position(), radius) {
                        continue;
                    }
                    next
                }
                Driver::Scripted(motion) => {
                    let mut next = before;
                    motion.before_met(&mut next, step, scene, radius);
                    next
                }
            };
            let member_blocked =
                self.blocked(next.position(), radius, reach, member_idx + 1, focal);
            let member = &mut self.members[member_idx];
            match (&member.driver, member_blocked) {
                (_, false) => member.pose = next,
                // A controller's move is undone whole, heading included, as against a wall; a
                // scripted walker keeps the turn it drew, so it does not push on for ever.
                (Driver::Scripted(_), true) => member.pose.heading = next.heading,
                (Driver::Evolved(_), true) => {}
            }
        }
        self.note_positions(focal);
    }

    fn note_positions(&mut self, focal: &Pose) {
        self.positions.clear();
        self.positions.push(focal.position());
        self.positions
            .extend(self.members.iter().map(|member| member.pose.position()));
    }
}
