//! Hand-written reference policies for every task. They prove that each task is solvable with
//! the robot's own sensors and that the simulator's goal detection is right, and they let a
//! user sanity-check a task configuration without evolving anything. Each policy sees only the
//! sensor frame, exactly like an evolved controller; besides that it integrates its own
//! commanded wheel speeds (dead reckoning) to know, for example, when a 90-degree turn is done.
//!
//! All of them share one small driving core: the IR inputs are turned back into distances with
//! the average calibration curve; in corridors a two-state observer (sideways offset from the
//! centre line and heading relative to it) is corrected by those distances and a proportional
//! law on the observer steers, while in the room a damped law keeps the left side at a fixed
//! distance from whatever is followed. On top of that core each policy is a small state
//! machine: cruise along a corridor, advance a measured distance, spin in place, and the
//! decisions of its task (which way to turn at a junction, when to take a side opening, when
//! to leave an obstacle).
//!
//! The policies assume the paper's geometry (0.20 m corridors, square room corners,
//! rectangular obstacles at least 0.10 m from everything else); `for_task` adapts them to a
//! task configuration's robot (size, speed) and IR mapping.

use hevo_sim_core::IrMapping;
use hevo_sim_core::Policy;
use hevo_sim_core::RobotConfig;
use hevo_sim_core::TaskConfig;
use hevo_sim_core::{InputGroup, SensorFrame};
use hevo_sim_core::{IrModel, MEAN_IR_CURVE};
use hevo_sim_core::{N_IR, N_LIGHT};
use std::f32::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// A group's values as an array of its width (zeros should the width differ: it cannot, the
/// widths are the registry's).
fn group<const N: usize>(frame: &SensorFrame, group: InputGroup) -> [f32; N] {
    frame.values(group).try_into().unwrap_or([0.0; N])
}

/// A side of the robot, or the direction of a turn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TurnSide {
    /// Counter-clockwise, towards the +90 degree sensor.
    Left,
    /// Clockwise, towards the -90 degree sensor.
    Right,
}

impl TurnSide {
    /// +1 for a left (counter-clockwise) turn, -1 for a right one.
    fn sign(self) -> f32 {
        match self {
            TurnSide::Left => 1.0,
            TurnSide::Right => -1.0,
        }
    }

    /// Index into `[left, right]` pairs (the light inputs' order).
    fn index(self) -> usize {
        match self {
            TurnSide::Left => 0,
            TurnSide::Right => 1,
        }
    }

    fn other(self) -> TurnSide {
        match self {
            TurnSide::Left => TurnSide::Right,
            TurnSide::Right => TurnSide::Left,
        }
    }
}

// Geometry the policies assume: the maze's 0.30 m cells leave 0.20 m corridors.
/// Half the clear width of a corridor, metres.
const CORRIDOR_HALF_WIDTH: f32 = 0.10;
/// A lateral reading beyond this distance (sensor to surface) counts as nothing there.
const SEEN_MAX: f32 = 0.092;
/// A lateral wall farther than this (sensor to surface) is not used to steer: a robot centred
/// in a corridor sees its walls at 6.25 cm, and a wall that reads farther is usually one whose
/// end the sensor's cone is just passing, which would pull the robot towards the opening.
const STEER_MAX: f32 = 0.08;
/// With the linear-distance IR mapping, a lateral reading this much farther than the wall it
/// has been reading means that wall ended. Needed besides `SEEN_MAX` because that mapping
/// reads an empty cone as a wall 7.6-10.4 cm away for three of the eight measured curves
/// (r2s7, r2s5, r1s5). With the linear-raw mapping, which reads every curve's empty cone as
/// 0, `SEEN_MAX` alone is more reliable.
const WALL_END_JUMP: f32 = 0.012;
/// A side that was open within this distance of travel still counts as open at a wall ahead:
/// at the junction's centre the cone may again catch the corner of the wall just passed.
const OPEN_MEMORY: f32 = 0.12;
/// A side counts as open when it has seen no wall in `OPEN_CYCLES` of the last `OPEN_WINDOW`
/// cycles.
const OPEN_CYCLES: u32 = 3;
const OPEN_WINDOW: u32 = 4;
/// Both front sensors this close (metres) mean a wall ahead of a corridor: the robot's centre is
/// then near the centre of the cell in front of that wall.
const CORRIDOR_WALL_AHEAD: f32 = 0.066;
/// Below this front distance the robot slows down, so that it stops where it should.
const SLOW_DOWN_AHEAD: f32 = 0.09;
/// Distance driven after a side opening is seen before spinning into it: from where the
/// lateral sensor loses the wall to the centre of the opening.
const OPENING_ADVANCE: f32 = 0.015;
/// Orienting, the corridor is found when nothing is this close ahead (metres) and walls are
/// on both sides; facing a side wall of the 0.20 m corridor, the front reads about 6 cm.
const ORIENT_CLEAR_AHEAD: f32 = 0.085;
/// Orienting spin rate, rad/s: slow enough that the sensors see each heading.
const ORIENT_TURN_RATE: f32 = 1.2;
/// After a turn, openings are ignored for this distance: the junction just left is still open
/// behind the robot.
const SETTLE_DISTANCE: f32 = 0.17;
/// How far the returner drives into the room once the stem's walls end on both sides: enough
/// to bring the teammate, 0.10 m behind, inside; short of the room's obstacles, which keep
/// 0.30 m from the exit.
const ENTER_DISTANCE: f32 = 0.25;
/// Wall-following distance in the room (sensor to wall): close enough that the robot's body
/// stays clear of every obstacle, which the room keeps at least 0.10 m from the walls.
const HUG_DISTANCE: f32 = 0.017;
/// The front-left sensor this close to a surface while wall-following: a concave corner.
const HUG_CORNER_AHEAD: f32 = 0.03;
/// Either front sensor this close while driving freely: an obstacle or wall ahead.
const FREE_STOP_AHEAD: f32 = 0.045;
/// The hugging law steers by the distance to the left surface up to this much beyond
/// `HUG_DISTANCE`.
const HUG_BAND: f32 = 0.01;
/// Farther surfaces are approached at this angle (radians) to the direction of the surface
/// followed last...
const HUG_APPROACH_ANGLE: f32 = 0.3;
/// ...or, when that direction is unknown (after meeting a surface at an unknown angle), by
/// turning towards them at this rate (radians per second).
const HUG_APPROACH_RATE: f32 = 0.3;
/// Something on the right this close while wall-following: steer in the middle of the passage.
const NARROW_RIGHT: f32 = 0.02;
/// Distance driven past a convex corner (or into the room's exit) before turning around it.
const CONVEX_ADVANCE: f32 = 0.03;
/// Cycles of corridor-like walls on both sides, in a passage, after which the rescuer takes
/// the passage for the maze's stem: long enough that a gap between an obstacle and a wall
/// rarely passes for it, which would send the maze solver into the room.
const CORRIDOR_CYCLES: u32 = 8;
/// The same when the corner may have been an obstacle's: longer than a passage between an
/// obstacle's side and a wall can be.
const CORRIDOR_CYCLES_UNSURE: u32 = 28;
/// Longest side of a room obstacle plus a margin, metres.
const OBSTACLE_SIDE_MAX: f32 = 0.25;
/// How far past a convex corner a wall appearing on the right makes a passage.
const PASSAGE_PROBE: f32 = 0.08;
/// How far the exiter drives along a passage found behind a convex corner before it follows
/// walls again: far enough to be out of the room through the exit.
const PASSAGE_LENGTH: f32 = 0.3;
/// Distance along one surface after which the exiter gives it up (two rounds of the largest
/// room without finding the exit mean it is lost), metres.
const HUG_GIVE_UP: f32 = 8.0;
/// Net left turning, radians, after which a left-hand follower concludes it is circling an
/// obstacle (following the room's walls turns it right, never left).
const ORBIT_TURN: f32 = 1.75 * PI;

/// Turns IR inputs back into distances (sensor to surface, metres) through the average
/// measured curve and the task's raw-to-input mapping. Real sensors differ from the average;
/// at the distances the policies steer by that is up to about a centimetre.
#[derive(Debug)]
struct Ranger {
    /// Input of the average curve at each millimetre from contact, made non-increasing.
    input_at_mm: Vec<f32>,
    /// `WALL_END_JUMP` where the mapping needs it.
    wall_end_jump: Option<f32>,
}

impl Ranger {
    /// The ranger for a mapping, built once per process.
    fn for_mapping(mapping: IrMapping) -> &'static Ranger {
        static LINEAR_DISTANCE: OnceLock<Ranger> = OnceLock::new();
        static LINEAR_RAW: OnceLock<Ranger> = OnceLock::new();
        static AVERAGE_TABLE: OnceLock<Ranger> = OnceLock::new();
        let cell = match mapping {
            IrMapping::LinearDistance => &LINEAR_DISTANCE,
            IrMapping::LinearRaw => &LINEAR_RAW,
            IrMapping::AverageTable => &AVERAGE_TABLE,
        };
        cell.get_or_init(|| Ranger::new(mapping))
    }

    fn new(mapping: IrMapping) -> Ranger {
        let model = IrModel::builtin();
        let mut lowest = f32::INFINITY;
        let input_at_mm = (0..=120)
            .map(|mm| {
                let input = model.noise_free_input(MEAN_IR_CURVE, mm as f32 * 0.001, mapping);
                // The measured curves flatten and even rise again near 12 cm; a running
                // minimum keeps the inverse well defined.
                lowest = lowest.min(input);
                lowest
            })
            .collect();
        let wall_end_jump = (mapping != IrMapping::LinearRaw).then_some(WALL_END_JUMP);
        Ranger {
            input_at_mm,
            wall_end_jump,
        }
    }

    /// The distance whose average input is `input`; infinity when the input is below what any
    /// surface within range gives.
    fn distance(&self, input: f32) -> f32 {
        let table = &self.input_at_mm;
        if input >= table[0] {
            return 0.0;
        }
        match table.iter().position(|&x| x <= input) {
            Some(0) => 0.0,
            Some(mm) => {
                let (near, far) = (table[mm - 1], table[mm]);
                let t = if near > far {
                    (near - input) / (near - far)
                } else {
                    0.0
                };
                (mm as f32 - 1.0 + t) * 0.001
            }
            None => f32::INFINITY,
        }
    }
}

/// One cycle's distances, sensor to surface, metres (infinity when nothing is in range).
#[derive(Debug, Clone, Copy)]
struct Ranges {
    front_left: f32,
    left: f32,
    right: f32,
    front_right: f32,
}

impl Ranges {
    fn lateral(&self, side: TurnSide) -> f32 {
        match side {
            TurnSide::Left => self.left,
            TurnSide::Right => self.right,
        }
    }

    fn front_max(&self) -> f32 {
        self.front_left.max(self.front_right)
    }

    fn front_min(&self) -> f32 {
        self.front_left.min(self.front_right)
    }
}

/// The driving core shared by all policies: dead reckoning, the lateral observer, the steering
/// law and in-place spins.
#[derive(Debug, Clone)]
struct Driver {
    v_max: f32,
    wheel_base: f32,
    radius: f32,
    ranger: &'static Ranger,
    /// Dead-reckoned heading, radians, not wrapped.
    heading: f32,
    /// Dead-reckoned distance driven forward, metres.
    odometer: f32,
    /// Heading of the line being followed, in the dead-reckoning frame.
    axis: f32,
    /// Estimated offset to the left of that line, metres; `None` until a wall was seen.
    lateral: Option<f32>,
    /// Cycles since the last lateral measurement.
    unmeasured: u32,
    /// Forward speed commanded in the last cycle, metres per second.
    last_speed: f32,
    /// For each side (left, right), the last cycles' "no wall seen" as bits, newest lowest.
    open_history: [u8; 2],
    /// The distance each side's wall (left, right) has been reading, while there is one.
    wall_level: [Option<f32>; 2],
    /// Odometer when each side (left, right) was last open.
    open_at: [Option<f32>; 2],
}

impl Driver {
    /// A driver for the default robot and IR mapping.
    fn standard() -> Driver {
        Driver::new(&RobotConfig::default(), IrMapping::default())
    }

    fn for_task(task: &TaskConfig) -> Driver {
        Driver::new(&task.params.robot, task.params.ir.mapping)
    }

    fn new(robot: &RobotConfig, mapping: IrMapping) -> Driver {
        Driver::with_body(
            robot.v_max,
            robot.wheel_base,
            robot.radius,
            Ranger::for_mapping(mapping),
        )
    }

    fn with_body(v_max: f32, wheel_base: f32, radius: f32, ranger: &'static Ranger) -> Driver {
        Driver {
            v_max,
            wheel_base,
            radius,
            ranger,
            heading: 0.0,
            odometer: 0.0,
            axis: 0.0,
            lateral: None,
            unmeasured: 0,
            last_speed: 0.0,
            open_history: [0; 2],
            wall_level: [None; 2],
            open_at: [None; 2],
        }
    }

    fn reset(&mut self) {
        *self = Driver::with_body(self.v_max, self.wheel_base, self.radius, self.ranger);
    }

    /// Reads the frame into distances and updates the open-side counters.
    fn perceive(&mut self, frame: &SensorFrame) -> Ranges {
        let ranger = self.ranger;
        let [front_left, left, right, front_right] = group::<N_IR>(frame, InputGroup::IR);
        let ranges = Ranges {
            front_left: ranger.distance(front_left),
            left: ranger.distance(left),
            right: ranger.distance(right),
            front_right: ranger.distance(front_right),
        };
        for side in [TurnSide::Left, TurnSide::Right] {
            let distance = ranges.lateral(side);
            let level = &mut self.wall_level[side.index()];
            // A wall ends where the reading jumps well beyond the level it has been at, or
            // beyond anything a wall in range gives. The jump matters where a sensor's own
            // curve reads an empty cone as a wall some 8 cm away (see `WALL_END_JUMP`).
            let jumped = ranger
                .wall_end_jump
                .is_some_and(|jump| level.is_some_and(|at| distance > at + jump));
            let gone = distance > SEEN_MAX || jumped;
            if !gone {
                *level = Some(match *level {
                    // Follow a wall coming closer at once, one receding slowly: a wall that
                    // ends must not drag the level along before the jump is seen.
                    Some(at) if distance > at => at + 0.15 * (distance - at),
                    _ => distance,
                });
            }
            let history = &mut self.open_history[side.index()];
            *history = (*history << 1) | u8::from(gone);
            if self.is_open(side) {
                self.open_at[side.index()] = Some(self.odometer);
                // Whatever comes into view next is a new wall.
                self.wall_level[side.index()] = None;
            }
        }
        ranges
    }

    /// Whether a side is open: no wall in at least `OPEN_CYCLES` of the last `OPEN_WINDOW`
    /// cycles. A far wall read by a weak sensor is close to the noise of an empty cone, so
    /// one stray reading must not hide an opening.
    fn is_open(&self, side: TurnSide) -> bool {
        let window = (1u16 << OPEN_WINDOW) - 1;
        (u16::from(self.open_history[side.index()]) & window).count_ones() >= OPEN_CYCLES
    }

    /// Whether a side is open now or was open within the last `OPEN_MEMORY` of travel.
    fn was_open(&self, side: TurnSide) -> bool {
        self.open_at[side.index()].is_some_and(|at| self.odometer - at <= OPEN_MEMORY)
    }

    /// Heading relative to the followed line.
    fn relative_heading(&self) -> f32 {
        self.heading - self.axis
    }

    /// Commands a forward speed and turn rate, saturating the wheels, and dead-reckons them.
    fn command(&mut self, speed: f32, turn_rate: f32, dt: f32) -> [f32; 2] {
        let half_difference = 0.5 * turn_rate * self.wheel_base;
        let mut left = speed - half_difference;
        let mut right = speed + half_difference;
        // Keep the turn rate and give up forward speed when a wheel would saturate.
        let excess = left.abs().max(right.abs()) - self.v_max;
        if excess > 0.0 {
            let shift = excess * speed.signum();
            left -= shift;
            right -= shift;
            let scale = self.v_max / left.abs().max(right.abs()).max(self.v_max);
            left *= scale;
            right *= scale;
        }
        self.heading += (right - left) / self.wheel_base * dt;
        self.last_speed = 0.5 * (left + right);
        self.odometer += self.last_speed * dt;
        [left, right].map(|v| (0.5 * (v / self.v_max + 1.0)).clamp(0.0, 1.0))
    }

    /// Follows the centre line of a 0.20 m corridor at `speed` (a fraction of the top speed),
    /// steering by both walls or by the one that is seen.
    fn track(&mut self, ranges: &Ranges, speed: f32, dt: f32) -> [f32; 2] {
        let theta = self.relative_heading();
        if let Some(offset) = self.lateral.as_mut() {
            *offset += self.last_speed * dt * theta.sin();
        }
        let left_seen = ranges.left <= STEER_MAX;
        let right_seen = ranges.right <= STEER_MAX;
        let nominal = CORRIDOR_HALF_WIDTH - self.radius;
        let measured = match (left_seen, right_seen) {
            (true, true) => Some(0.5 * (ranges.right - ranges.left)),
            // With one wall only, the other side is an opening (or about to be one, at a
            // junction): a far reading there may be a wall end fading out of the cone, so a
            // single wall only ever pushes the robot away, never pulls it closer.
            (true, false) => Some((nominal - ranges.left).max(0.0)),
            (false, true) => Some((ranges.right - nominal).min(0.0)),
            (false, false) => None,
        };
        match (measured, self.lateral) {
            (Some(m), Some(estimate)) => {
                let residual = m - estimate;
                self.lateral = Some(estimate + 0.35 * residual);
                // A residual that keeps the same sign means the heading estimate is off: the
                // offset grows faster than the believed heading explains.
                let travel = (self.last_speed * dt).abs().max(0.004);
                let correction = (0.12 * residual / travel).clamp(-0.04, 0.04);
                self.axis -= correction;
                self.unmeasured = 0;
            }
            (Some(m), None) => {
                self.lateral = Some(m);
                self.unmeasured = 0;
            }
            (None, _) => {
                self.unmeasured += 1;
                // Dead reckoning alone drifts; an old offset would steer at nothing.
                if self.unmeasured > 30 {
                    self.lateral = None;
                }
            }
        }
        let theta = self.relative_heading();
        let offset = self.lateral.unwrap_or(0.0);
        let turn_rate = (-25.0 * offset - 3.5 * theta).clamp(-2.5, 2.5);
        let forward = speed * self.v_max * theta.cos().max(0.3);
        self.command(forward, turn_rate, dt)
    }

    /// Drives straight along the current axis without lateral feedback.
    fn hold(&mut self, speed: f32, dt: f32) -> [f32; 2] {
        let turn_rate = (-3.5 * self.relative_heading()).clamp(-2.5, 2.5);
        self.command(speed * self.v_max, turn_rate, dt)
    }

    /// One cycle of an in-place spin towards `target` heading; `None` once it is reached.
    fn spin(&mut self, target: f32, dt: f32) -> Option<[f32; 2]> {
        let error = target - self.heading;
        if error.abs() < 0.02 {
            return None;
        }
        // At most about 11 degrees per cycle, and never past the target.
        let turn_rate = (error / dt).clamp(-1.9, 1.9);
        Some(self.command(0.0, turn_rate, dt))
    }

    /// Makes `axis` the line to follow from now on (after a turn).
    fn set_axis(&mut self, axis: f32) {
        self.axis = axis;
        self.lateral = None;
        self.unmeasured = 0;
        // Facing another way, the sensors see other walls.
        self.wall_level = [None; 2];
    }
}

/// How a corridor policy decides at junctions and openings.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Strategy {
    /// Go straight past side openings; at a wall ahead turn to the open side.
    Follow,
    /// At a wall ahead prefer this side.
    Turn(TurnSide),
    /// At the n-th wall ahead turn to the side of the n-th light flash.
    Maze,
    /// Take every single side opening; at a double one (the room) drive straight in and stop.
    Return,
}

/// The state of a corridor policy.
#[derive(Debug, Clone, Copy, PartialEq)]
enum CorridorMode {
    /// Spin in place until the robot lies along a corridor (walls on both sides, nothing close
    /// ahead), then cruise along it. The returner starts so: it may face any way in the
    /// branch end.
    Orient,
    /// Follow the corridor; openings are ignored until the odometer passes `settle_until`.
    Cruise { settle_until: f32 },
    /// Drive on to the centre of a side opening, then spin into it.
    Advance { until: f32, side: TurnSide },
    /// Spin in place to `axis`, then cruise along it.
    Spin { axis: f32 },
    /// Drive straight on without turning until the odometer passes `until`, then stop.
    Enter { until: f32 },
    /// Stand still.
    Stop,
}

/// The corridor state machine behind `CorridorFollower`, `Turner`, `MazeSolver` and `Returner`.
#[derive(Debug, Clone)]
struct CorridorLogic {
    strategy: Strategy,
    mode: CorridorMode,
    /// Walls ahead met so far (junctions for the maze).
    walls_ahead: usize,
    /// Sides of the light flashes seen so far, in order.
    flashes: Vec<TurnSide>,
    /// Light inputs of the last cycle, to find rising edges.
    last_light: [f32; 2],
}

impl CorridorLogic {
    fn new(strategy: Strategy) -> CorridorLogic {
        CorridorLogic {
            strategy,
            mode: if strategy == Strategy::Return {
                CorridorMode::Orient
            } else {
                CorridorMode::Cruise { settle_until: 0.0 }
            },
            walls_ahead: 0,
            flashes: Vec::new(),
            last_light: [0.0; 2],
        }
    }

    fn reset(&mut self) {
        *self = CorridorLogic::new(self.strategy);
    }

    /// Records the side of each new flash (a rising edge of a light input).
    fn watch_lights(&mut self, frame: &SensorFrame) {
        let light = group::<N_LIGHT>(frame, InputGroup::LIGHT);
        for side in [TurnSide::Left, TurnSide::Right] {
            let now = light[side.index()];
            if now >= 0.5 && self.last_light[side.index()] < 0.5 {
                self.flashes.push(side);
            }
        }
        self.last_light = light;
    }

    /// Which way to turn at a wall ahead, given which sides are open; `None` in a dead end.
    fn choose_at_wall(&self, driver: &Driver, ranges: &Ranges) -> Option<TurnSide> {
        // Open: seen open on the approach, or nothing there now. Closed: a wall at about the
        // corridor's half-width now and never open on the approach. A tilted robot can see
        // the corner of an opening, so a side may be neither.
        let open = |side| driver.was_open(side) || ranges.lateral(side) > SEEN_MAX;
        let closed = |side| !driver.was_open(side) && ranges.lateral(side) <= STEER_MAX;
        let preferred = match self.strategy {
            Strategy::Follow | Strategy::Return => {
                if open(TurnSide::Left) && !open(TurnSide::Right) {
                    TurnSide::Left
                } else {
                    TurnSide::Right
                }
            }
            Strategy::Turn(side) => side,
            Strategy::Maze => self
                .flashes
                .get(self.walls_ahead)
                .copied()
                .unwrap_or(TurnSide::Right),
        };
        let other = preferred.other();
        if closed(preferred) && closed(other) {
            None
        } else if open(preferred) {
            Some(preferred)
        } else if open(other) {
            Some(other)
        } else if !closed(preferred) {
            Some(preferred)
        } else {
            Some(other)
        }
    }

    fn step(&mut self, driver: &mut Driver, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.watch_lights(frame);
        let ranges = driver.perceive(frame);
        loop {
            match self.mode {
                CorridorMode::Orient => {
                    let walled = ranges.left <= SEEN_MAX && ranges.right <= SEEN_MAX;
                    // Two turns without finding the corridor: cruise and let it steer.
                    let given_up = driver.heading.abs() > 4.0 * PI;
                    if (walled && ranges.front_min() > ORIENT_CLEAR_AHEAD) || given_up {
                        driver.set_axis(driver.heading);
                        self.mode = CorridorMode::Cruise { settle_until: 0.0 };
                        continue;
                    }
                    return driver.command(0.0, ORIENT_TURN_RATE, dt);
                }
                CorridorMode::Cruise { settle_until } => {
                    if ranges.front_max() <= CORRIDOR_WALL_AHEAD {
                        let turn = self.choose_at_wall(driver, &ranges);
                        self.walls_ahead += 1;
                        let angle = turn.map_or(PI, |side| side.sign() * FRAC_PI_2);
                        self.mode = CorridorMode::Spin {
                            axis: driver.axis + angle,
                        };
                        continue;
                    }
                    let settled = driver.odometer >= settle_until;
                    if settled && self.strategy == Strategy::Return {
                        let left = driver.is_open(TurnSide::Left);
                        let right = driver.is_open(TurnSide::Right);
                        if left && right {
                            self.mode = CorridorMode::Enter {
                                until: driver.odometer + ENTER_DISTANCE,
                            };
                            continue;
                        }
                        if left || right {
                            let side = if left {
                                TurnSide::Left
                            } else {
                                TurnSide::Right
                            };
                            self.mode = CorridorMode::Advance {
                                until: driver.odometer + OPENING_ADVANCE,
                                side,
                            };
                            continue;
                        }
                    }
                    // A turner takes the first opening on its side even where the corridor
                    // goes on straight (the maze's side junctions); where both sides open at
                    // once it is a T, taken at the wall ahead.
                    if settled
                        && let Strategy::Turn(side) = self.strategy
                        && driver.is_open(side)
                        && !driver.is_open(side.other())
                    {
                        self.mode = CorridorMode::Advance {
                            until: driver.odometer + OPENING_ADVANCE,
                            side,
                        };
                        continue;
                    }
                    let speed = if ranges.front_min() < SLOW_DOWN_AHEAD {
                        0.6
                    } else {
                        1.0
                    };
                    return driver.track(&ranges, speed, dt);
                }
                CorridorMode::Advance { until, side } => {
                    if driver.is_open(side.other()) {
                        self.mode = if self.strategy == Strategy::Return {
                            // Both sides open at once: this is no junction but the room.
                            CorridorMode::Enter {
                                until: driver.odometer + ENTER_DISTANCE,
                            }
                        } else {
                            // A T: the turn is taken at the wall ahead.
                            CorridorMode::Cruise {
                                settle_until: driver.odometer,
                            }
                        };
                        continue;
                    }
                    if driver.odometer >= until || ranges.front_max() <= CORRIDOR_WALL_AHEAD {
                        self.mode = CorridorMode::Spin {
                            axis: driver.axis + side.sign() * FRAC_PI_2,
                        };
                        continue;
                    }
                    return driver.hold(0.7, dt);
                }
                CorridorMode::Spin { axis } => {
                    if let Some(wheels) = driver.spin(axis, dt) {
                        return wheels;
                    }
                    driver.set_axis(axis);
                    self.mode = CorridorMode::Cruise {
                        settle_until: driver.odometer + SETTLE_DISTANCE,
                    };
                }
                CorridorMode::Enter { until } => {
                    if driver.odometer >= until || ranges.front_min() < FREE_STOP_AHEAD {
                        self.mode = CorridorMode::Stop;
                        continue;
                    }
                    return driver.hold(1.0, dt);
                }
                CorridorMode::Stop => return driver.command(0.0, 0.0, dt),
            }
        }
    }
}

/// Implements `Policy` for a scripted policy made of a `Driver` and a `CorridorLogic`.
macro_rules! corridor_policy {
    ($name:ident) => {
        impl Policy for $name {
            fn reset(&mut self) {
                self.driver.reset();
                self.logic.reset();
            }

            fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
                self.logic.step(&mut self.driver, frame, dt)
            }
        }
    };
}

/// Drives along a corridor, centred between its walls, and turns with it at a bend (the
/// follow-wall task, and L-bends). Side openings are passed straight by; at a wall ahead it
/// turns to the open side, and in a dead end it turns around.
#[derive(Debug, Clone)]
pub struct CorridorFollower {
    driver: Driver,
    logic: CorridorLogic,
}

impl CorridorFollower {
    /// A follower for the default robot and sensors.
    pub fn new() -> CorridorFollower {
        CorridorFollower::with_driver(Driver::standard())
    }

    /// A follower for the robot and IR mapping of a task configuration.
    pub fn for_task(task: &TaskConfig) -> CorridorFollower {
        CorridorFollower::with_driver(Driver::for_task(task))
    }

    fn with_driver(driver: Driver) -> CorridorFollower {
        CorridorFollower {
            driver,
            logic: CorridorLogic::new(Strategy::Follow),
        }
    }
}

impl Default for CorridorFollower {
    fn default() -> Self {
        CorridorFollower::new()
    }
}

corridor_policy!(CorridorFollower);

/// Takes the single turn of a corridor to `side`: at an L-bend, at a T-junction whose other
/// arm is a wrong branch, and at a side opening the corridor goes on straight past (the
/// turn-left and turn-right tasks).
#[derive(Debug, Clone)]
pub struct Turner {
    /// The side the turn is taken to.
    pub side: TurnSide,
    driver: Driver,
    logic: CorridorLogic,
}

impl Turner {
    /// A turner to `side` for the default robot and sensors.
    pub fn new(side: TurnSide) -> Turner {
        Turner::with_driver(side, Driver::standard())
    }

    /// A turner to `side` for the robot and IR mapping of a task configuration.
    pub fn for_task(side: TurnSide, task: &TaskConfig) -> Turner {
        Turner::with_driver(side, Driver::for_task(task))
    }

    fn with_driver(side: TurnSide, driver: Driver) -> Turner {
        Turner {
            side,
            driver,
            logic: CorridorLogic::new(Strategy::Turn(side)),
        }
    }
}

impl Policy for Turner {
    fn reset(&mut self) {
        // The side is public, so it may have changed since construction.
        self.logic = CorridorLogic::new(Strategy::Turn(self.side));
        self.driver.reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.logic.step(&mut self.driver, frame, dt)
    }
}

/// Solves the double T-maze: remembers the side of the first and second light flash in the
/// stem and turns to that side at the first and second junction (a light on the right means a
/// right turn). Without a flash it turns right.
#[derive(Debug, Clone)]
pub struct MazeSolver {
    driver: Driver,
    logic: CorridorLogic,
}

impl MazeSolver {
    /// A solver for the default robot and sensors.
    pub fn new() -> MazeSolver {
        MazeSolver::with_driver(Driver::standard())
    }

    /// A solver for the robot and IR mapping of a task configuration.
    pub fn for_task(task: &TaskConfig) -> MazeSolver {
        MazeSolver::with_driver(Driver::for_task(task))
    }

    fn with_driver(driver: Driver) -> MazeSolver {
        MazeSolver {
            driver,
            logic: CorridorLogic::new(Strategy::Maze),
        }
    }

    /// The sides of the flashes seen so far in this sample, in order.
    pub fn flashes(&self) -> &[TurnSide] {
        &self.logic.flashes
    }
}

impl Default for MazeSolver {
    fn default() -> Self {
        MazeSolver::new()
    }
}

corridor_policy!(MazeSolver);

/// Returns from a branch end of the maze to its entrance: at each junction exactly one side
/// opens towards the way back (straight on is a wrong branch), and it takes that side. Where
/// both sides open at once (the stem's mouth into the room) it drives straight in and stops.
#[derive(Debug, Clone)]
pub struct Returner {
    driver: Driver,
    logic: CorridorLogic,
}

impl Returner {
    /// A returner for the default robot and sensors.
    pub fn new() -> Returner {
        Returner::with_driver(Driver::standard())
    }

    /// A returner for the robot and IR mapping of a task configuration.
    pub fn for_task(task: &TaskConfig) -> Returner {
        Returner::with_driver(Driver::for_task(task))
    }

    fn with_driver(driver: Driver) -> Returner {
        Returner {
            driver,
            logic: CorridorLogic::new(Strategy::Return),
        }
    }
}

impl Default for Returner {
    fn default() -> Self {
        Returner::new()
    }
}

corridor_policy!(Returner);

/// The state of the room exiter.
#[derive(Debug, Clone, Copy, PartialEq)]
enum RoomMode {
    /// Drive straight until something is ahead.
    Seek,
    /// Turn right in place until nothing is close ahead, then follow what is now on the left.
    Clear,
    /// Follow what is on the left (a wall or an obstacle) at `HUG_DISTANCE`.
    Hug,
    /// Drive past a convex corner on the left (or to the middle of the exit) before turning.
    Advance { until: f32 },
    /// Spin to `heading`; then hug, or seek when leaving an obstacle.
    Spin { heading: f32, then_seek: bool },
    /// Drive along a passage (the exit, found by turning around a convex corner and seeing a
    /// wall on the right as well) in its middle, ignoring openings, until the odometer passes
    /// `until`.
    Passage { until: f32 },
}

/// What the room exiter's hug steers by.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Regime {
    /// The distance to the surface on the left.
    Wall,
    /// The middle between the left surface and a close one on the right.
    Narrow,
}

/// The room exiter's state machine (also the first stage of the rescuer).
#[derive(Debug, Clone)]
struct RoomLogic {
    mode: RoomMode,
    /// Dead-reckoned heading when the robot started following the current surface: turning
    /// left by most of a circle since then means it is circling an obstacle.
    hug_heading: f32,
    /// Odometer when the current hug began, and at the last turn around a convex corner.
    hug_start: f32,
    last_convex: Option<f32>,
    /// Whether the driver's axis is the direction of a surface (learned while following it,
    /// or set by a square turn at one of its corners), rather than a guess.
    axis_known: bool,
    /// Odometer when the left surface was last within the hugging band.
    last_touch: Option<f32>,
    /// The last cycle's distance error while hugging, for the steering law's damping term.
    last_error: Option<(Regime, f32)>,
    /// The last cycle's left distance, to tell a receding surface from a steady one.
    last_left: Option<f32>,
    /// Obstacles left so far; each escape turns a little further, so that repeated escapes
    /// from one obstacle do not retrace the same line.
    escapes: u32,
    /// Consecutive cycles in a passage with walls on both sides at about a corridor's width.
    corridor_cycles: u32,
    /// Whether the surface followed before the last convex corner was surely a room wall: a
    /// concave corner was turned since the hug began, or the surface ran on for longer than
    /// any obstacle's side. Only then is a passage behind that corner quickly taken for the exit.
    followed_wall: bool,
    passage_after_wall: bool,
    /// Odometer at the last turn or first contact, to measure how long a surface runs.
    straight_from: f32,
}

impl RoomLogic {
    fn new() -> RoomLogic {
        RoomLogic {
            mode: RoomMode::Seek,
            hug_heading: 0.0,
            hug_start: 0.0,
            last_convex: None,
            axis_known: false,
            last_touch: None,
            last_error: None,
            last_left: None,
            escapes: 0,
            corridor_cycles: 0,
            followed_wall: false,
            passage_after_wall: false,
            straight_from: 0.0,
        }
    }

    /// Whether the robot is in a 0.20 m corridor (the room's exit or the maze's stem) after
    /// turning through an opening: the rescuer's cue to start solving the maze.
    fn in_corridor(&self) -> bool {
        let needed = if self.passage_after_wall {
            CORRIDOR_CYCLES
        } else {
            CORRIDOR_CYCLES_UNSURE
        };
        self.corridor_cycles >= needed
    }

    /// Whether the robot is driving along what looks like the exit.
    fn in_passage(&self) -> bool {
        matches!(self.mode, RoomMode::Passage { .. })
    }

    fn start_hug(&mut self, driver: &mut Driver) {
        self.hug_heading = driver.heading;
        self.axis_known = false;
        self.followed_wall = false;
        self.straight_from = driver.odometer;
        driver.set_axis(driver.heading);
        self.hug_start = driver.odometer;
        self.last_convex = None;
        self.last_touch = Some(driver.odometer);
        self.last_error = None;
        self.mode = RoomMode::Hug;
    }

    /// Keeps the left side at `HUG_DISTANCE` from the surface there, or in the middle of a
    /// passage so narrow that hugging would graze its other side. The sideways distances say
    /// nothing about the heading, so the damping term uses how fast the distance error changes.
    /// A surface well beyond the hugging distance is approached slowly if it stays put (after
    /// a corner), and ignored while it recedes (a wall ending at a corner or at the exit): the
    /// robot then keeps the remembered direction of the surface, so that it passes an opening
    /// parallel to it and sees the opening cleanly.
    fn hug(&mut self, driver: &mut Driver, ranges: &Ranges, dt: f32) -> [f32; 2] {
        let speed = 0.9 * driver.v_max;
        let narrow = ranges.left <= SEEN_MAX && ranges.right <= NARROW_RIGHT;
        let keep_direction = -3.5 * driver.relative_heading();
        let (error, mut turn_rate) = if narrow {
            let error = 0.5 * (ranges.left - ranges.right);
            (
                Some((Regime::Narrow, error)),
                self.damped(Regime::Narrow, error, speed, dt),
            )
        } else if ranges.left <= HUG_DISTANCE + HUG_BAND {
            let error = ranges.left - HUG_DISTANCE;
            let turn_rate = self.damped(Regime::Wall, error, speed, dt);
            if error.abs() < 0.004
                && self
                    .last_error
                    .is_some_and(|(r, e)| r == Regime::Wall && (e - error).abs() < 0.0005)
            {
                // Running parallel to the surface: remember its direction, so that turns at
                // its corners are square to it even if the robot is tilted then.
                driver.axis += 0.2 * (driver.heading - driver.axis);
                self.axis_known = true;
            }
            (Some((Regime::Wall, error)), turn_rate)
        } else if ranges.left <= SEEN_MAX {
            let receding = self
                .last_left
                .is_some_and(|last| ranges.left > last + 0.001);
            // Towards the surface at a bounded angle to the direction of the surface followed
            // before, if that is known; else by turning steadily towards it.
            let approach = if self.axis_known {
                -3.5 * (driver.relative_heading() - HUG_APPROACH_ANGLE)
            } else {
                HUG_APPROACH_RATE
            };
            (None, if receding { keep_direction } else { approach })
        } else {
            (None, keep_direction)
        };
        // Something close ahead on the right or beside the right (a tilted obstacle's
        // corner): veer off it.
        if ranges.front_right < 0.04 {
            turn_rate += 40.0 * (0.04 - ranges.front_right);
        }
        if ranges.right < 0.02 {
            turn_rate += 60.0 * (0.02 - ranges.right);
        }
        self.last_error = error;
        self.last_left = Some(ranges.left);
        driver.command(speed, turn_rate.clamp(-1.5, 1.5), dt)
    }

    /// The hugging law: proportional on the distance error, damped by its rate of change when
    /// the last cycle steered by the same regime.
    fn damped(&self, regime: Regime, error: f32, speed: f32, dt: f32) -> f32 {
        match self.last_error {
            Some((last_regime, last)) if last_regime == regime => {
                let approach = -(error - last) / dt / speed;
                25.0 * error - 3.5 * approach
            }
            _ => 25.0 * error,
        }
    }

    fn step(&mut self, driver: &mut Driver, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let ranges = driver.perceive(frame);
        let width = ranges.left + ranges.right + 2.0 * driver.radius;
        let corridor_like = ranges.left <= SEEN_MAX
            && ranges.right <= SEEN_MAX
            && (0.17..=0.23).contains(&width)
            && self.in_passage();
        self.corridor_cycles = if corridor_like {
            self.corridor_cycles + 1
        } else {
            0
        };
        loop {
            match self.mode {
                RoomMode::Seek => {
                    if ranges.front_min() <= FREE_STOP_AHEAD || ranges.right <= 0.02 {
                        self.mode = RoomMode::Clear;
                        continue;
                    }
                    if ranges.left <= 0.04 {
                        self.start_hug(driver);
                        continue;
                    }
                    return driver.hold(1.0, dt);
                }
                RoomMode::Clear => {
                    if ranges.front_min() > FREE_STOP_AHEAD + 0.015 {
                        self.start_hug(driver);
                        continue;
                    }
                    return driver.command(0.0, -1.9, dt);
                }
                RoomMode::Hug => {
                    if driver.heading - self.hug_heading >= ORBIT_TURN
                        || driver.odometer - self.hug_start > HUG_GIVE_UP
                    {
                        // Circling an obstacle (or lost): leave it, turning away from it.
                        self.escapes += 1;
                        let angle = -FRAC_PI_2 - 0.4 * (self.escapes % 3) as f32;
                        self.mode = RoomMode::Spin {
                            heading: driver.heading + angle,
                            then_seek: true,
                        };
                        continue;
                    }
                    if ranges.front_left <= HUG_CORNER_AHEAD
                        || ranges.front_min() <= 0.5 * HUG_CORNER_AHEAD
                    {
                        // A concave corner: the room's are square.
                        self.last_error = None;
                        let base = if self.axis_known {
                            driver.axis
                        } else {
                            driver.heading
                        };
                        self.followed_wall = true;
                        self.straight_from = driver.odometer;
                        self.mode = RoomMode::Spin {
                            heading: base - FRAC_PI_2,
                            then_seek: false,
                        };
                        continue;
                    }
                    if ranges.left <= HUG_DISTANCE + HUG_BAND {
                        self.last_touch = Some(driver.odometer);
                    }
                    // Just round a convex corner, a wall on the right as well: this is a
                    // passage, most likely the exit.
                    let probing = self
                        .last_convex
                        .is_some_and(|at| driver.odometer - at < PASSAGE_PROBE);
                    if probing && ranges.right <= SEEN_MAX {
                        self.mode = RoomMode::Passage {
                            until: driver.odometer + PASSAGE_LENGTH,
                        };
                        continue;
                    }
                    if driver.is_open(TurnSide::Left) {
                        // A convex corner only ends a surface that was being followed; an
                        // opening after a stretch without one means there is nothing to follow.
                        let touched = self
                            .last_touch
                            .is_some_and(|at| driver.odometer - at < 0.08);
                        let lost = self
                            .last_convex
                            .is_some_and(|at| driver.odometer - at > 0.2)
                            || (!touched
                                && self
                                    .last_convex
                                    .is_none_or(|at| driver.odometer - at > 0.03));
                        if lost {
                            // Nothing on the left since the last corner: the surface is gone.
                            self.mode = RoomMode::Seek;
                            driver.set_axis(driver.heading);
                            continue;
                        }
                        if self
                            .last_convex
                            .is_none_or(|at| driver.odometer - at > 0.03)
                        {
                            self.mode = RoomMode::Advance {
                                until: driver.odometer + CONVEX_ADVANCE,
                            };
                            continue;
                        }
                    }
                    return self.hug(driver, &ranges, dt);
                }
                RoomMode::Advance { until } => {
                    if driver.odometer >= until || ranges.front_min() <= FREE_STOP_AHEAD {
                        // Rectangles have square corners, so a quarter turn faces along the
                        // next side.
                        self.last_convex = Some(driver.odometer);
                        self.passage_after_wall = self.followed_wall
                            || driver.odometer - self.straight_from > OBSTACLE_SIDE_MAX;
                        self.straight_from = driver.odometer;
                        self.last_error = None;
                        let base = if self.axis_known {
                            driver.axis
                        } else {
                            driver.heading
                        };
                        self.mode = RoomMode::Spin {
                            heading: base + FRAC_PI_2,
                            then_seek: false,
                        };
                        continue;
                    }
                    return driver.hold(0.7, dt);
                }
                RoomMode::Spin { heading, then_seek } => {
                    if let Some(wheels) = driver.spin(heading, dt) {
                        return wheels;
                    }
                    driver.set_axis(heading);
                    self.mode = if then_seek {
                        RoomMode::Seek
                    } else {
                        RoomMode::Hug
                    };
                }
                RoomMode::Passage { until } => {
                    if ranges.front_max() <= CORRIDOR_WALL_AHEAD
                        || ranges.front_min() <= FREE_STOP_AHEAD
                    {
                        self.mode = RoomMode::Clear;
                        continue;
                    }
                    if driver.odometer >= until {
                        self.start_hug(driver);
                        continue;
                    }
                    return driver.track(&ranges, 0.9, dt);
                }
            }
        }
    }
}

/// Leaves the room through its narrow exit: drives until something is ahead, then follows it
/// with its left side at about 2 cm. Following a room wall this way turns right at every
/// corner, so the first opening on the left is the exit, which it turns into. Following an
/// obstacle instead turns it left all the time; after most of a full circle it leaves the
/// obstacle and drives off to find a wall.
#[derive(Debug, Clone)]
pub struct RoomExiter {
    driver: Driver,
    logic: RoomLogic,
}

impl RoomExiter {
    /// An exiter for the default robot and sensors.
    pub fn new() -> RoomExiter {
        RoomExiter::with_driver(Driver::standard())
    }

    /// An exiter for the robot and IR mapping of a task configuration.
    pub fn for_task(task: &TaskConfig) -> RoomExiter {
        RoomExiter::with_driver(Driver::for_task(task))
    }

    fn with_driver(driver: Driver) -> RoomExiter {
        RoomExiter {
            driver,
            logic: RoomLogic::new(),
        }
    }
}

impl Default for RoomExiter {
    fn default() -> Self {
        RoomExiter::new()
    }
}

impl Policy for RoomExiter {
    fn reset(&mut self) {
        self.driver.reset();
        self.logic = RoomLogic::new();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.logic.step(&mut self.driver, frame, dt)
    }
}

/// The rescue phases, in the order of the root arbitrator's children.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum RescuePhase {
    ExitRoom = 0,
    SolveMaze = 1,
    Return = 2,
}

/// The whole rescue, composed like the paper's hierarchy: `RoomExiter` until it is in the
/// maze's corridor, then `MazeSolver` (with the flashes seen since the start), and once the
/// teammate is near (`near_robot`) a U-turn and `Returner`, which stops inside the room. It
/// reports the phase as the root's choice (0 exit room, 1 solve maze, 2 return), so the
/// derived fitness f3 can be checked with it: the active path is `[0, 1 + phase]` of 4 nodes.
#[derive(Debug, Clone)]
pub struct Rescuer {
    driver: Driver,
    room: RoomLogic,
    maze: CorridorLogic,
    back: CorridorLogic,
    phase: RescuePhase,
    active: [usize; 2],
}

impl Rescuer {
    /// A rescuer for the default robot and sensors.
    pub fn new() -> Rescuer {
        Rescuer::with_driver(Driver::standard())
    }

    /// A rescuer for the robot and IR mapping of a task configuration.
    pub fn for_task(task: &TaskConfig) -> Rescuer {
        Rescuer::with_driver(Driver::for_task(task))
    }

    fn with_driver(driver: Driver) -> Rescuer {
        Rescuer {
            driver,
            room: RoomLogic::new(),
            maze: CorridorLogic::new(Strategy::Maze),
            back: CorridorLogic::new(Strategy::Return),
            phase: RescuePhase::ExitRoom,
            active: [0, 1],
        }
    }

    /// The current phase: 0 exit the room, 1 solve the maze, 2 return with the teammate.
    pub fn phase(&self) -> usize {
        self.phase as usize
    }
}

impl Default for Rescuer {
    fn default() -> Self {
        Rescuer::new()
    }
}

impl Policy for Rescuer {
    fn reset(&mut self) {
        self.driver.reset();
        self.room = RoomLogic::new();
        self.maze.reset();
        self.back.reset();
        self.phase = RescuePhase::ExitRoom;
        self.active = [0, 1];
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        // The flashes come in the stem, possibly before the maze phase has begun.
        if self.phase != RescuePhase::SolveMaze {
            self.maze.watch_lights(frame);
        }
        if self.phase != RescuePhase::Return && frame.values(InputGroup::NEAR_ROBOT)[0] >= 0.5 {
            self.phase = RescuePhase::Return;
            // Turn around in the branch: the teammate waits at its dead end.
            self.back.mode = CorridorMode::Spin {
                axis: self.driver.axis + PI,
            };
        } else if self.phase == RescuePhase::ExitRoom && self.room.in_corridor() {
            self.phase = RescuePhase::SolveMaze;
            self.maze.mode = CorridorMode::Cruise { settle_until: 0.0 };
        }
        self.active = [0, 1 + self.phase as usize];
        match self.phase {
            RescuePhase::ExitRoom => self.room.step(&mut self.driver, frame, dt),
            RescuePhase::SolveMaze => self.maze.step(&mut self.driver, frame, dt),
            RescuePhase::Return => self.back.step(&mut self.driver, frame, dt),
        }
    }

    fn root_choice(&self) -> Option<usize> {
        Some(self.phase as usize)
    }

    fn active_path(&self) -> &[usize] {
        &self.active
    }

    fn n_nodes(&self) -> usize {
        4
    }
}
