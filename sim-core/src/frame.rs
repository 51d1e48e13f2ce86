//! The sensor frame: what the robot perceives in one control cycle, in the normalised form the
//! networks read. It is the single interface between the world (which fills it) and the
//! controllers (which read the groups of inputs each network declares).

use serde::{Deserialize, Serialize};

/// Number of infrared proximity inputs: front-left (+17 deg), left (+90 deg), right (-90 deg),
/// front-right (-17 deg), in that order.
pub const N_IR: usize = 4;
/// Number of light-flash inputs: left, right.
pub const N_LIGHT: usize = 2;

/// Angles of the four IR sensors from the heading, radians, in input order.
pub const IR_ANGLES: [f32; N_IR] = [
    17.0 * std::f32::consts::PI / 180.0,
    std::f32::consts::FRAC_PI_2,
    -std::f32::consts::FRAC_PI_2,
    -17.0 * std::f32::consts::PI / 180.0,
];

/// All inputs of one control cycle, each in [0, 1].
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorFrame {
    /// IR proximity: 1 at contact, 0 at 12 cm or beyond.
    pub ir: [f32; N_IR],
    /// Light flash held inputs: left, right.
    pub light: [f32; N_LIGHT],
    /// 1 when another robot is within the near-robot range.
    pub near_robot: f32,
}

/// A named group of inputs a network can declare. A network's inputs are the concatenation of
/// its groups in the order it lists them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputGroup {
    /// The four IR proximity inputs.
    Ir,
    /// The two light-flash inputs.
    Light,
    /// The near-robot boolean.
    NearRobot,
}

impl InputGroup {
    /// How many network inputs this group contributes.
    pub fn width(self) -> usize {
        match self {
            InputGroup::Ir => N_IR,
            InputGroup::Light => N_LIGHT,
            InputGroup::NearRobot => 1,
        }
    }

    /// The group's current values in the frame.
    pub fn values(self, frame: &SensorFrame) -> &[f32] {
        match self {
            InputGroup::Ir => &frame.ir,
            InputGroup::Light => &frame.light,
            InputGroup::NearRobot => std::slice::from_ref(&frame.near_robot),
        }
    }
}
