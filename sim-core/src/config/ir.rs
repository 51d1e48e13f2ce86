//! The IR proximity sensors: their geometry, noise and how a reading becomes an input. The
//! sensor model itself, with its calibration tables, is [`crate::sensors::ir`].

use super::{ConfigError, invalid};
use serde::{Deserialize, Serialize};

/// How each sample picks the measured curve that models each IR sensor.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurveChoice {
    /// Each sensor independently uses any of the 8 measured curves, so controllers meet the
    /// full variety of real sensors, including mismatched ones on one robot.
    #[default]
    Any,
    /// One of the two measured robots is picked per sample and each sensor uses that robot's
    /// curve for the matching physical sensor (see `SAME_ROBOT_CURVES` in the IR model).
    SameRobot,
    /// Every sensor uses the average curve; no per-sensor variety.
    Mean,
}

/// How a raw reading becomes a network input in [0, 1] (1 at contact, 0 at 12 cm or beyond).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IrMapping {
    /// Model version 3's mapping: as `average_table`, after a baseline correction that moves
    /// each sensor's empty reading, plus a margin of four noise standard deviations, onto the
    /// average curve's. The margin makes walls 9 cm away read 0 even on the average curve, so
    /// a robot driving along one wall cannot see the other, nor an opening in it; return to
    /// room could not bootstrap past one start branch in four (72 % after 150 generations
    /// with `average_table`, against 25 % flat).
    LinearDistance,
    /// Linear in the raw value between the curve's mean at 12 cm (0) and at contact (1). A
    /// wall 6 cm away reads 0.008: the sensor is close to a contact switch, and the turning
    /// primitives did not bootstrap with it.
    LinearRaw,
    /// The default, as JBotEvolver's `EpuckIRSensor` (the paper's simulator): nothing sensed
    /// beyond 12 cm (reads 0); nearer, the raw reading drawn from the sensor's own curve is
    /// turned back into a distance through the average table (what a robot calibrated once
    /// with the average table does), with no baseline correction, and the input is
    /// `1 - d / 12 cm`. A sensor whose own curve differs from the average reads systematically
    /// off, as a real one would; a wall 8-9 cm away reads about 0.2-0.3 on most curves.
    #[default]
    AverageTable,
}

/// IR sensor configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IrConfig {
    /// How far from the robot's body a sensor senses, metres. Beyond 12 cm a sensor reads 0
    /// anyway (the alternative mappings read the calibration's farthest row); the world uses
    /// this and `cone_deg` for geometry.
    pub range_m: f32,
    /// Opening of each sensor's cone, degrees.
    pub cone_deg: f32,
    /// Largest fixed offset noise, as a fraction of the input: each sensor's offset is drawn
    /// from U(-offset_fraction, +offset_fraction) at the start of each sample.
    pub offset_fraction: f32,
    /// How each sample picks the measured curves.
    pub curve_choice: CurveChoice,
    /// How a raw reading maps to the input.
    pub mapping: IrMapping,
}

impl Default for IrConfig {
    fn default() -> Self {
        IrConfig {
            range_m: 0.14,
            cone_deg: 70.0,
            offset_fraction: 0.05,
            curve_choice: CurveChoice::Any,
            mapping: IrMapping::AverageTable,
        }
    }
}

impl IrConfig {
    /// Checks the sensors' geometry; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.range_m > 0.0 && self.range_m <= 0.5) {
            return Err(invalid(
                "ir.range_m",
                format!("must be in (0, 0.5], got {}", self.range_m),
            ));
        }
        if !(self.cone_deg >= 0.0 && self.cone_deg < 180.0) {
            return Err(invalid(
                "ir.cone_deg",
                format!("must be in [0, 180), got {}", self.cone_deg),
            ));
        }
        Ok(())
    }
}
