//! `compass`: the robot's heading as two inputs in [0, 1], (1 + cos) / 2 and (1 + sin) / 2.
use super::{SenseView, Sensor, SensorKind, SensorRun};
use crate::math::rng::SimRng;

pub const COMPASS: SensorKind = SensorKind {
    name: "compass",
    inputs: &["compass_cos", "compass_sin"],
    by_default: false,
    compile: |_params, _world| Some(Box::new(Compass)),
};

#[derive(Debug, Clone, Copy)]
struct Compass;

impl Sensor for Compass {
    fn start<'s>(&'s self, _setup: &mut SimRng) -> Box<dyn SensorRun + 's> {
        Box::new(*self)
    }
}

impl SensorRun for Compass {
    fn read(&mut self, view: &SenseView<'_>, _noise: &mut SimRng, out: &mut [f32]) {
        for (slot, value) in out.iter_mut().zip([view.cos_heading, view.sin_heading]) {
            *slot = 0.5 * (1.0 + value);
        }
    }
}
