//! The room of the exit-room and rescue tasks: a rectangle whose sides are drawn from
//! 1.0-1.2 m, two or three rectangular obstacles (sides 0.05-0.20 m) depending on its size, one
//! narrow exit at a random place in a wall, and a start pose near the centre. The room is laid
//! out with its exit in the top wall and then placed by a rigid transform, so the stand-alone
//! room (exit in any wall) and the rescue room (exit under the maze's stem) share one generator.

use crate::body::Pose;
use crate::config::{ObstaclePlacement, RoomConfig};
use crate::geometry::scene::{Rect, RectKind};
use crate::math::float::hypot;
use crate::math::rng::SimRng;
use rand::RngExt;
use std::f32::consts::{FRAC_PI_2, PI};

/// A generated room, in world coordinates.
#[derive(Debug, Clone)]
pub struct Room {
    /// Walls (with the exit gap) and obstacles.
    pub rects: Vec<Rect>,
    /// Centre of the interior.
    pub center: [f32; 2],
    /// Centre of the exit gap on the wall's inner face.
    pub exit_center: [f32; 2],
    /// Unit vector pointing out of the room through the exit.
    pub exit_outward: [f32; 2],
    /// Where the robot starts.
    pub start: Pose,
    /// Interior side lengths before placement: width along the exit wall, depth.
    pub size: [f32; 2],
}

/// Where to put the room.
#[derive(Debug, Clone, Copy)]
pub enum Placement {
    /// Stand-alone: centred at the origin, exit in a random wall, with a short corridor stub.
    Standalone,
    /// Rescue: exit centred at `exit_center`, opening in +y, no stub (the maze continues).
    Below {
        /// Where the exit's centre must be (the maze entrance's lower border).
        exit_center: [f32; 2],
    },
}

/// Draws a room from the environment stream, for a robot of `robot_radius` (the authors'
/// placement moves the start until such a robot touches nothing).
pub fn generate(
    config: &RoomConfig,
    placement: Placement,
    robot_radius: f32,
    rng: &mut SimRng,
) -> Room {
    let width = rng.random_range(config.min_side..=config.max_side);
    let depth = rng.random_range(config.min_side..=config.max_side);
    let t = config.wall_thickness;
    let half_exit = 0.5 * config.exit_width;
    // Local frame: interior [0, width] x [0, depth], exit in the top wall.
    let exit_x = rng.random_range(0.1 + half_exit..=width - 0.1 - half_exit);
    let mut local = vec![
        Rect::from_corners(RectKind::Wall, -t, -t, width + t, 0.0),
        Rect::from_corners(RectKind::Wall, -t, 0.0, 0.0, depth),
        Rect::from_corners(RectKind::Wall, width, 0.0, width + t, depth),
        Rect::from_corners(RectKind::Wall, -t, depth, exit_x - half_exit, depth + t),
        Rect::from_corners(
            RectKind::Wall,
            exit_x + half_exit,
            depth,
            width + t,
            depth + t,
        ),
    ];
    if matches!(placement, Placement::Standalone) && config.exit_corridor_length > 0.0 {
        let top = depth + t + config.exit_corridor_length;
        local.push(Rect::from_corners(
            RectKind::Wall,
            exit_x - half_exit - t,
            depth,
            exit_x - half_exit,
            top,
        ));
        local.push(Rect::from_corners(
            RectKind::Wall,
            exit_x + half_exit,
            depth,
            exit_x + half_exit + t,
            top,
        ));
    }

    let center = [0.5 * width, 0.5 * depth];
    let exit_center = [exit_x, depth];
    let n_obstacles = config.obstacle_count(width, depth);
    let obstacles = match config.obstacle_placement {
        ObstaclePlacement::Spaced | ObstaclePlacement::Uniform => {
            place_with_clearances(config, n_obstacles, [width, depth], exit_center, rng)
        }
        ObstaclePlacement::Jbotevolver => {
            place_as_the_authors(config, n_obstacles, [width, depth], rng)
        }
    };
    local.extend(obstacles);
    let start_local = match config.obstacle_placement {
        ObstaclePlacement::Jbotevolver => {
            start_clear_of_solids(config, &local, [width, depth], robot_radius, rng)
        }
        _ => Pose {
            x: center[0] + rng.random_range(-config.start_offset..=config.start_offset),
            y: center[1] + rng.random_range(-config.start_offset..=config.start_offset),
            heading: rng.random_range(-PI..PI),
        },
    };

    // Placement: a rotation by a multiple of 90 degrees about the local origin, then a shift.
    let (quarter_turns, shift) = match placement {
        Placement::Standalone => {
            let quarter_turns = rng.random_range(0..4u32);
            let rotated_center = rotate(center, quarter_turns);
            (quarter_turns, [-rotated_center[0], -rotated_center[1]])
        }
        Placement::Below {
            exit_center: target,
        } => (0, [target[0] - exit_center[0], target[1] - exit_center[1]]),
    };
    let place = |p: [f32; 2]| {
        let r = rotate(p, quarter_turns);
        [r[0] + shift[0], r[1] + shift[1]]
    };
    let turn = quarter_turns as f32 * FRAC_PI_2;
    let rects = local
        .into_iter()
        .map(|rect| Rect {
            center: place(rect.center),
            angle: rect.angle + turn,
            ..rect
        })
        .collect();
    let start_position = place([start_local.x, start_local.y]);
    Room {
        rects,
        center: place(center),
        exit_center: place(exit_center),
        exit_outward: rotate([0.0, 1.0], quarter_turns),
        start: Pose {
            x: start_position[0],
            y: start_position[1],
            heading: start_local.heading + turn,
        },
        size: [width, depth],
    }
}

/// One obstacle's sides: two drawn for a rectangle at any angle, one for a square aligned with
/// the walls.
fn draw_obstacle(config: &RoomConfig, rng: &mut SimRng) -> Rect {
    let side_range = config.obstacle_min_side..=config.obstacle_max_side;
    let (half_extents, angle) = if config.square_obstacles {
        let half = 0.5 * rng.random_range(side_range);
        ([half, half], 0.0)
    } else {
        let half_extents = [
            0.5 * rng.random_range(side_range.clone()),
            0.5 * rng.random_range(side_range),
        ];
        (half_extents, rng.random_range(0.0..PI))
    };
    Rect {
        center: [0.0, 0.0],
        half_extents,
        angle,
        kind: RectKind::Obstacle,
    }
}

/// hevo's placements, in the room's local frame (interior `[0, size[0]] x [0, size[1]]`, exit
/// in the top wall): rejection sampling with a fixed attempt budget, deterministic for a seed;
/// an obstacle that finds no legal place is left out (never seen with the defaults). Spaced
/// obstacles keep `obstacle_clearance` (between circumscribed circles) from the walls and
/// each other; uniform ones only keep their centres that far in from the walls, and may
/// overlap.
fn place_with_clearances(
    config: &RoomConfig,
    n_obstacles: usize,
    [width, depth]: [f32; 2],
    exit_center: [f32; 2],
    rng: &mut SimRng,
) -> Vec<Rect> {
    let spaced = config.obstacle_placement == ObstaclePlacement::Spaced;
    let center = [0.5 * width, 0.5 * depth];
    let mut obstacles: Vec<Rect> = Vec::new();
    for _ in 0..n_obstacles {
        for _attempt in 0..1000 {
            let candidate = draw_obstacle(config, rng);
            let reach = if spaced {
                candidate.circumradius() + config.obstacle_clearance
            } else {
                config.obstacle_clearance
            };
            if 2.0 * reach >= width || 2.0 * reach >= depth {
                continue;
            }
            let c = [
                rng.random_range(reach..width - reach),
                rng.random_range(reach..depth - reach),
            ];
            let dist = |p: [f32; 2]| hypot(c[0] - p[0], c[1] - p[1]);
            let clear_of_start = dist(center) > config.start_clearance + candidate.circumradius();
            let clear_of_exit =
                dist(exit_center) > config.exit_clearance + candidate.circumradius();
            let clear_of_others = !spaced
                || obstacles
                    .iter()
                    .all(|o| dist(o.center) > o.circumradius() + reach);
            if clear_of_start && clear_of_exit && clear_of_others {
                obstacles.push(Rect {
                    center: c,
                    ..candidate
                });
                break;
            }
        }
    }
    obstacles
}

/// The authors' placement (JBotEvolver's `ClutteredMazeEnvironment`), in the local frame:
/// each obstacle's centre uniform across the width, `obstacle_clearance` in from the side
/// walls, and `0.6 x (depth / 2 - side - u x depth / 2)` above the room's centre (u uniform in
/// [0, 1); a larger obstacle stands lower), wherever that puts it: on another obstacle, into a
/// side wall, over the centre. Every obstacle is placed; none is refused.
fn place_as_the_authors(
    config: &RoomConfig,
    n_obstacles: usize,
    [width, depth]: [f32; 2],
    rng: &mut SimRng,
) -> Vec<Rect> {
    let margin = config.obstacle_clearance.min(0.5 * width);
    (0..n_obstacles)
        .map(|_| {
            let candidate = draw_obstacle(config, rng);
            // The side along the depth, for a rectangle as for a square.
            let side = 2.0 * candidate.half_extents[1];
            let x = rng.random_range(margin..=width - margin);
            let u = rng.random_range(0.0..1.0f32);
            let y = 0.5 * depth + 0.6 * (0.5 * depth - side - u * 0.5 * depth);
            Rect {
                center: [x, y],
                ..candidate
            }
        })
        .collect()
}

/// The most starts the authors' placement tries before it gives up.
const START_ATTEMPTS: u32 = 100;

/// How much clear of every solid a searched start must be, metres: a margin over the robot's
/// radius so that the scene's own test, in the placed room's coordinates, agrees.
const START_MARGIN: f32 = 1e-4;

/// The authors' start: the centre plus a uniform offset of up to `start_offset` per axis,
/// drawn again until the robot's disc, inside the interior, touches none of `solids`; after
/// every ten tries the offset grows by 0.1 m, as in the authors' code. After
/// [`START_ATTEMPTS`] the centre, touching or not (the start check of every evaluator then
/// refuses the world, naming the seed).
fn start_clear_of_solids(
    config: &RoomConfig,
    solids: &[Rect],
    [width, depth]: [f32; 2],
    robot_radius: f32,
    rng: &mut SimRng,
) -> Pose {
    let center = [0.5 * width, 0.5 * depth];
    let heading = rng.random_range(-PI..PI);
    let clear = |p: [f32; 2]| {
        let inside = p[0] >= robot_radius
            && p[0] <= width - robot_radius
            && p[1] >= robot_radius
            && p[1] <= depth - robot_radius;
        inside
            && solids
                .iter()
                .all(|solid| distance_to_rect(solid, p) >= robot_radius + START_MARGIN)
    };
    let mut offset = config.start_offset;
    for attempt in 1..=START_ATTEMPTS {
        let p = if offset > 0.0 {
            [
                center[0] + rng.random_range(-offset..=offset),
                center[1] + rng.random_range(-offset..=offset),
            ]
        } else {
            center
        };
        if clear(p) {
            return Pose {
                x: p[0],
                y: p[1],
                heading,
            };
        }
        if attempt % 10 == 0 {
            offset += 0.1;
        }
    }
    Pose {
        x: center[0],
        y: center[1],
        heading,
    }
}

/// The distance from `p` to the nearest point of `rect` (0 inside it).
fn distance_to_rect(rect: &Rect, p: [f32; 2]) -> f32 {
    let (s, c) = rect.angle.sin_cos();
    let d = [p[0] - rect.center[0], p[1] - rect.center[1]];
    let local = [c * d[0] + s * d[1], -s * d[0] + c * d[1]];
    let outside = [
        (local[0].abs() - rect.half_extents[0]).max(0.0),
        (local[1].abs() - rect.half_extents[1]).max(0.0),
    ];
    hypot(outside[0], outside[1])
}

/// Rotates a point about the origin by `quarter_turns` times 90 degrees, exactly.
fn rotate(p: [f32; 2], quarter_turns: u32) -> [f32; 2] {
    match quarter_turns % 4 {
        0 => p,
        1 => [-p[1], p[0]],
        2 => [-p[0], -p[1]],
        _ => [p[1], -p[0]],
    }
}

impl Room {
    /// How far a point lies beyond the exit wall's inner face, measured outward (negative
    /// inside the room).
    pub fn depth_beyond_exit(&self, point: [f32; 2]) -> f32 {
        (point[0] - self.exit_center[0]) * self.exit_outward[0]
            + (point[1] - self.exit_center[1]) * self.exit_outward[1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::scene::Scene;
    use crate::math::rng::{Stream, stream_rng};

    const EPUCK_RADIUS: f32 = 0.0375;

    #[test]
    fn rooms_respect_the_spec_ranges() {
        let config = RoomConfig::default();
        for seed in 0..300 {
            let mut rng = stream_rng(seed, Stream::Environment);
            let room = generate(&config, Placement::Standalone, EPUCK_RADIUS, &mut rng);
            assert!(room.size.iter().all(|&s| (1.0..=1.2).contains(&s)));
            let obstacles: Vec<&Rect> = room
                .rects
                .iter()
                .filter(|r| r.kind == RectKind::Obstacle)
                .collect();
            let expected = if room.size[0] * room.size[1] > 1.21 {
                3
            } else {
                2
            };
            assert_eq!(obstacles.len(), expected, "seed {seed}");
            for o in &obstacles {
                assert!(o.half_extents.iter().all(|&h| (0.025..=0.1).contains(&h)));
            }
            // The start pose is free, and the exit is on the room's boundary.
            let scene = Scene::new(room.rects.clone(), 0.25);
            assert!(
                !scene.disc_hits(room.start.position(), 0.0375),
                "seed {seed}"
            );
            assert_exit_in_the_wall_face(&config, &room, &format!("seed {seed}"));
        }
    }

    /// Whether a point lies inside a (possibly rotated) rectangle, in its own frame.
    fn inside(rect: &Rect, p: [f32; 2]) -> bool {
        let (s, c) = rect.angle.sin_cos();
        let d = [p[0] - rect.center[0], p[1] - rect.center[1]];
        let local = [c * d[0] + s * d[1], -s * d[0] + c * d[1]];
        local[0].abs() <= rect.half_extents[0] && local[1].abs() <= rect.half_extents[1]
    }

    /// The exit's centre lies exactly on the exit wall's inner face, half the room's depth out
    /// from its centre, and the gap is the exit's width: the two walls either side of it have
    /// their inner face on the same line and end exactly half an exit width either side.
    fn assert_exit_in_the_wall_face(config: &RoomConfig, room: &Room, context: &str) {
        const TIGHT: f32 = 1e-5;
        let out = room.exit_outward;
        assert!(
            out == [0.0, 1.0] || out == [0.0, -1.0] || out == [1.0, 0.0] || out == [-1.0, 0.0],
            "{context}: outward {out:?}"
        );
        let along = [-out[1], out[0]];
        let dot = |p: [f32; 2], v: [f32; 2]| p[0] * v[0] + p[1] * v[1];
        let face = dot(room.exit_center, out);
        // Half the interior's depth (size[1], across the exit wall) out from the centre.
        assert!(
            (face - dot(room.center, out) - 0.5 * room.size[1]).abs() < TIGHT,
            "{context}: the exit is {} out from the centre of a room {} deep",
            face - dot(room.center, out),
            room.size[1]
        );
        // The exit at least 0.1 m of wall from either end of its wall.
        let lateral = dot(room.exit_center, along) - dot(room.center, along);
        assert!(
            lateral.abs() <= 0.5 * room.size[0] - 0.1 - 0.5 * config.exit_width + TIGHT,
            "{context}: exit {lateral} m along a wall {} m long",
            room.size[0]
        );
        // The gap's two ends are corners of walls whose inner face is the exit's line.
        let half = 0.5 * config.exit_width;
        for sign in [-1.0f32, 1.0] {
            let end = [
                room.exit_center[0] + sign * half * along[0],
                room.exit_center[1] + sign * half * along[1],
            ];
            let flanking: Vec<&Rect> = room
                .rects
                .iter()
                .filter(|r| r.kind == RectKind::Wall)
                .filter(|r| {
                    r.corners()
                        .iter()
                        .any(|c| (c[0] - end[0]).abs() < TIGHT && (c[1] - end[1]).abs() < TIGHT)
                })
                .collect();
            assert!(!flanking.is_empty(), "{context}: no wall ends at {end:?}");
            let exit_wall = flanking.iter().any(|r| {
                let nearest = r
                    .corners()
                    .iter()
                    .map(|&c| dot(c, out))
                    .fold(f32::INFINITY, f32::min);
                (nearest - face).abs() < TIGHT
            });
            assert!(exit_wall, "{context}: no wall's inner face through {end:?}");
            // Just beyond the gap's end the face is solid; inside the gap it is open.
            let on_face = |distance: f32, depth: f32| {
                [
                    room.exit_center[0] + distance * along[0] + depth * out[0],
                    room.exit_center[1] + distance * along[1] + depth * out[1],
                ]
            };
            let solid = |p: [f32; 2]| room.rects.iter().any(|r| inside(r, p));
            assert!(solid(on_face(sign * (half + 0.001), 0.001)), "{context}");
            assert!(!solid(on_face(sign * (half - 0.001), 0.001)), "{context}");
            assert!(!solid(on_face(sign * (half + 0.001), -0.001)), "{context}");
        }
    }

    /// The authors' room as `scenarios/examples/exit_room_authors.toml` writes it.
    fn authors_room() -> RoomConfig {
        RoomConfig {
            obstacles_per_m2: Some(3.0),
            square_obstacles: true,
            obstacle_min_side: 0.125,
            obstacle_max_side: 0.375,
            obstacle_placement: ObstaclePlacement::Jbotevolver,
            obstacle_clearance: 0.1,
            start_offset: 0.0,
            ..RoomConfig::default()
        }
    }

    /// Each obstacle of a room, in its local frame (exit wall up, interior from the origin).
    fn local_obstacles(room: &Room) -> Vec<Rect> {
        let turns = (0..4u32)
            .find(|&t| rotate([0.0, 1.0], t) == room.exit_outward)
            .unwrap();
        let shift = [
            0.5 * room.size[0] - rotate(room.center, 4 - turns)[0],
            0.5 * room.size[1] - rotate(room.center, 4 - turns)[1],
        ];
        room.rects
            .iter()
            .filter(|r| r.kind == RectKind::Obstacle)
            .map(|r| {
                let c = rotate(r.center, 4 - turns);
                Rect {
                    center: [c[0] + shift[0], c[1] + shift[1]],
                    ..*r
                }
            })
            .collect()
    }

    #[test]
    fn the_authors_room_has_int_3_area_squares_in_their_band_and_a_clear_start() {
        let config = authors_room();
        let mut counts = [0usize; 5];
        let mut any_overlap = false;
        for seed in 0..500 {
            let mut rng = stream_rng(seed, Stream::Environment);
            let room = generate(&config, Placement::Standalone, EPUCK_RADIUS, &mut rng);
            let [width, depth] = room.size;
            let obstacles = local_obstacles(&room);
            assert_eq!(
                obstacles.len(),
                (3.0 * width * depth) as usize,
                "seed {seed}"
            );
            counts[obstacles.len()] += 1;
            for o in &obstacles {
                let [hx, hy] = o.half_extents;
                assert_eq!(hx, hy, "seed {seed}: a square");
                assert!(
                    (0.0625..=0.1875).contains(&hx),
                    "seed {seed}: side {}",
                    2.0 * hx
                );
                // Aligned with the walls: a whole number of quarter turns.
                let quarters = o.angle / FRAC_PI_2;
                assert!((quarters - quarters.round()).abs() < 1e-5, "seed {seed}");
                let [x, y] = o.center;
                assert!(
                    x >= 0.1 - 1e-4 && x <= width - 0.1 + 1e-4,
                    "seed {seed}: x {x}"
                );
                let above_centre = y - 0.5 * depth;
                let side = 2.0 * hx;
                assert!(
                    above_centre >= 0.6 * -side - 1e-4
                        && above_centre <= 0.6 * (0.5 * depth - side) + 1e-4,
                    "seed {seed}: {above_centre} above the centre, side {side}"
                );
            }
            any_overlap |= obstacles.iter().enumerate().any(|(i, a)| {
                obstacles[i + 1..].iter().any(|b| {
                    (a.center[0] - b.center[0]).abs() < a.half_extents[0] + b.half_extents[0]
                        && (a.center[1] - b.center[1]).abs() < a.half_extents[1] + b.half_extents[1]
                })
            });
            let scene = Scene::new(room.rects.clone(), 0.25);
            assert!(
                !scene.disc_hits(room.start.position(), EPUCK_RADIUS),
                "seed {seed}: the start touches a solid"
            );
            assert_exit_in_the_wall_face(&config, &room, &format!("seed {seed}"));
        }
        // Areas 1.0-1.44 m²: three obstacles, four above 4/3 m² (both sides near 1.2 m,
        // about one room in sixteen); and some overlap.
        assert_eq!(counts[0] + counts[1] + counts[2], 0, "{counts:?}");
        assert!(counts[3] > 400 && counts[4] > 10, "{counts:?}");
        assert!(any_overlap, "overlap is allowed and happens");
    }

    #[test]
    fn uniform_obstacles_may_overlap_but_keep_off_the_start() {
        let config = RoomConfig {
            obstacles_per_m2: Some(8.0),
            obstacle_placement: ObstaclePlacement::Uniform,
            ..RoomConfig::default()
        };
        let mut any_overlap = false;
        for seed in 0..200 {
            let mut rng = stream_rng(seed, Stream::Environment);
            let room = generate(&config, Placement::Standalone, EPUCK_RADIUS, &mut rng);
            let obstacles = local_obstacles(&room);
            assert!(obstacles.len() <= (8.0 * room.size[0] * room.size[1]) as usize);
            any_overlap |= obstacles.iter().enumerate().any(|(i, a)| {
                obstacles[i + 1..].iter().any(|b| {
                    hypot(a.center[0] - b.center[0], a.center[1] - b.center[1])
                        < a.circumradius() + b.circumradius() + config.obstacle_clearance
                })
            });
            let scene = Scene::new(room.rects.clone(), 0.25);
            assert!(
                !scene.disc_hits(room.start.position(), EPUCK_RADIUS),
                "seed {seed}"
            );
        }
        assert!(any_overlap, "closer than spaced obstacles may be");
    }

    #[test]
    fn spaced_rooms_with_a_count_per_area_keep_their_gaps() {
        let config = RoomConfig {
            obstacles_per_m2: Some(4.0),
            square_obstacles: true,
            ..RoomConfig::default()
        };
        for seed in 0..200 {
            let mut rng = stream_rng(seed, Stream::Environment);
            let room = generate(&config, Placement::Standalone, EPUCK_RADIUS, &mut rng);
            let obstacles = local_obstacles(&room);
            assert!(obstacles.len() <= (4.0 * room.size[0] * room.size[1]) as usize);
            for (i, a) in obstacles.iter().enumerate() {
                assert_eq!(a.half_extents[0], a.half_extents[1]);
                for b in &obstacles[i + 1..] {
                    let gap = hypot(a.center[0] - b.center[0], a.center[1] - b.center[1])
                        - a.circumradius()
                        - b.circumradius();
                    assert!(gap > config.obstacle_clearance, "seed {seed}: gap {gap}");
                }
            }
        }
    }

    #[test]
    fn rescue_room_puts_its_exit_where_asked() {
        let mut rng = stream_rng(3, Stream::Environment);
        let room = generate(
            &RoomConfig::default(),
            Placement::Below {
                exit_center: [0.0, -1.7],
            },
            EPUCK_RADIUS,
            &mut rng,
        );
        assert!(room.exit_center[0].abs() < 1e-5 && (room.exit_center[1] + 1.7).abs() < 1e-5);
        assert_eq!(room.exit_outward, [0.0, 1.0]);
        assert!(room.center[1] < -2.0);
        assert_exit_in_the_wall_face(&RoomConfig::default(), &room, "rescue room");
    }
}
