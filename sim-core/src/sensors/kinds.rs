//! The robot's sensors (a scenario's `sensors`, and the input groups a network lists): `ir`,
//! the four IR proximity sensors read through the measured calibration curves
//! ([`crate::sensors::ir`]); `light`, the two lateral sensors in ambient-light mode, as flash
//! detectors ([`crate::sensors::light`]); `near_robot`, whether the teammate is within
//! `robot.near_robot_range`. Each turns what a cycle's [`SenseView`] shows into its inputs;
//! the models and their calibration tables live in [`crate::sensors`], and this file only
//! wires them to the frame.

use super::registry::{SenseView, SensedWorld, Sensor, SensorKind, SensorRun};
use super::{FlashDetector, IR_ANGLES, IrModel, IrSensorSetup, LIGHT_ANGLES, LightModel, N_IR};
use crate::body::Pose;
use crate::config::{IrConfig, LightConfig, N_LIGHT, Params};
use crate::geometry::scene::{Cone, ConeLanes};
use crate::math::float::hypot;
use crate::math::rng::SimRng;

/// A sensor cone for drawing: sensor position, the two boundary ray directions, the range.
pub type IrCone = ([f32; 2], [f32; 2], [f32; 2], f32);

/// `ir`: front-left, left, right and front-right proximity, 1 at contact, 0 at 12 cm or beyond.
pub const IR: SensorKind = SensorKind {
    name: "ir",
    inputs: &["ir_front_left", "ir_left", "ir_right", "ir_front_right"],
    by_default: true,
    compile: compile_ir,
};

/// `light`: a flash seen on the left or on the right, held for `light.hold_cycles`.
pub const LIGHT: SensorKind = SensorKind {
    name: "light",
    inputs: &["light_left", "light_right"],
    by_default: true,
    compile: compile_light,
};

/// `near_robot`: 1 while the teammate is within `robot.near_robot_range`, else 0.
pub const NEAR_ROBOT: SensorKind = SensorKind {
    name: "near_robot",
    inputs: &["near_robot"],
    by_default: true,
    compile: compile_near_robot,
};

const _: () = assert!(IR.inputs.len() == N_IR && LIGHT.inputs.len() == N_LIGHT);

/// Where each of a ring of sensors sits, given the heading's sine and cosine: `[axis][sensor]`.
#[inline(always)]
fn positions<const N: usize>(
    offsets: &[[f32; 2]; N],
    pose: &Pose,
    sin_h: f32,
    cos_h: f32,
) -> [[f32; N]; 2] {
    [
        std::array::from_fn(|s| pose.x + cos_h * offsets[s][0] - sin_h * offsets[s][1]),
        std::array::from_fn(|s| pose.y + sin_h * offsets[s][0] + cos_h * offsets[s][1]),
    ]
}

/// Each sensor's place on the body of a robot of `radius`, in the robot frame.
fn body_offsets<const N: usize>(angles: [f32; N], radius: f32) -> [[f32; 2]; N] {
    angles.map(|a| [radius * a.cos(), radius * a.sin()])
}

/// The IR ring as the task's `ir` and `robot.radius` set it.
#[derive(Debug)]
struct IrSensor {
    /// Each sensor's cone in the robot frame, lane by lane.
    cones: ConeLanes<N_IR>,
    offsets: [[f32; 2]; N_IR],
    /// The robots' radius: another robot of a team is a disc of it.
    radius: f32,
    config: IrConfig,
    model: &'static IrModel,
}

fn compile_ir(params: &Params, _world: &SensedWorld) -> Option<Box<dyn Sensor>> {
    Some(Box::new(IrSensor {
        cones: ConeLanes::new(&ir_cones_at_rest(&params.ir)),
        offsets: body_offsets(IR_ANGLES, params.robot.radius),
        radius: params.robot.radius,
        config: params.ir,
        model: IrModel::builtin(),
    }))
}

fn ir_cones_at_rest(config: &IrConfig) -> [Cone; N_IR] {
    let opening = config.cone_deg.to_radians();
    IR_ANGLES.map(|angle| Cone::new(angle, opening))
}

/// The IR sensors' cones at a pose: for each sensor its position, the directions of its two
/// boundary rays, and the range; for drawing.
pub fn ir_cones(params: &Params, pose: &Pose) -> Vec<IrCone> {
    let (sin_h, cos_h) = pose.heading.sin_cos();
    let origins = positions(
        &body_offsets(IR_ANGLES, params.robot.radius),
        pose,
        sin_h,
        cos_h,
    );
    ir_cones_at_rest(&params.ir)
        .iter()
        .enumerate()
        .map(|(sensor, cone)| {
            let cone = cone.rotated(sin_h, cos_h);
            (
                [origins[0][sensor], origins[1][sensor]],
                cone.boundaries[0],
                cone.boundaries[1],
                params.ir.range_m,
            )
        })
        .collect()
}

impl Sensor for IrSensor {
    fn start<'s>(&'s self, setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(IrRun {
            sensor: self,
            setup: self.config.draw_setup(setup),
        })
    }
}

/// A sample's IR ring: which measured curve models each sensor, and its offset.
#[derive(Debug)]
struct IrRun<'s> {
    sensor: &'s IrSensor,
    setup: IrSensorSetup,
}

impl SensorRun for IrRun<'_> {
    #[inline]
    fn read(&mut self, view: &SenseView<'_>, noise: &mut SimRng, out: &mut [f32]) {
        read_ir(self.sensor, &self.setup, view, noise, out);
    }
}

/// One IR reading: the cones' distances through the scene, then the curves. Compiled for the
/// baseline CPU and again for AVX2, which the CPU picks at run time: the cone test's lane code
/// then uses three-operand vector instructions and blends. Both versions perform the same IEEE
/// operations in the same order (no fused multiply-add), so they give the same bits.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn read_ir(
    sensor: &IrSensor,
    setup: &IrSensorSetup,
    view: &SenseView<'_>,
    noise: &mut SimRng,
    out: &mut [f32],
) {
    let (sin_h, cos_h) = (view.sin_heading, view.cos_heading);
    let cones = sensor.cones.rotated(sin_h, cos_h);
    let origins = positions(&sensor.offsets, view.robot, sin_h, cos_h);
    let mut distances = view.scene.cone_lane_distances(
        view.robot.position(),
        &origins,
        &cones,
        sensor.config.range_m,
    );
    if view.crowd.is_some() || !view.bodies.is_empty() {
        see_other_robots(sensor, view, &origins, &cones, &mut distances);
    }
    out.copy_from_slice(&sensor.model.read_all(setup, &distances, noise));
}

/// Lowers each IR distance to the nearest other robot of a team, mover or box inside that
/// sensor's cone: robots are discs of the robot's own radius, movers and boxes discs of
/// theirs, and a body is candidate only when its centre lies within the range plus its radius
/// and the sensing robot's of the sensing robot's centre (its sensors sit on its rim).
#[inline(never)]
fn see_other_robots(
    sensor: &IrSensor,
    view: &SenseView<'_>,
    origins: &[[f32; N_IR]; 2],
    cones: &ConeLanes<N_IR>,
    distances: &mut [Option<f32>; N_IR],
) {
    let range = sensor.config.range_m;
    let reach = range + 2.0 * sensor.radius;
    let mut best = distances.map(|d| d.unwrap_or(range));
    let mut hit = distances.map(|d| if d.is_some() { u32::MAX } else { 0 });
    for (center, _) in view.others_near(reach) {
        cones.disc_lanes(origins, center, sensor.radius, &mut best, &mut hit);
    }
    let at = view.robot.position();
    for disc in view.bodies {
        let reach = range + sensor.radius + disc.radius;
        let (dx, dy) = (disc.center[0] - at[0], disc.center[1] - at[1]);
        if dx * dx + dy * dy <= reach * reach {
            cones.disc_lanes(origins, disc.center, disc.radius, &mut best, &mut hit);
        }
    }
    *distances = std::array::from_fn(|s| (hit[s] != 0).then_some(best[s]));
}

/// The two light sensors as the task's `light` and `robot.radius` set them.
#[derive(Debug)]
struct LightSensor {
    offsets: [[f32; 2]; N_LIGHT],
    config: LightConfig,
    model: &'static LightModel,
}

fn compile_light(params: &Params, world: &SensedWorld) -> Option<Box<dyn Sensor>> {
    if !world.has_lights {
        return None;
    }
    Some(Box::new(LightSensor {
        offsets: body_offsets(LIGHT_ANGLES, params.robot.radius),
        config: params.light,
        model: LightModel::builtin(),
    }))
}

impl Sensor for LightSensor {
    fn start<'s>(&'s self, _setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(LightRun {
            sensor: self,
            flash: FlashDetector::from_config(&self.config),
        })
    }
}

/// A sample's light sensors: the flash each side holds.
#[derive(Debug)]
struct LightRun<'s> {
    sensor: &'s LightSensor,
    flash: FlashDetector,
}

impl SensorRun for LightRun<'_> {
    #[inline]
    fn read(&mut self, view: &SenseView<'_>, noise: &mut SimRng, out: &mut [f32]) {
        // Without lights there is nothing to see, and nothing is drawn.
        if view.lights.is_empty() {
            return;
        }
        let robot = view.robot;
        let origins = positions(
            &self.sensor.offsets,
            robot,
            view.sin_heading,
            view.cos_heading,
        );
        // A side sees a lit light on its own side only: the body hides a light behind it.
        let mut nearest = [None::<f32>; N_LIGHT];
        // The lit lights only, in index order: the set bits of the mask.
        let mut lit = view.lit_mask;
        while lit != 0 {
            let light_idx = lit.trailing_zeros() as usize;
            lit &= lit - 1;
            let Some(light) = view.lights.get(light_idx) else {
                break;
            };
            for (side, nearest) in nearest.iter_mut().enumerate() {
                let p = [origins[0][side], origins[1][side]];
                let facing = [p[0] - robot.x, p[1] - robot.y];
                let to_light = [light[0] - p[0], light[1] - p[1]];
                if facing[0] * to_light[0] + facing[1] * to_light[1] > 0.0 {
                    let d = hypot(to_light[0], to_light[1]);
                    *nearest = Some(nearest.map_or(d, |n: f32| n.min(d)));
                }
            }
        }
        let raw = self.sensor.model.read_raw_both(nearest, noise);
        out.copy_from_slice(&self.flash.update(raw));
    }
}

/// The near-robot detector, with the task's range: no state, no noise.
#[derive(Debug, Clone, Copy)]
struct NearRobot {
    range_m: f32,
}

fn compile_near_robot(params: &Params, world: &SensedWorld) -> Option<Box<dyn Sensor>> {
    if !world.has_teammate {
        return None;
    }
    Some(Box::new(NearRobot {
        range_m: params.robot.near_robot_range,
    }))
}

impl Sensor for NearRobot {
    fn start<'s>(&'s self, _setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(*self)
    }
}

impl SensorRun for NearRobot {
    #[inline]
    fn read(&mut self, view: &SenseView<'_>, _noise: &mut SimRng, out: &mut [f32]) {
        let near = view
            .teammate
            .is_some_and(|mate| mate.distance_to(view.robot.position()) < self.range_m);
        if let Some(slot) = out.first_mut() {
            *slot = if near { 1.0 } else { 0.0 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::SENSORS;
    use super::*;
    use crate::episode::evaluator::Evaluator;
    use crate::math::rng::{Stream, stream_rng};
    use crate::outcome::Sample;
    use crate::task::TaskConfig;
    use proptest::prelude::*;
    use std::collections::HashSet;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// The IR reading in the version the CPU picks (AVX2 where it has it) gives the bits,
        /// and leaves the noise stream where, the same code compiled for the baseline CPU
        /// does: at random poses, near walls and far from them, in the maze and in rooms.
        #[test]
        fn dispatched_ir_reading_matches_the_baseline_one_bit_for_bit(
            task_idx in 0usize..3,
            seed in any::<u64>(),
            offset in (-0.3f32..0.3, -0.3f32..0.3, -3.2f32..3.2),
        ) {
            if !crate::cpu_feature_for_test(
                "avx2",
                std::arch::is_x86_feature_detected!("avx2"),
                "dispatched_ir_reading_matches_the_baseline_one_bit_for_bit",
            ) {
                return Ok(());
            }
            let task = TaskConfig::shipped(["solve_maze", "rescue", "exit_room"][task_idx]).unwrap();
            let evaluator = Evaluator::new(task.clone()).unwrap();
            let env = evaluator.environment(Sample::seeded(seed));
            let robot = Pose {
                x: env.start.x + offset.0,
                y: env.start.y + offset.1,
                heading: offset.2,
            };
            let view = SenseView::unlit(&robot, &env.scene);
            let (sin_heading, cos_heading) = (view.sin_heading, view.cos_heading);
            let sensor = IrSensor {
                cones: ConeLanes::new(&ir_cones_at_rest(&task.params.ir)),
                offsets: body_offsets(IR_ANGLES, task.params.robot.radius),
                radius: task.params.robot.radius,
                config: task.params.ir,
                model: IrModel::builtin(),
            };
            let setup = task.params.ir.draw_setup(&mut stream_rng(seed, Stream::SensorSetup));
            let (mut noise_dispatched, mut noise_baseline) =
                (stream_rng(seed, Stream::Noise), stream_rng(seed, Stream::Noise));
            let mut dispatched = [0.0f32; N_IR];
            read_ir(&sensor, &setup, &view, &mut noise_dispatched, &mut dispatched);
            // The body of `read_ir`, inlined here and so compiled for the baseline CPU.
            let cones = sensor.cones.rotated(sin_heading, cos_heading);
            let origins = positions(&sensor.offsets, &robot, sin_heading, cos_heading);
            let distances =
                env.scene
                    .cone_lane_distances(robot.position(), &origins, &cones, task.params.ir.range_m);
            let baseline = sensor.model.read_all(&setup, &distances, &mut noise_baseline);
            prop_assert_eq!(dispatched.map(f32::to_bits), baseline.map(f32::to_bits));
            prop_assert_eq!(
                noise_dispatched.random::<u64>(),
                noise_baseline.random::<u64>()
            );
        }
    }

    /// SPEC 2: the near-robot input is 1 when another robot is within 0.15 m (centre to
    /// centre) and 0 beyond: the paper's range, not read from the configuration, in every
    /// direction and whatever the noise stream.
    #[test]
    fn near_robot_reads_one_within_fifteen_centimetres_and_zero_beyond() {
        let task = TaskConfig::shipped("rescue").unwrap();
        let kind = SENSORS
            .iter()
            .find(|kind| kind.name == "near_robot")
            .unwrap();
        let sensor = (kind.compile)(&task.params, &task.scenario.sensed_world())
            .expect("the rescue has a teammate");
        let evaluator = Evaluator::new(task.clone()).unwrap();
        let env = evaluator.environment(Sample::seeded(11));
        let robot = env.start;
        let read = |distance: f32, angle: f32| -> f32 {
            let (sin, cos) = angle.sin_cos();
            let mate = Pose {
                x: robot.x + distance * cos,
                y: robot.y + distance * sin,
                heading: 0.0,
            };
            let mut view = SenseView::unlit(&robot, &env.scene);
            view.teammate = Some(&mate);
            let mut run = sensor.start(&mut stream_rng(11, Stream::SensorSetup));
            let mut out = [0.5f32];
            run.read(&view, &mut stream_rng(11, Stream::Noise), &mut out);
            out[0]
        };
        for step in 0..16 {
            let angle = step as f32 * std::f32::consts::TAU / 16.0;
            assert_eq!(read(0.149, angle), 1.0, "at 0.149 m, angle {angle}");
            assert_eq!(read(0.151, angle), 0.0, "at 0.151 m, angle {angle}");
            assert_eq!(read(0.0, angle), 1.0);
            assert_eq!(read(1.0, angle), 0.0);
        }
    }

    #[test]
    fn registered_sensors_have_distinct_names_and_input_names() {
        let names: HashSet<&str> = SENSORS.iter().map(|kind| kind.name).collect();
        assert_eq!(names.len(), SENSORS.len());
        let inputs: Vec<&str> = SENSORS
            .iter()
            .flat_map(|kind| kind.inputs.iter().copied())
            .collect();
        let distinct: HashSet<&str> = inputs.iter().copied().collect();
        assert_eq!(
            distinct.len(),
            inputs.len(),
            "trace columns must be distinct: {inputs:?}"
        );
        assert!(SENSORS.iter().all(|kind| !kind.inputs.is_empty()));
    }

    #[test]
    fn a_sensor_nothing_in_the_scenario_can_excite_is_not_compiled() {
        let compiled = |task: &str| -> Vec<&str> {
            let task = TaskConfig::shipped(task).unwrap();
            SENSORS
                .iter()
                .filter(|kind| {
                    (kind.compile)(&task.params, &task.scenario.sensed_world()).is_some()
                })
                .map(|kind| kind.name)
                .collect()
        };
        assert_eq!(compiled("exit_room"), ["ir"]);
        assert_eq!(compiled("return_room"), ["ir", "near_robot"]);
        assert_eq!(compiled("rescue"), ["ir", "light", "near_robot"]);
    }
}
