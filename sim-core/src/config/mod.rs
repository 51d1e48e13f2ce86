//! The numbers in force: every setting of the robot, its sensors and the world's generators,
//! as one plain, serialisable [`Params`], and the one error a bad value gets ([`ConfigError`]).
//! A scenario file's tables are its defaults; a task may override any of them. Nothing here
//! knows a scenario, a world or a controller, so every floor above can take `&Params`.

mod corridor;
mod ir;
mod light;
mod rab;
mod robot;
mod room;

pub use corridor::{CorridorConfig, MAZE_CELL_SIZE, StartConfig};
pub use ir::{CurveChoice, IrConfig, IrMapping};
pub use light::{LightConfig, N_LIGHT};
pub use rab::RabConfig;
pub use robot::RobotConfig;
pub use room::{ObstaclePlacement, RoomConfig};

/// Every number of the robot, its sensors and the world's generators: the seven tables a
/// scenario file and a task carry.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params {
    /// Robot body and motors.
    pub robot: RobotConfig,
    /// IR proximity sensors.
    pub ir: IrConfig,
    /// Light-flash sensing.
    pub light: LightConfig,
    /// The range-and-bearing board.
    pub rab: RabConfig,
    /// The room generator.
    pub room: RoomConfig,
    /// The corridor generator.
    pub corridor: CorridorConfig,
    /// Start placement in corridors and the maze.
    pub start: StartConfig,
}

impl Params {
    /// How far around a grid cell the scene must list solids: the body, the IR range and a
    /// cycle of movement.
    pub fn query_margin(&self) -> f32 {
        self.robot.radius + self.ir.range_m + self.robot.v_max * self.robot.cycle_seconds + 0.02
    }
}

/// A value of a task configuration that is out of range, or an option where it does not apply.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key} {message}")]
pub struct ConfigError {
    /// The key, as in the configuration: `robot.v_max`, `corridor.start_advance`.
    pub key: String,
    /// What is wrong: `must be in [0, 1], got 2`.
    pub message: String,
}

/// A [`ConfigError`] for `key`.
pub(crate) fn invalid(key: &str, message: String) -> ConfigError {
    ConfigError {
        key: key.to_string(),
        message,
    }
}
