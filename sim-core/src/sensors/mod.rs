//! The robot's sensors: what a sensor is ([`registry`]) and the one list of those that exist
//! ([`SENSORS`], below), the frame their inputs fill ([`frame`]), the registered kinds (`ir`,
//! `light`, `near_robot`: [`kinds`]; `rab`, the range-and-bearing board: [`rab`]; `items`, the
//! items on the floor: [`items`]), and the
//! sensor models: how the e-puck's IR proximity and ambient-light sensors
//! turn the distances the world computes into the normalised inputs of the sensor frame. Both
//! models are built once from measured calibration tables (embedded in the crate) and
//! resampled onto a fine uniform distance grid, so a per-cycle read is an index, a linear
//! interpolation and one normal draw from the sample's own noise stream, with no allocation.

pub mod calibration;
pub mod frame;
pub mod ir;
pub mod items;
pub mod kinds;
pub mod light;
pub mod rab;
pub mod registry;

pub use ir::{IR_ANGLES, IrModel, IrSensorSetup, N_IR};
pub use kinds::IrCone;
pub use light::{FlashDetector, LIGHT_ANGLES, LightModel};
pub use registry::{SenseView, SensedWorld, Sensor, SensorKind, SensorRun};

/// The robot's sensors, in frame order: a frame holds each one's inputs in this order, and a
/// cycle reads them (and draws their noise) in this order, so a new one goes last. A
/// scenario's robot carries those its `sensors` key names, or else those carried by default;
/// each one's name is also the input group a network lists.
pub const SENSORS: &[SensorKind] = &[
    kinds::IR,
    kinds::LIGHT,
    kinds::NEAR_ROBOT,
    rab::RAB,
    items::ITEMS,
];
