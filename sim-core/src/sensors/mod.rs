//! Sensor models: how the e-puck's IR proximity and ambient-light sensors turn the distances the
//! world computes into the normalised inputs of the sensor frame. Both models are built once
//! from measured calibration tables (embedded in the crate) and resampled onto a fine uniform
//! distance grid, so a per-cycle read is an index, a linear interpolation and one normal draw
//! from the sample's own noise stream, with no allocation.

pub mod calibration;
pub mod ir;
pub mod light;

pub use calibration::{CalibrationError, CalibrationTable, MeanStd, MeasuredCurve, ResampledCurve};
pub use ir::{CurveChoice, IR_ANGLES, IrConfig, IrMapping, IrModel, IrSensorSetup, N_IR};
pub use light::{FlashDetector, LIGHT_ANGLES, LightConfig, LightModel, N_LIGHT};
