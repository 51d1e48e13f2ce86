//! The room generator's numbers; the generator is [`crate::world::room`].

use super::{ConfigError, invalid};
use serde::{Deserialize, Serialize};

/// Every number of the room generator. Defaults follow SPEC section 4; the clearances are
/// hevo's choices (the paper is silent) and keep every room solvable.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RoomConfig {
    /// Smallest side of the room's interior, metres.
    pub min_side: f32,
    /// Largest side, metres.
    pub max_side: f32,
    /// Rooms with an interior area above this get three obstacles, others two (m^2; 1.21 is a
    /// 1.1 m square, the middle of the size range).
    pub three_obstacles_above_area: f32,
    /// Smallest obstacle side, metres.
    pub obstacle_min_side: f32,
    /// Largest obstacle side, metres.
    pub obstacle_max_side: f32,
    /// Clear width of the exit, metres (the maze corridor width).
    pub exit_width: f32,
    /// Wall thickness, metres (the maze's, so the rescue room's wall is the maze's border).
    pub wall_thickness: f32,
    /// The start position is the centre plus a uniform offset of up to this much per axis.
    pub start_offset: f32,
    /// Minimum free gap between an obstacle and a wall or another obstacle, metres.
    pub obstacle_clearance: f32,
    /// No obstacle comes closer than this to the room centre (the start area), metres.
    pub start_clearance: f32,
    /// No obstacle comes closer than this to the exit's centre, metres.
    pub exit_clearance: f32,
    /// Length of the corridor stub outside the exit of the stand-alone room, metres.
    pub exit_corridor_length: f32,
    /// Obstacles per square metre of interior: a room gets int(this x its area) obstacles,
    /// as the authors' room does with 3. Unset (the default): two or three, by
    /// `three_obstacles_above_area`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub obstacles_per_m2: Option<f32>,
    /// Square obstacles aligned with the walls, their side drawn from
    /// `obstacle_min_side..=obstacle_max_side`, in place of rectangles (two sides drawn) at
    /// any angle.
    #[serde(skip_serializing_if = "is_false")]
    pub square_obstacles: bool,
    /// Where obstacles may stand.
    #[serde(skip_serializing_if = "ObstaclePlacement::is_spaced")]
    pub obstacle_placement: ObstaclePlacement,
}

/// Where a room's obstacles may stand. Absent from a serialised task at its default, so task
/// hashes and run fingerprints made before the other placements existed stay valid.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstaclePlacement {
    /// hevo's room: rejection sampling keeping `obstacle_clearance` from the walls and each
    /// other, `start_clearance` from the centre and `exit_clearance` from the exit; never
    /// overlapping.
    #[default]
    Spaced,
    /// Centres uniform over the interior, `obstacle_clearance` in from every wall, still
    /// `start_clearance` from the centre and `exit_clearance` from the exit: obstacles may
    /// overlap each other and touch or cross into a wall.
    Uniform,
    /// JBotEvolver's `ClutteredMazeEnvironment`: centres uniform across the width,
    /// `obstacle_clearance` in from the side walls, and at 0.6 x (depth / 2 - side - u x depth
    /// / 2) from the centre towards the exit wall (u uniform in [0, 1)), overlapping and
    /// touching as they fall; no start or exit clearance. The start is moved instead until the
    /// robot touches nothing ([`crate::world::room`]).
    Jbotevolver,
}

impl ObstaclePlacement {
    fn is_spaced(&self) -> bool {
        *self == ObstaclePlacement::Spaced
    }
}

fn is_false(value: &bool) -> bool {
    !value
}

/// The most obstacles a room may get: `obstacles_per_m2` times the largest area is checked
/// against it before any room is drawn.
pub const MAX_ROOM_OBSTACLES: f32 = 64.0;

impl Default for RoomConfig {
    fn default() -> Self {
        RoomConfig {
            min_side: 1.0,
            max_side: 1.2,
            three_obstacles_above_area: 1.21,
            obstacle_min_side: 0.05,
            obstacle_max_side: 0.20,
            exit_width: 0.20,
            wall_thickness: 0.10,
            start_offset: 0.10,
            obstacle_clearance: 0.10,
            start_clearance: 0.25,
            exit_clearance: 0.30,
            exit_corridor_length: 0.30,
            obstacles_per_m2: None,
            square_obstacles: false,
            obstacle_placement: ObstaclePlacement::Spaced,
        }
    }
}

impl RoomConfig {
    /// Checks ranges; names the offending key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        // Every length finite and room-sized: a scene's lookup table covers the room in 0.1 m
        // cells, so an unbounded side would be an unbounded allocation.
        for (key, metres) in [
            ("room.min_side", self.min_side),
            ("room.max_side", self.max_side),
            ("room.obstacle_min_side", self.obstacle_min_side),
            ("room.obstacle_max_side", self.obstacle_max_side),
            ("room.exit_width", self.exit_width),
            ("room.wall_thickness", self.wall_thickness),
            ("room.start_offset", self.start_offset),
            ("room.obstacle_clearance", self.obstacle_clearance),
            ("room.start_clearance", self.start_clearance),
            ("room.exit_clearance", self.exit_clearance),
            ("room.exit_corridor_length", self.exit_corridor_length),
            (
                "room.three_obstacles_above_area",
                self.three_obstacles_above_area.sqrt(),
            ),
        ] {
            if !(metres.is_finite() && metres <= MAX_ROOM_METRES) {
                return Err(invalid(
                    key,
                    format!(
                        "must be a finite number of at most {MAX_ROOM_METRES} m (m² for an area)"
                    ),
                ));
            }
        }
        let checks = [
            (
                self.min_side > 0.3 && self.min_side <= self.max_side,
                "room.min_side",
                "must be > 0.3 and <= room.max_side",
            ),
            (
                self.obstacle_min_side > 0.0 && self.obstacle_min_side <= self.obstacle_max_side,
                "room.obstacle_min_side",
                "must be > 0 and <= room.obstacle_max_side",
            ),
            (
                self.exit_width > 0.0 && self.exit_width < self.min_side - 0.2,
                "room.exit_width",
                "must be > 0 and leave 0.1 m of wall either side",
            ),
            (
                self.wall_thickness > 0.0,
                "room.wall_thickness",
                "must be > 0",
            ),
            (
                self.start_offset >= 0.0,
                "room.start_offset",
                "must be >= 0",
            ),
            (
                self.obstacle_clearance >= 0.0,
                "room.obstacle_clearance",
                "must be >= 0",
            ),
            (
                self.start_clearance >= 0.0,
                "room.start_clearance",
                "must be >= 0",
            ),
            (
                self.exit_clearance >= 0.0,
                "room.exit_clearance",
                "must be >= 0",
            ),
            (
                self.exit_corridor_length >= 0.0,
                "room.exit_corridor_length",
                "must be >= 0",
            ),
        ];
        if let Some((_, key, message)) = checks.iter().find(|(ok, _, _)| !ok) {
            return Err(invalid(key, (*message).to_string()));
        }
        self.validate_obstacle_count()
    }

    /// The obstacle count per area: finite, not negative, and at most
    /// [`MAX_ROOM_OBSTACLES`] in the largest room, so the cost of drawing a room is bounded
    /// before any is drawn.
    fn validate_obstacle_count(&self) -> Result<(), ConfigError> {
        let Some(per_m2) = self.obstacles_per_m2 else {
            return Ok(());
        };
        let most = per_m2 * self.max_side * self.max_side;
        if per_m2.is_finite() && per_m2 >= 0.0 && most <= MAX_ROOM_OBSTACLES {
            return Ok(());
        }
        Err(invalid(
            "room.obstacles_per_m2",
            format!(
                "must be a finite number >= 0 giving at most {MAX_ROOM_OBSTACLES} obstacles in \
                 the largest room (room.max_side {} m), got {per_m2}",
                self.max_side
            ),
        ))
    }

    /// How many obstacles a room of interior `width` x `depth` gets.
    pub fn obstacle_count(&self, width: f32, depth: f32) -> usize {
        match self.obstacles_per_m2 {
            // As the authors' `(int)(objects * (width * height))`: truncated.
            Some(per_m2) => (per_m2 * (width * depth)) as usize,
            None if width * depth > self.three_obstacles_above_area => 3,
            None => 2,
        }
    }

    /// The smallest `start_clearance` that keeps every obstacle off every start: a start lies
    /// up to `start_offset` from the centre on each axis (so up to `start_offset * sqrt 2`
    /// away), and the robot's body reaches `robot_radius` beyond it. With the defaults (0.10 m,
    /// an e-puck's 0.0375 m) that is 0.179 m.
    pub fn min_start_clearance(&self, robot_radius: f32) -> f32 {
        self.start_offset * std::f32::consts::SQRT_2 + robot_radius
    }

    /// Refuses a start clearance that lets an obstacle cover a start: such a robot would
    /// begin inside a solid, and the sample could never be solved.
    /// The authors' placement keeps no start clearance: it moves the start instead.
    pub fn validate_start_clearance(&self, robot_radius: f32) -> Result<(), ConfigError> {
        if self.obstacle_placement == ObstaclePlacement::Jbotevolver {
            return Ok(());
        }
        let needed = self.min_start_clearance(robot_radius);
        if self.start_clearance >= needed {
            return Ok(());
        }
        Err(invalid(
            "room.start_clearance",
            format!(
                "{} m leaves the start no clearance: the robot starts up to {:.3} m from the \
                 room's centre (room.start_offset {} m on each axis) and its body reaches {} m \
                 beyond, so an obstacle could cover the start; use at least {:.3} m, or a \
                 smaller room.start_offset",
                self.start_clearance,
                self.start_offset * std::f32::consts::SQRT_2,
                self.start_offset,
                robot_radius,
                (needed * 1000.0).ceil() / 1000.0,
            ),
        ))
    }
}

/// The longest length a room's numbers may give, metres.
pub const MAX_ROOM_METRES: f32 = 20.0;

#[cfg(test)]
mod tests {
    use super::*;

    const EPUCK_RADIUS: f32 = 0.0375;

    #[test]
    fn the_default_room_leaves_the_start_clear() {
        let room = RoomConfig::default();
        assert!(room.validate_start_clearance(EPUCK_RADIUS).is_ok());
        // The figure the docs quote.
        let needed = room.min_start_clearance(EPUCK_RADIUS);
        assert!((needed - 0.1789).abs() < 1e-3, "{needed}");
    }

    #[test]
    fn a_start_clearance_an_obstacle_could_cover_is_refused_with_the_minimum() {
        let room = RoomConfig {
            start_clearance: 0.1,
            ..RoomConfig::default()
        };
        let message = room
            .validate_start_clearance(EPUCK_RADIUS)
            .unwrap_err()
            .to_string();
        assert!(message.contains("room.start_clearance"), "{message}");
        assert!(message.contains("no clearance"), "{message}");
        assert!(message.contains("at least 0.179 m"), "{message}");
        // A smaller offset needs less: the check follows the start area, not a constant.
        let near_centre = RoomConfig {
            start_clearance: 0.1,
            start_offset: 0.02,
            ..RoomConfig::default()
        };
        assert!(near_centre.validate_start_clearance(EPUCK_RADIUS).is_ok());
    }

    #[test]
    fn the_new_keys_are_absent_from_a_default_room_serialised() {
        let json = serde_json::to_string(&RoomConfig::default()).unwrap();
        for key in ["obstacles_per_m2", "square_obstacles", "obstacle_placement"] {
            assert!(!json.contains(key), "{json}");
        }
        let authors = RoomConfig {
            obstacles_per_m2: Some(3.0),
            square_obstacles: true,
            obstacle_placement: ObstaclePlacement::Jbotevolver,
            ..RoomConfig::default()
        };
        let json = serde_json::to_string(&authors).unwrap();
        assert!(
            json.contains(r#""obstacle_placement":"jbotevolver""#),
            "{json}"
        );
        let back: RoomConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, authors);
    }

    #[test]
    fn obstacle_counts_follow_the_area_and_are_bounded_before_any_room_is_drawn() {
        let per_area = RoomConfig {
            obstacles_per_m2: Some(3.0),
            ..RoomConfig::default()
        };
        assert!(per_area.validate().is_ok());
        // int(3 x area), truncated as the authors' code does.
        assert_eq!(per_area.obstacle_count(1.0, 1.0), 3);
        assert_eq!(per_area.obstacle_count(1.1, 1.2), 3);
        assert_eq!(per_area.obstacle_count(1.2, 1.2), 4);
        // Without a count per area: the paper's two or three.
        assert_eq!(RoomConfig::default().obstacle_count(1.0, 1.0), 2);
        assert_eq!(RoomConfig::default().obstacle_count(1.2, 1.2), 3);
        for bad in [f32::NAN, f32::INFINITY, -1.0, 45.0] {
            let config = RoomConfig {
                obstacles_per_m2: Some(bad),
                ..RoomConfig::default()
            };
            let message = config.validate().unwrap_err().to_string();
            assert!(
                message.starts_with("room.obstacles_per_m2 "),
                "{bad}: {message}"
            );
            assert!(message.contains("at most 64 obstacles"), "{message}");
        }
        // The bound follows the largest room: 10 per m² is fine in 1.2 m rooms, not in 3 m ones.
        let big = RoomConfig {
            obstacles_per_m2: Some(10.0),
            max_side: 3.0,
            ..RoomConfig::default()
        };
        assert!(big.validate().is_err());
    }

    #[test]
    fn the_authors_placement_needs_no_start_clearance() {
        let config = RoomConfig {
            obstacle_placement: ObstaclePlacement::Jbotevolver,
            start_clearance: 0.0,
            ..RoomConfig::default()
        };
        assert!(config.validate_start_clearance(EPUCK_RADIUS).is_ok());
        let uniform = RoomConfig {
            obstacle_placement: ObstaclePlacement::Uniform,
            ..config
        };
        assert!(uniform.validate_start_clearance(EPUCK_RADIUS).is_err());
    }
}
