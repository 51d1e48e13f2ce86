//! The robot's body and motors, and the control cycle.

use super::{ConfigError, invalid};
use serde::{Deserialize, Serialize};

/// Physical constants of the robot and the control cycle (SPEC section 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotConfig {
    /// Body radius, metres (e-puck diameter 0.075 m).
    pub radius: f32,
    /// Distance between the wheels, metres.
    pub wheel_base: f32,
    /// Top wheel speed, metres per second (the hardware allows 0.13).
    pub v_max: f32,
    /// Standard deviation of the multiplicative wheel noise, drawn per wheel per cycle.
    pub wheel_noise: f32,
    /// Control cycle, seconds.
    pub cycle_seconds: f32,
    /// Range of the near-robot sensor (range & bearing board), metres, centre to centre.
    pub near_robot_range: f32,
}

impl Default for RobotConfig {
    fn default() -> Self {
        RobotConfig {
            radius: 0.0375,
            wheel_base: 0.053,
            v_max: 0.1,
            wheel_noise: 0.05,
            cycle_seconds: 0.1,
            near_robot_range: 0.15,
        }
    }
}

impl RobotConfig {
    /// Checks the values are physically meaningful; names the offending key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let positive = [
            ("radius", self.radius),
            ("wheel_base", self.wheel_base),
            ("v_max", self.v_max),
            ("cycle_seconds", self.cycle_seconds),
            ("near_robot_range", self.near_robot_range),
        ];
        for (name, value) in positive {
            if !(value.is_finite() && value > 0.0) {
                return Err(invalid(
                    &format!("robot.{name}"),
                    format!("must be a positive number, got {value}"),
                ));
            }
        }
        if !(self.wheel_noise.is_finite() && (0.0..1.0).contains(&self.wheel_noise)) {
            return Err(invalid(
                "robot.wheel_noise",
                format!("must be in [0, 1), got {}", self.wheel_noise),
            ));
        }
        // One cycle's travel must stay well below the thinnest solid (5 cm obstacles) so a
        // move can never jump through a wall between two collision tests.
        if self.v_max * self.cycle_seconds > 0.025 {
            return Err(invalid(
                "robot.v_max",
                format!(
                    "times robot.cycle_seconds is {} m per cycle, more than 0.025 m",
                    self.v_max * self.cycle_seconds
                ),
            ));
        }
        Ok(())
    }
}
