//! How the teammate moves (`teammate.behaviour`). Every behaviour is *met* when the robot comes
//! within `robot.near_robot_range` of it (`teammate following` holds from then on); they
//! differ in what it does before and after: `follow` waits, then follows the robot's own trail
//! (so it never cuts a corner into a wall) keeping a gap; `fixed` never moves; `wander` walks
//! at random on its own stream until met, then follows.

use super::{Motion, TeammateBehaviour};
use crate::body::Pose;
use crate::geometry::scene::Scene;
use crate::math::float::hypot;
use crate::math::rng::{SimRng, Stream, stream_rng};
use std::collections::VecDeque;

/// The follower's keep-away distance, centre to centre: it stops this close behind the robot.
const TEAMMATE_GAP: f32 = 0.10;
/// A wanderer moves at this share of the robot's top speed: slow enough for a robot to catch.
const WANDER_SPEED_SHARE: f32 = 0.5;
/// A wanderer keeps a heading for a whole number of cycles drawn uniformly from this range...
const WANDER_LEG_CYCLES: std::ops::RangeInclusive<u32> = 10..=40;
/// ...then turns by an angle drawn uniformly from plus or minus this, radians (90 degrees).
const WANDER_TURN: f32 = std::f32::consts::FRAC_PI_2;

/// `follow`: waits where it is; once met, follows the robot's trail.
#[derive(Debug)]
pub struct Follow;

impl TeammateBehaviour for Follow {
    fn name(&self) -> &'static str {
        "follow"
    }

    fn start(&self, _pose: &mut Pose, _sample_seed: u64, max_cycles: u32) -> Box<dyn Motion> {
        Box::new(FollowMotion {
            trail: Trail::new(max_cycles),
        })
    }
}

#[derive(Debug)]
struct FollowMotion {
    trail: Trail,
}

impl Motion for FollowMotion {
    fn before_met(&mut self, _pose: &mut Pose, _step: f32, _scene: &Scene, _radius: f32) {}

    fn after_met(&mut self, pose: &mut Pose, robot: &Pose, step: f32) {
        self.trail.follow(pose, robot, step);
    }
}

/// `fixed`: never moves, met or not.
#[derive(Debug)]
pub struct Fixed;

impl TeammateBehaviour for Fixed {
    fn name(&self) -> &'static str {
        "fixed"
    }

    fn start(&self, _pose: &mut Pose, _sample_seed: u64, _max_cycles: u32) -> Box<dyn Motion> {
        Box::new(Still)
    }
}

#[derive(Debug)]
struct Still;

impl Motion for Still {
    fn before_met(&mut self, _pose: &mut Pose, _step: f32, _scene: &Scene, _radius: f32) {}

    fn after_met(&mut self, _pose: &mut Pose, _robot: &Pose, _step: f32) {}
}

/// `wander`: walks at random on its own until met, then follows as `follow` does.
#[derive(Debug)]
pub struct Wander;

impl TeammateBehaviour for Wander {
    fn name(&self) -> &'static str {
        "wander"
    }

    fn check(&self, following: bool) -> Result<(), String> {
        if following {
            return Err(
                "a wandering teammate that follows from the start would never wander: \
                        leave `following` out"
                    .into(),
            );
        }
        Ok(())
    }

    fn start(&self, pose: &mut Pose, sample_seed: u64, max_cycles: u32) -> Box<dyn Motion> {
        // Only a wanderer draws from this stream, so no other sample's draws move.
        Box::new(WanderMotion {
            walk: Walk::new(pose, stream_rng(sample_seed, Stream::Teammate)),
            trail: Trail::new(max_cycles),
        })
    }
}

#[derive(Debug)]
struct WanderMotion {
    walk: Walk,
    trail: Trail,
}

impl Motion for WanderMotion {
    fn before_met(&mut self, pose: &mut Pose, step: f32, scene: &Scene, radius: f32) {
        self.walk
            .step(pose, WANDER_SPEED_SHARE * step, scene, radius);
    }

    fn after_met(&mut self, pose: &mut Pose, robot: &Pose, step: f32) {
        self.trail.follow(pose, robot, step);
    }
}

/// The robot's positions since the teammate was met, the oldest first.
#[derive(Debug)]
struct Trail {
    points: VecDeque<[f32; 2]>,
}

impl Trail {
    fn new(max_cycles: u32) -> Trail {
        Trail {
            points: VecDeque::with_capacity(max_cycles as usize + 1),
        }
    }

    /// Notes the robot's position, then walks up to `step` along the trail towards it,
    /// stopping at the gap.
    fn follow(&mut self, pose: &mut Pose, robot: &Pose, step: f32) {
        self.points.push_back(robot.position());
        let mut budget = step;
        while budget > 0.0 && pose.distance_to(robot.position()) > TEAMMATE_GAP {
            let Some(&target) = self.points.front() else {
                break;
            };
            let (dx, dy) = (target[0] - pose.x, target[1] - pose.y);
            let d = hypot(dx, dy);
            if d <= budget {
                pose.x = target[0];
                pose.y = target[1];
                budget -= d;
                self.points.pop_front();
            } else {
                pose.x += dx / d * budget;
                pose.y += dy / d * budget;
                budget = 0.0;
            }
            if d > 1e-6 {
                pose.heading = dy.atan2(dx);
            }
        }
    }
}

/// A wandering teammate's random walk, drawn from its own stream: straight legs of random
/// length, a random turn between legs, and when the next step would touch a solid (the robot's
/// own disc test) no move but a turn away, by 90 to 270 degrees.
#[derive(Debug)]
struct Walk {
    rng: SimRng,
    /// Cycles left on the current leg.
    leg_left: u32,
}

impl Walk {
    /// Starts a walk: the first heading and the first leg's length are its first draws.
    fn new(pose: &mut Pose, mut rng: SimRng) -> Walk {
        use rand::RngExt;
        pose.heading = rng.random_range(-std::f32::consts::PI..std::f32::consts::PI);
        let leg_left = rng.random_range(WANDER_LEG_CYCLES);
        Walk { rng, leg_left }
    }

    fn step(&mut self, pose: &mut Pose, step: f32, scene: &Scene, radius: f32) {
        use rand::RngExt;
        use std::f32::consts::PI;
        if self.leg_left == 0 {
            pose.heading =
                wrap_angle(pose.heading + self.rng.random_range(-WANDER_TURN..=WANDER_TURN));
            self.leg_left = self.rng.random_range(WANDER_LEG_CYCLES);
        }
        self.leg_left -= 1;
        let (sin_h, cos_h) = pose.heading.sin_cos();
        let next = [pose.x + step * cos_h, pose.y + step * sin_h];
        if scene.disc_hits(next, radius) {
            pose.heading = wrap_angle(pose.heading + self.rng.random_range(0.5 * PI..=1.5 * PI));
        } else {
            pose.x = next[0];
            pose.y = next[1];
        }
    }
}

/// An angle in [-pi, pi).
fn wrap_angle(angle: f32) -> f32 {
    use std::f32::consts::PI;
    (angle + PI).rem_euclid(2.0 * PI) - PI
}
