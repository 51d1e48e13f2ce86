//! The corridor generator's shapes and how a robot is placed at a corridor or maze start. The
//! generator is [`crate::world::corridor`].

use super::{ConfigError, invalid};
use serde::{Deserialize, Serialize};

/// The maze's cell side (JBotEvolver's default): corridors are built of the maze's own cells.
pub const MAZE_CELL_SIZE: f32 = 0.30;

/// Corridor shapes for the maze primitives.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CorridorConfig {
    /// Straight corridor length range, in 0.30 m cells, inclusive.
    pub straight_cells: [u32; 2],
    /// Cells before the turn, inclusive range (the turn cell included).
    pub cells_before_turn: [u32; 2],
    /// Cells after the turn, inclusive range.
    pub cells_after_turn: [u32; 2],
    /// Share of turn samples whose turn is a T-junction with a wrong arm, not an L-bend.
    pub junction_share: f32,
    /// Share of turn samples whose turn is a side opening with the corridor going on straight
    /// past it (a wrong branch), as on the way back out of the maze. The turning tasks use
    /// 0.4; absent means 0, which leaves the content hash of every other task, and so the
    /// fingerprints of runs evolved before this option existed, unchanged.
    #[serde(skip_serializing_if = "is_zero")]
    pub side_junction_share: f32,
    /// The robot starts a uniform random distance of up to this many metres further along the
    /// corridor than the centre of its first cell. An arbitrator activates a primitive, freshly
    /// reset, wherever the robot happens to be, often beside the opening it must take; a turning
    /// primitive that only ever started a whole cell or more before its junction never learns
    /// to turn from there (see `docs/decisions/model/0016-turn-starts-up-to-the-junction.md`). The
    /// turning tasks use one cell, 0.30 m, so starts cover every distance up to the junction's
    /// centre; absent means 0, which leaves the other tasks' draws and content hashes unchanged.
    #[serde(skip_serializing_if = "is_zero")]
    pub start_advance: f32,
}

fn is_zero(value: &f32) -> bool {
    *value == 0.0
}

impl Default for CorridorConfig {
    fn default() -> Self {
        CorridorConfig {
            straight_cells: [3, 8],
            cells_before_turn: [2, 4],
            cells_after_turn: [2, 4],
            junction_share: 0.5,
            side_junction_share: 0.0,
            start_advance: 0.0,
        }
    }
}

/// How a robot is placed at a corridor or maze start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StartConfig {
    /// Uniform sideways offset from the corridor's centre line, metres, up to this much.
    pub lateral_offset: f32,
    /// Uniform heading jitter, degrees, up to this much either way.
    pub heading_jitter_deg: f32,
}

impl Default for StartConfig {
    fn default() -> Self {
        StartConfig {
            lateral_offset: 0.02,
            heading_jitter_deg: 10.0,
        }
    }
}

impl CorridorConfig {
    /// Checks the shapes' ranges and shares; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = self;
        for (name, range, min) in [
            ("corridor.straight_cells", c.straight_cells, 1),
            ("corridor.cells_before_turn", c.cells_before_turn, 1),
            ("corridor.cells_after_turn", c.cells_after_turn, 1),
        ] {
            if range[0] < min || range[0] > range[1] || range[1] > 50 {
                return Err(invalid(
                    name,
                    format!("must be [low, high] with {min} <= low <= high <= 50, got {range:?}"),
                ));
            }
        }
        for (name, share) in [
            ("corridor.junction_share", c.junction_share),
            ("corridor.side_junction_share", c.side_junction_share),
        ] {
            if !(0.0..=1.0).contains(&share) {
                return Err(invalid(name, format!("must be in [0, 1], got {share}")));
            }
        }
        if c.junction_share + c.side_junction_share > 1.0 {
            return Err(invalid(
                "corridor.side_junction_share",
                format!(
                    "plus corridor.junction_share must be at most 1, got {} + {}",
                    c.side_junction_share, c.junction_share
                ),
            ));
        }
        // One cell at most, and never from a one-cell corridor, so the advanced start is still
        // inside the start cell's corridor and never past the junction's centre.
        if !(0.0..=MAZE_CELL_SIZE).contains(&c.start_advance) {
            return Err(invalid(
                "corridor.start_advance",
                format!(
                    "must be in [0, {MAZE_CELL_SIZE}] metres, got {}",
                    c.start_advance
                ),
            ));
        }
        if c.start_advance > 0.0 && (c.straight_cells[0] < 2 || c.cells_before_turn[0] < 2) {
            return Err(invalid(
                "corridor.start_advance",
                format!(
                    "{} needs corridor.straight_cells and corridor.cells_before_turn to start at 2 cells or more, got {:?} and {:?}",
                    c.start_advance, c.straight_cells, c.cells_before_turn
                ),
            ));
        }
        Ok(())
    }
}

impl StartConfig {
    /// Checks the placement's ranges; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !(self.lateral_offset >= 0.0 && self.lateral_offset <= 0.05) {
            return Err(invalid(
                "start.lateral_offset",
                format!("must be in [0, 0.05], got {}", self.lateral_offset),
            ));
        }
        if !(self.heading_jitter_deg >= 0.0 && self.heading_jitter_deg <= 180.0) {
            return Err(invalid(
                "start.heading_jitter_deg",
                format!("must be in [0, 180], got {}", self.heading_jitter_deg),
            ));
        }
        Ok(())
    }
}
