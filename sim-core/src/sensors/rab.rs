//! `rab`: the e-puck's range-and-bearing board, which tells a robot where the other robots of
//! its team (`[[robots]]`) are. The board hears every neighbour whose centre lies within
//! `rab.range_m` of its own (walls do not block it); the sensor folds what it hears into four
//! sectors of 90 degrees centred on the robot's front, left (+90 degrees, counter-clockwise,
//! as `ir_left`), back and right, each reading `1 - d / range` for the nearest neighbour in it
//! (0 when none), and a count of the neighbours heard, over [`RAB_COUNT_CAP`], clipped to 1.
//! A range measured with `rab.range_noise` is `d * (1 + N(0, 1) * range_noise)`, one draw from
//! the sample's noise stream per neighbour heard; with no noise (the default) nothing is drawn.
//! Neighbours are found by the crowd's sort and sweep ([`SenseView::others_near`]), never by
//! a scan of the whole team. The `[teammate]` of the rescue is no robot of a team and is not
//! heard: `near_robot` senses it.

use super::registry::{SenseView, SensedWorld, Sensor, SensorKind, SensorRun};
use crate::config::Params;
use crate::math::rng::{SimRng, standard_normal};

/// `rab`: the nearest neighbour in each of four sectors, and how many are heard.
pub const RAB: SensorKind = SensorKind {
    name: "rab",
    inputs: &[
        "rab_front",
        "rab_left",
        "rab_back",
        "rab_right",
        "rab_count",
    ],
    by_default: false,
    compile: compile_rab,
};

/// The number of sectors: front, left, back, right, in input order.
pub const N_RAB_SECTORS: usize = 4;

/// How many neighbours heard make `rab_count` read 1: a robot in a flock rarely has more
/// within the board's range, and beyond this the count says little to a controller.
pub const RAB_COUNT_CAP: u32 = 8;

/// Sector indices, as the inputs are ordered.
const FRONT: usize = 0;
const LEFT: usize = 1;
const BACK: usize = 2;
const RIGHT: usize = 3;

const _: () = assert!(RAB.inputs.len() == N_RAB_SECTORS + 1);

/// The board with the task's range and noise: no state between cycles.
#[derive(Debug, Clone, Copy)]
struct RangeAndBearing {
    range_m: f32,
    range_noise: f32,
}

fn compile_rab(params: &Params, world: &SensedWorld) -> Option<Box<dyn Sensor>> {
    if !world.has_team {
        return None;
    }
    Some(Box::new(RangeAndBearing {
        range_m: params.rab.range_m,
        range_noise: params.rab.range_noise,
    }))
}

impl Sensor for RangeAndBearing {
    fn start<'s>(&'s self, _setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(*self)
    }
}

/// The sector of a neighbour `forward` metres ahead of the robot and `leftward` metres to its
/// left. A bearing exactly on a border (45 degrees off an axis) counts for the front or the
/// back, so every bearing has one sector; a neighbour at the robot's own centre is in front.
#[inline]
pub(crate) fn sector_of(forward: f32, leftward: f32) -> usize {
    if forward.abs() >= leftward.abs() {
        if forward >= 0.0 { FRONT } else { BACK }
    } else if leftward > 0.0 {
        LEFT
    } else {
        RIGHT
    }
}

impl SensorRun for RangeAndBearing {
    #[inline]
    fn read(&mut self, view: &SenseView<'_>, noise: &mut SimRng, out: &mut [f32]) {
        let range = self.range_m;
        // Strictly within range, as `near_robot`: a neighbour on the edge would read 0 anyway.
        let range_sq = range * range;
        let (sin_h, cos_h) = (view.sin_heading, view.cos_heading);
        let mut nearest = [range; N_RAB_SECTORS];
        let mut heard = 0u32;
        for (position, distance_sq) in view.others_near(range) {
            if distance_sq >= range_sq {
                continue;
            }
            heard += 1;
            let (dx, dy) = (position[0] - view.robot.x, position[1] - view.robot.y);
            let sector = sector_of(dx * cos_h + dy * sin_h, dy * cos_h - dx * sin_h);
            let mut distance = distance_sq.sqrt();
            if self.range_noise > 0.0 {
                distance *= 1.0 + standard_normal(noise) * self.range_noise;
            }
            nearest[sector] = nearest[sector].min(distance);
        }
        let mut values = [0.0f32; N_RAB_SECTORS + 1];
        for (value, distance) in values.iter_mut().zip(nearest) {
            *value = (1.0 - distance / range).clamp(0.0, 1.0);
        }
        values[N_RAB_SECTORS] = (heard as f32 / RAB_COUNT_CAP as f32).min(1.0);
        out.copy_from_slice(&values);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Pose;
    use crate::config::RabConfig;
    use crate::episode::evaluator::Evaluator;
    use crate::geometry::crowd::Crowd;
    use crate::geometry::scene::Scene;
    use crate::math::hash::fnv1a_hex;
    use crate::math::rng::{Stream, stream_rng};
    use crate::network::Policy;
    use crate::network::controller::{Controller, ControllerFile};
    use crate::outcome::{Sample, Trace};
    use crate::scenario::Scenario;
    use crate::sensors::frame::{InputGroup, SensorFrame};
    use crate::task::TaskConfig;
    use rand::RngExt;
    use std::f32::consts::{FRAC_PI_2, PI};
    use std::sync::Arc;

    /// An arena of solids, 2 m square, and a team of five in a 0.5 m square nest at its centre:
    /// the focal robot and four wanderers, every one within 0.8 m of every other at the start.
    const ARENA: &str = r#"
schema = "hevo.scenario/1"
name = "rab_arena"
max_cycles = 300
end_on_collision = false

[world]
solids = [
    [-1.05, -1.05, 1.05, -1.0],
    [-1.05, 1.0, 1.05, 1.05],
    [-1.05, -1.0, -1.0, 1.0],
    [1.0, -1.0, 1.05, 1.0],
]

[regions]
nest = { rect = [-0.25, -0.25, 0.25, 0.25] }
corner = { rect = [0.8, 0.8, 0.95, 0.95] }

[place]
at = "nest"
anywhere = true
facing = "up"
turn_deg = [-180, 180]

[[robots]]
name = "flock"
count = 4
region = "nest"
controller = "wander"

[end]
solved = "in corner"

[fitness]
solved = "1 + time_bonus"
otherwise = "0"
"#;

    /// The arena's task, with `sensors` (a line of the file, or nothing) and `rab` (a table,
    /// or nothing) added.
    fn arena(sensors: &str, rab: &str) -> TaskConfig {
        let text = ARENA
            .replace("max_cycles = 300", &format!("{sensors}max_cycles = 300"))
            .replace("[end]", &format!("{rab}[end]"));
        TaskConfig::from_scenario(Arc::new(Scenario::parse(&text, "rab_arena.toml").unwrap()))
    }

    /// Drives a wide curve whatever it senses.
    #[derive(Debug)]
    struct Curve;

    impl Policy for Curve {
        fn reset(&mut self) {}

        fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
            [0.9, 0.7]
        }
    }

    /// The board with `range_m` and no noise, reading robot 0 of `positions` at `heading`.
    fn read_at(positions: &[[f32; 2]], heading: f32, range_m: f32) -> [f32; 5] {
        let board = RangeAndBearing {
            range_m,
            range_noise: 0.0,
        };
        let mut crowd = Crowd::default();
        crowd.set(positions.iter().copied());
        let robot = Pose {
            x: positions[0][0],
            y: positions[0][1],
            heading,
        };
        let scene = Scene::new(Vec::new(), 0.2);
        let mut view = SenseView::unlit(&robot, &scene);
        view.crowd = Some(&crowd);
        let mut noise = stream_rng(1, Stream::Noise);
        let mut out = [0.0f32; 5];
        board
            .start(&mut stream_rng(1, Stream::SensorSetup))
            .read(&view, &mut noise, &mut out);
        // Without noise, nothing is drawn.
        assert_eq!(
            noise.random::<u64>(),
            stream_rng(1, Stream::Noise).random::<u64>()
        );
        out
    }

    /// A point `distance` from `at`, `bearing` radians counter-clockwise from `heading`.
    fn seen_at(at: [f32; 2], heading: f32, bearing: f32, distance: f32) -> [f32; 2] {
        let (sin, cos) = (heading + bearing).sin_cos();
        [at[0] + distance * cos, at[1] + distance * sin]
    }

    #[test]
    fn a_neighbour_lights_the_sector_it_lies_in_whatever_the_heading() {
        let at = [0.3, -0.2];
        for heading in [0.0, 1.0, -2.5, PI] {
            for (bearing, sector) in [
                (0.0, FRONT),
                (FRAC_PI_2, LEFT),
                (PI, BACK),
                (-FRAC_PI_2, RIGHT),
            ] {
                let out = read_at(&[at, seen_at(at, heading, bearing, 0.4)], heading, 0.8);
                for (idx, &value) in out[..N_RAB_SECTORS].iter().enumerate() {
                    if idx == sector {
                        assert!((value - 0.5).abs() < 1e-5, "heading {heading}: {out:?}");
                    } else {
                        assert_eq!(value, 0.0, "heading {heading}, bearing {bearing}: {out:?}");
                    }
                }
                assert_eq!(out[N_RAB_SECTORS], 1.0 / 8.0);
            }
        }
        // 40 degrees off the front is still the front, 50 degrees the left or the right.
        let heading = 0.7;
        let at = [0.0, 0.0];
        for (bearing_deg, sector) in [
            (40.0f32, FRONT),
            (50.0, LEFT),
            (-50.0, RIGHT),
            (140.0, BACK),
        ] {
            let out = read_at(
                &[at, seen_at(at, heading, bearing_deg.to_radians(), 0.2)],
                heading,
                0.8,
            );
            assert!(out[sector] > 0.0, "{bearing_deg} degrees: {out:?}");
        }
        // The IR ring's left sensor is at +90 degrees too: the same side.
        assert_eq!(super::super::IR_ANGLES[1], FRAC_PI_2);
    }

    #[test]
    fn a_sector_reads_its_nearest_neighbour_and_the_count_all_heard() {
        let at = [0.0, 0.0];
        let out = read_at(
            &[at, [0.6, 0.0], [0.2, 0.05], [0.0, -0.4], [-3.0, 0.0]],
            0.0,
            0.8,
        );
        let d = 0.2f32.hypot(0.05);
        assert!((out[FRONT] - (1.0 - d / 0.8)).abs() < 1e-6, "{out:?}");
        assert!((out[RIGHT] - 0.5).abs() < 1e-6, "{out:?}");
        assert_eq!((out[LEFT], out[BACK]), (0.0, 0.0));
        // The robot 3 m away is not heard.
        assert_eq!(out[N_RAB_SECTORS], 3.0 / 8.0);
    }

    #[test]
    fn a_neighbour_is_heard_within_range_and_not_beyond() {
        let at = [0.1, 0.1];
        let inside = read_at(&[at, [0.1 + 0.799, 0.1]], 0.0, 0.8);
        assert!(inside[FRONT] > 0.0 && inside[FRONT] < 0.01, "{inside:?}");
        assert_eq!(inside[N_RAB_SECTORS], 1.0 / 8.0);
        for beyond in [0.801, 0.9, 5.0] {
            assert_eq!(read_at(&[at, [0.1 + beyond, 0.1]], 0.0, 0.8), [0.0; 5]);
        }
        // A shorter board hears less.
        assert_eq!(read_at(&[at, [0.5, 0.1]], 0.0, 0.3), [0.0; 5]);
        // Touching robots read nearly 1.
        let touching = read_at(&[at, [0.175, 0.1]], 0.0, 0.8);
        assert!((touching[FRONT] - (1.0 - 0.075 / 0.8)).abs() < 1e-5);
    }

    #[test]
    fn the_count_is_clipped_at_its_cap() {
        let ring = |n: usize| -> Vec<[f32; 2]> {
            std::iter::once([0.0, 0.0])
                .chain((0..n).map(|k| seen_at([0.0, 0.0], 0.0, k as f32 * 0.3, 0.3)))
                .collect()
        };
        for (n, count) in [
            (0, 0.0),
            (1, 0.125),
            (7, 0.875),
            (8, 1.0),
            (9, 1.0),
            (20, 1.0),
        ] {
            assert_eq!(
                read_at(&ring(n), 0.0, 0.8)[N_RAB_SECTORS],
                count,
                "{n} robots"
            );
        }
    }

    #[test]
    fn nothing_is_read_or_drawn_alone() {
        // A robot alone has no crowd; one of a crowd of one hears no one.
        let board = RangeAndBearing {
            range_m: 0.8,
            range_noise: 0.2,
        };
        let robot = Pose {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
        };
        let scene = Scene::new(Vec::new(), 0.2);
        let alone = SenseView::unlit(&robot, &scene);
        let mut crowd = Crowd::default();
        crowd.set([[0.0, 0.0]]);
        let mut in_crowd = alone;
        in_crowd.crowd = Some(&crowd);
        for view in [alone, in_crowd] {
            let mut noise = stream_rng(5, Stream::Noise);
            let mut out = [0.0f32; 5];
            board
                .start(&mut stream_rng(5, Stream::SensorSetup))
                .read(&view, &mut noise, &mut out);
            assert_eq!(out, [0.0; 5]);
            assert_eq!(
                noise.random::<u64>(),
                stream_rng(5, Stream::Noise).random::<u64>()
            );
        }
        // A world without a team compiles no board at all.
        let task = TaskConfig::shipped("rescue").unwrap();
        let world = task.scenario.sensed_world();
        assert!(!world.has_team);
        assert!((RAB.compile)(&task.params, &world).is_none());
        assert!(
            (RAB.compile)(
                &task.params,
                &SensedWorld {
                    has_team: true,
                    ..world
                }
            )
            .is_some()
        );
    }

    #[test]
    fn range_noise_draws_once_per_neighbour_heard_and_stays_in_bounds() {
        let board = RangeAndBearing {
            range_m: 0.8,
            range_noise: 0.5,
        };
        let robot = Pose {
            x: 0.0,
            y: 0.0,
            heading: 0.0,
        };
        let scene = Scene::new(Vec::new(), 0.2);
        let mut crowd = Crowd::default();
        crowd.set([[0.0, 0.0], [0.4, 0.0], [0.0, 0.7], [2.0, 0.0]]);
        let mut view = SenseView::unlit(&robot, &scene);
        view.crowd = Some(&crowd);
        let mut run = board.start(&mut stream_rng(9, Stream::SensorSetup));
        let mut noise = stream_rng(9, Stream::Noise);
        let mut spread = Vec::new();
        for _ in 0..200 {
            let mut out = [0.0f32; 5];
            run.read(&view, &mut noise, &mut out);
            assert!(out.iter().all(|v| (0.0..=1.0).contains(v)), "{out:?}");
            assert_eq!(out[N_RAB_SECTORS], 2.0 / 8.0);
            spread.push(out[FRONT]);
        }
        assert!(
            spread.iter().any(|&v| v != spread[0]),
            "the noise moves the reading"
        );
        // Two neighbours heard, two draws per cycle.
        let mut expected = stream_rng(9, Stream::Noise);
        for _ in 0..400 {
            standard_normal(&mut expected);
        }
        assert_eq!(noise.random::<u64>(), expected.random::<u64>());
    }

    /// Reads the board of a trace's focal robot again, by a scan of every robot of the team.
    fn read_by_scan(trace: &Trace, cycle: usize, range: f32) -> [f32; 5] {
        let step = &trace.cycles[cycle];
        let robot = step.robot;
        let (sin_h, cos_h) = crate::math::trig::sin_cos(robot.heading);
        let mut nearest = [range; 4];
        let mut heard = 0;
        for other in &step.team {
            let (dx, dy) = (other.x - robot.x, other.y - robot.y);
            let distance_sq = dx * dx + dy * dy;
            if distance_sq < range * range {
                heard += 1;
                let sector = sector_of(dx * cos_h + dy * sin_h, dy * cos_h - dx * sin_h);
                nearest[sector] = nearest[sector].min(distance_sq.sqrt());
            }
        }
        let mut out = [0.0; 5];
        for (value, distance) in out.iter_mut().zip(nearest) {
            *value = (1.0 - distance / range).clamp(0.0, 1.0);
        }
        out[4] = (heard as f32 / 8.0).min(1.0);
        out
    }

    #[test]
    fn a_team_in_an_arena_hears_its_neighbours() {
        let task = arena("sensors = [\"ir\", \"rab\"]\n", "");
        let evaluator = Evaluator::new(task).unwrap();
        let mut heard_cycles = 0;
        for seed in 0..4 {
            let trace = evaluator.evaluate_traced(&mut Curve, Sample::seeded(seed));
            let first = trace.cycles[0].frame.values(InputGroup::RAB);
            // All five start in a 0.5 m square: every other robot is heard.
            assert_eq!(first[N_RAB_SECTORS], 4.0 / 8.0, "seed {seed}: {first:?}");
            assert!(first[..N_RAB_SECTORS].iter().any(|&v| v > 0.0));
            for (cycle, step) in trace.cycles.iter().enumerate() {
                let read = step.frame.values(InputGroup::RAB);
                assert_eq!(
                    read,
                    read_by_scan(&trace, cycle, 0.8),
                    "seed {seed}, cycle {cycle}"
                );
                heard_cycles += usize::from(read[N_RAB_SECTORS] > 0.0);
                assert!(
                    step.frame
                        .values(InputGroup::LIGHT)
                        .iter()
                        .all(|&v| v == 0.0)
                );
            }
        }
        assert!(heard_cycles > 0);
        // A shorter board, set in the file, hears fewer.
        let short = Evaluator::new(arena(
            "sensors = [\"ir\", \"rab\"]\n",
            "[rab]\nrange_m = 0.1\n\n",
        ))
        .unwrap();
        assert_eq!(short.task().params.rab.range_m, 0.1);
        let trace = short.evaluate_traced(&mut Curve, Sample::seeded(0));
        for (cycle, step) in trace.cycles.iter().enumerate() {
            assert_eq!(
                step.frame.values(InputGroup::RAB),
                read_by_scan(&trace, cycle, 0.1)
            );
        }
    }

    #[test]
    fn a_bad_rab_table_is_refused_by_its_key() {
        let task = arena("sensors = [\"ir\", \"rab\"]\n", "[rab]\nrange_m = 0.0\n\n");
        let error = Evaluator::new(task).unwrap_err().to_string();
        assert!(error.contains("rab.range_m"), "{error}");
        let text = ARENA.replace("[end]", "[rab]\nrange = 0.5\n\n[end]");
        let error = Scenario::parse(&text, "rab_arena.toml")
            .unwrap_err()
            .to_string();
        assert!(error.contains("range"), "{error}");
    }

    #[test]
    fn a_task_at_the_default_board_serialises_as_before_and_another_round_trips() {
        let task = arena("", "");
        let json = serde_json::to_string(&task).unwrap();
        assert!(!json.contains("\"rab\""), "{json}");
        let mut wide = task.clone();
        wide.params.rab = RabConfig {
            range_m: 1.2,
            range_noise: 0.1,
        };
        let json = serde_json::to_string(&wide).unwrap();
        assert!(json.contains("\"rab\":{\"range_m\":1.2"), "{json}");
        assert_eq!(serde_json::from_str::<TaskConfig>(&json).unwrap(), wide);
    }

    /// The frame inputs a robot without the board reads (ir, light, near_robot), cycle after
    /// cycle, hashed: the count of cycles and the hash.
    fn frames_digest(task: TaskConfig, policy: &mut impl Policy, sample: Sample) -> String {
        let trace = Evaluator::new(task)
            .unwrap()
            .evaluate_traced(policy, sample);
        let mut bytes = Vec::new();
        for cycle in &trace.cycles {
            assert_eq!(cycle.frame.values(InputGroup::RAB), [0.0; 5]);
            for value in &cycle.frame.inputs[..InputGroup::RAB.flat_range().start] {
                bytes.extend_from_slice(&value.to_bits().to_le_bytes());
            }
        }
        format!("{} {}", trace.cycles.len(), fnv1a_hex(&bytes))
    }

    fn shipped_controller(text: &str) -> Controller {
        Controller::new(&ControllerFile::from_json_str(text).unwrap(), None).unwrap()
    }

    /// Robots that do not carry the board read what they read before it existed, bit for bit:
    /// the digests were recorded with the sensors as they were then.
    #[test]
    fn a_robot_without_the_board_reads_as_before_it_existed() {
        assert_eq!(InputGroup::RAB.flat_range().start, 7);
        let rescue = frames_digest(
            TaskConfig::shipped("rescue").unwrap(),
            &mut shipped_controller(include_str!("../../../controllers/rescue.json")),
            Sample {
                seed: 18,
                variant: Some(2),
            },
        );
        assert_eq!(rescue, "1021 fcc0cd7db32b81e4");
        let maze = frames_digest(
            TaskConfig::shipped("solve_maze").unwrap(),
            &mut shipped_controller(include_str!("../../../controllers/solve_maze.json")),
            Sample {
                seed: 16,
                variant: Some(1),
            },
        );
        assert_eq!(maze, "258 1df5a9e1520051d5");
        // A team whose robots carry the e-puck's sensors, or the IR ring alone.
        let team = frames_digest(arena("", ""), &mut Curve, Sample::seeded(3));
        assert_eq!(team, "300 12e5be4eac48e749");
        let ir_only = frames_digest(
            arena("sensors = [\"ir\"]\n", ""),
            &mut Curve,
            Sample::seeded(4),
        );
        assert_eq!(ir_only, "300 858132a8ae255365");
    }

    /// A board without noise draws nothing: the robots of a team that carries it move, and
    /// read their IR, exactly as they do without it.
    #[test]
    fn a_board_without_noise_leaves_everything_else_as_it_was() {
        let with = Evaluator::new(arena("sensors = [\"ir\", \"rab\"]\n", "")).unwrap();
        let without = Evaluator::new(arena("sensors = [\"ir\"]\n", "")).unwrap();
        for seed in 0..3 {
            let a = with.evaluate_traced(&mut Curve, Sample::seeded(seed));
            let b = without.evaluate_traced(&mut Curve, Sample::seeded(seed));
            assert_eq!(a.cycles.len(), b.cycles.len());
            for (x, y) in a.cycles.iter().zip(&b.cycles) {
                assert_eq!((x.robot, &x.team), (y.robot, &y.team));
                assert_eq!(
                    x.frame.values(InputGroup::IR),
                    y.frame.values(InputGroup::IR)
                );
            }
        }
    }
}
