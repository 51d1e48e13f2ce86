//! `items`: what a forager sees of the items on the floor (`[[objects]]`): the nearest item
//! lying on the floor in each of four sectors of 90 degrees centred on the robot's front,
//! left, back and right (the sectors of `rab`), each reading `1 - d / range` for the nearest
//! item centre within [`ITEM_SENSOR_RANGE`] of the robot's (0 when none), and whether the
//! robot carries an item (0 or 1). Walls do not hide an item; nothing is drawn (a camera
//! looking down at tokens on a floor, read without noise), so adding the sensor to a
//! scenario moves no other draw.

use super::rab::{N_RAB_SECTORS, sector_of};
use super::registry::{SenseView, SensedWorld, Sensor, SensorKind, SensorRun};
use crate::config::Params;
use crate::math::rng::SimRng;

/// `items`: the nearest item on the floor in each of four sectors, and whether the robot
/// carries one.
pub const ITEMS: SensorKind = SensorKind {
    name: "items",
    inputs: &[
        "items_front",
        "items_left",
        "items_back",
        "items_right",
        "items_carrying",
    ],
    by_default: false,
    compile: compile_items,
};

/// How far the item sensor sees, centre to centre, metres: a few body lengths, about what the
/// e-puck's camera resolves of a small token on the floor ahead.
pub const ITEM_SENSOR_RANGE: f32 = 0.3;

const _: () = assert!(ITEMS.inputs.len() == N_RAB_SECTORS + 1);

/// The item sensor: no state between cycles, no setting.
#[derive(Debug, Clone, Copy)]
struct ItemSensor;

fn compile_items(_params: &Params, world: &SensedWorld) -> Option<Box<dyn Sensor>> {
    world
        .has_items
        .then(|| Box::new(ItemSensor) as Box<dyn Sensor>)
}

impl Sensor for ItemSensor {
    fn start<'s>(&'s self, _setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(*self)
    }
}

impl SensorRun for ItemSensor {
    fn read(&mut self, view: &SenseView<'_>, _noise: &mut SimRng, out: &mut [f32]) {
        let Some(items) = view.items else {
            return;
        };
        let range = ITEM_SENSOR_RANGE;
        let range_sq = range * range;
        let (sin_h, cos_h) = (view.sin_heading, view.cos_heading);
        let mut nearest_sq = [range_sq; N_RAB_SECTORS];
        for position in items.on_floor() {
            let (dx, dy) = (position[0] - view.robot.x, position[1] - view.robot.y);
            let distance_sq = dx * dx + dy * dy;
            if distance_sq >= range_sq {
                continue;
            }
            let sector = sector_of(dx * cos_h + dy * sin_h, dy * cos_h - dx * sin_h);
            nearest_sq[sector] = nearest_sq[sector].min(distance_sq);
        }
        for (value, distance_sq) in out.iter_mut().zip(nearest_sq) {
            *value = (1.0 - distance_sq.sqrt() / range).clamp(0.0, 1.0);
        }
        out[N_RAB_SECTORS] = if items.carries(view.me) { 1.0 } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::Pose;
    use crate::geometry::items::Items;
    use crate::geometry::scene::Scene;
    use crate::math::rng::{Stream, stream_rng};
    use std::f32::consts::FRAC_PI_2;

    /// The sensor's inputs for robot 0 at the origin facing `heading`, among `items`.
    fn read(items: &Items, heading: f32) -> [f32; 5] {
        let robot = Pose {
            x: 0.0,
            y: 0.0,
            heading,
        };
        let scene = Scene::new(Vec::new(), 0.1);
        let view = SenseView {
            items: Some(items),
            ..SenseView::unlit(&robot, &scene)
        };
        let mut out = [0.0; 5];
        ItemSensor.read(&view, &mut stream_rng(0, Stream::Noise), &mut out);
        out
    }

    #[test]
    fn each_sector_reads_its_nearest_item_and_the_last_input_says_carrying() {
        // Ahead 0.15 m and 0.2 m, to the left 0.06 m, out of range behind.
        let items = Items::new(vec![[0.15, 0.0], [0.2, 0.0], [0.0, 0.06], [-0.31, 0.0]], 1);
        let got = read(&items, 0.0);
        let expected = [1.0 - 0.15 / 0.3, 1.0 - 0.06 / 0.3, 0.0, 0.0, 0.0];
        for (got, expected) in got.iter().zip(expected) {
            assert!((got - expected).abs() < 1e-6, "{got} vs {expected}");
        }
        // Facing left (+y), the item at (0.15, 0) is on the right.
        let turned = read(&items, FRAC_PI_2);
        assert!((turned[3] - 0.5).abs() < 1e-6, "{turned:?}");
        assert!((turned[0] - 0.8).abs() < 1e-6, "{turned:?}");
        // Carrying the item at the robot's centre: it is off the floor, and carried.
        let mut items = Items::new(vec![[0.0, 0.0], [0.15, 0.0]], 1);
        items.step(&[[0.0, 0.0]], 0.05, |_| false);
        let carrying = read(&items, 0.0);
        assert_eq!(carrying[4], 1.0);
        assert!((carrying[0] - 0.5).abs() < 1e-6, "{carrying:?}");
    }
}
