//! Environments: everything a sample's world holds that does not move by itself. For each task
//! this builds, from the sample's environment stream, the scene, the start pose, the teammate,
//! the lights and the ground truth the task judges against (goal cells, the room's exit).
//! Layouts that never change (the maze) are built once per evaluator and shared.

pub mod cells;
pub mod corridor;
pub mod maze;
pub mod room;

use crate::rng::SimRng;
use crate::robot::Pose;
use crate::scene::{Rect, Scene};
use crate::task::{TaskConfig, TaskKind};
use cells::{CellMap, Side};
use corridor::{Junction, Turn};
use maze::MazeLayout;
use rand::RngExt;
use room::{Placement, Room};
use std::f32::consts::{FRAC_PI_2, PI};
use std::sync::Arc;

/// A light of the maze stem as one sample sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSpec {
    /// Position, metres.
    pub position: [f32; 2],
    /// Whether this light flashes in the sample's light configuration.
    pub flashes: bool,
}

/// What a sample's task judges progress against.
#[derive(Debug, Clone)]
pub enum Ground {
    /// Exit the room.
    Room(Room),
    /// Reach the last cell of a path of corridor cells without leaving the path.
    Cells(CellGoal),
    /// Rescue: leave the room, find the teammate in the maze, bring it back.
    Rescue {
        /// The room (its exit opens onto the maze entrance).
        room: Room,
        /// The maze and the teammate's branch.
        maze: CellGoal,
    },
}

/// A goal in a cell world: the path, the goal cell and the corridor-distance table.
#[derive(Debug, Clone)]
pub struct CellGoal {
    /// The cells.
    pub map: Arc<CellMap>,
    /// Whether each cell lies on the correct path.
    pub on_path: Vec<bool>,
    /// The goal cell (last on the path).
    pub goal: usize,
    /// Corridor distance from each cell centre to the goal's centre.
    pub distances: Vec<f32>,
    /// Corridor distance from the path's start (its first cell's centre) to the goal.
    pub total_distance: f32,
    /// The dead ends off the path: the other branches' end cells.
    pub wrong_ends: Vec<usize>,
}

impl CellGoal {
    fn new(map: Arc<CellMap>, path: &[usize]) -> CellGoal {
        let goal = *path.last().expect("paths have at least two cells");
        let distances = map.distances_to(goal);
        let mut on_path = vec![false; map.cells.len()];
        for &cell_idx in path {
            on_path[cell_idx] = true;
        }
        let total_distance = distances[path[0]];
        let wrong_ends = (0..map.cells.len())
            .filter(|&cell_idx| !on_path[cell_idx] && map.neighbours(cell_idx).count() == 1)
            .collect();
        CellGoal {
            map,
            on_path,
            goal,
            distances,
            total_distance,
            wrong_ends,
        }
    }

    /// Whether a robot of this radius at `point` has reached another branch's end, as the
    /// authors' code judges it: its bounding box meets the central half of a dead-end cell
    /// off the path.
    pub fn reached_wrong_end(&self, point: [f32; 2], radius: f32) -> bool {
        let reach = 0.25 * self.map.cell_size + radius;
        self.wrong_ends.iter().any(|&cell_idx| {
            let center = self.map.center(cell_idx);
            (point[0] - center[0]).abs() < reach && (point[1] - center[1]).abs() < reach
        })
    }

    /// Corridor distance from a point to the goal (None outside the cells).
    pub fn distance_from(&self, point: [f32; 2]) -> Option<f32> {
        self.map.distance_from(point, &self.distances)
    }
}

/// One sample's environment.
#[derive(Debug, Clone)]
pub struct Environment {
    /// Walls and obstacles.
    pub scene: Arc<Scene>,
    /// The robot's start pose.
    pub start: Pose,
    /// The teammate's start pose, and whether it already follows.
    pub teammate: Option<(Pose, bool)>,
    /// Lights of the stem, for maze tasks.
    pub lights: Vec<LightSpec>,
    /// The ground truth.
    pub ground: Ground,
    /// Light configuration (maze tasks), branch (return to room) or corridor shape index.
    pub variant: u32,
}

/// Geometry shared by all samples of an evaluator: built once.
#[derive(Debug)]
pub struct Statics {
    maze_closed: Option<(Arc<Scene>, Arc<CellMap>)>,
}

impl Statics {
    /// Builds what never changes between samples of this task.
    pub fn new(task: &TaskConfig) -> Statics {
        let maze_closed =
            matches!(task.kind, TaskKind::SolveMaze | TaskKind::ReturnRoom).then(|| {
                let layout = MazeLayout::builtin();
                let scene = Scene::new(layout.map.wall_rects(&[]), task.query_margin());
                (Arc::new(scene), Arc::new(layout.map.clone()))
            });
        Statics { maze_closed }
    }
}

/// Number of variants a task has: light configurations for the maze, start branches for the
/// return, 1 otherwise.
pub fn n_variants(kind: TaskKind) -> u32 {
    match kind {
        TaskKind::SolveMaze | TaskKind::ReturnRoom | TaskKind::Rescue => {
            MazeLayout::builtin().n_configurations()
        }
        _ => 1,
    }
}

/// How many values a sample's reported variant can take: the variants of [`n_variants`], and
/// for the turning tasks the corridor's shape (bend, T end, side junction), which is drawn,
/// never asked for.
pub fn reported_variants(kind: TaskKind) -> u32 {
    match kind {
        TaskKind::TurnLeft | TaskKind::TurnRight => 3,
        _ => n_variants(kind),
    }
}

/// Builds the environment of one sample. `variant` fixes the light configuration (or start
/// branch); `None` draws it from the stream.
pub fn build(
    task: &TaskConfig,
    statics: &Statics,
    variant: Option<u32>,
    rng: &mut SimRng,
) -> Environment {
    let maze = MazeLayout::builtin();
    let pick_variant =
        |rng: &mut SimRng| variant.unwrap_or_else(|| rng.random_range(0..n_variants(task.kind)));
    let margin = task.query_margin();
    match task.kind {
        TaskKind::ExitRoom => {
            let room = room::generate(&task.room, Placement::Standalone, rng);
            Environment {
                scene: Arc::new(Scene::new(room.rects.clone(), margin)),
                start: room.start,
                teammate: None,
                lights: Vec::new(),
                ground: Ground::Room(room),
                variant: 0,
            }
        }
        TaskKind::FollowWall | TaskKind::TurnLeft | TaskKind::TurnRight => {
            let c = &task.corridor;
            let (turn, before, after) = match task.kind {
                TaskKind::FollowWall => (
                    Turn::Straight,
                    rng.random_range(c.straight_cells[0]..=c.straight_cells[1]),
                    0,
                ),
                kind => (
                    if kind == TaskKind::TurnLeft {
                        Turn::Left
                    } else {
                        Turn::Right
                    },
                    rng.random_range(c.cells_before_turn[0]..=c.cells_before_turn[1]),
                    rng.random_range(c.cells_after_turn[0]..=c.cells_after_turn[1]),
                ),
            };
            // One draw picks the turn's shape, so tasks without side junctions draw exactly
            // what they drew before side junctions existed.
            let junction = if turn == Turn::Straight {
                Junction::Bend
            } else {
                let draw = rng.random::<f32>();
                if draw < c.junction_share {
                    Junction::TEnd
                } else if draw < c.junction_share + c.side_junction_share {
                    Junction::Side
                } else {
                    Junction::Bend
                }
            };
            let corridor = corridor::build(turn, before, after, junction);
            let map = Arc::new(corridor.map);
            let mut start = stem_start(map.center(corridor.path[0]), FRAC_PI_2, task, rng);
            // Drawn only when asked for, so tasks without an advance keep their draws.
            if c.start_advance > 0.0 {
                start.y += rng.random_range(0.0..=c.start_advance);
            }
            Environment {
                scene: Arc::new(Scene::new(map.wall_rects(&[]), margin)),
                start,
                teammate: None,
                lights: Vec::new(),
                ground: Ground::Cells(CellGoal::new(map, &corridor.path)),
                variant: junction.index(),
            }
        }
        TaskKind::SolveMaze => {
            let (scene, map) = statics
                .maze_closed
                .clone()
                .expect("maze statics are built for maze tasks");
            let config = pick_variant(rng);
            let path = &maze.paths[config as usize];
            let start = stem_start(map.center(path[0]), FRAC_PI_2, task, rng);
            let goal = CellGoal::new(map, path);
            Environment {
                scene,
                start,
                teammate: Some((teammate_at_branch_end(&goal, task), false)),
                lights: lights_for(maze, config),
                ground: Ground::Cells(goal),
                variant: config,
            }
        }
        TaskKind::ReturnRoom => {
            let (scene, map) = statics
                .maze_closed
                .clone()
                .expect("maze statics are built for maze tasks");
            let branch = pick_variant(rng);
            let mut path = maze.paths[branch as usize].clone();
            path.reverse();
            let goal = CellGoal::new(map.clone(), &path);
            // The robot starts in the branch end facing back out, just in front of the
            // teammate, which already follows it (it was found there).
            let end = map.center(path[0]);
            let out = map.center(path[1]);
            let heading = (out[1] - end[1]).atan2(out[0] - end[0]);
            let dir = [heading.cos(), heading.sin()];
            let start = stem_start(
                [end[0] + 0.05 * dir[0], end[1] + 0.05 * dir[1]],
                heading,
                task,
                rng,
            );
            let mate = Pose {
                x: end[0] - 0.06 * dir[0],
                y: end[1] - 0.06 * dir[1],
                heading,
            };
            Environment {
                scene,
                start,
                teammate: Some((mate, true)),
                lights: Vec::new(),
                ground: Ground::Cells(goal),
                variant: branch,
            }
        }
        TaskKind::Rescue => {
            let config = pick_variant(rng);
            let entrance = maze.entrance();
            let entrance_center = maze.map.center(entrance);
            let half = 0.5 * maze.map.cell_size;
            let room_exit = [
                entrance_center[0],
                entrance_center[1] - half - 0.5 * maze.map.wall_thickness,
            ];
            let room = room::generate(
                &task.room,
                Placement::Below {
                    exit_center: room_exit,
                },
                rng,
            );
            // The room's top wall is the maze's lower border, so the maze leaves its
            // entrance border open and the room's exit gap is the way in.
            let mut rects: Vec<Rect> = maze.map.wall_rects(&[(entrance, Side::Bottom)]);
            rects.extend(room.rects.iter().copied());
            let map = Arc::new(maze.map.clone());
            let goal = CellGoal::new(map, &maze.paths[config as usize]);
            Environment {
                scene: Arc::new(Scene::new(rects, margin)),
                start: room.start,
                teammate: Some((teammate_at_branch_end(&goal, task), false)),
                lights: lights_for(maze, config),
                ground: Ground::Rescue { room, maze: goal },
                variant: config,
            }
        }
    }
}

/// A start pose at a corridor cell: jittered sideways and in heading (SPEC is silent; the
/// amounts are config values).
fn stem_start(center: [f32; 2], heading: f32, task: &TaskConfig, rng: &mut SimRng) -> Pose {
    let lateral = task.start.lateral_offset;
    let jitter = task.start.heading_jitter_deg.to_radians();
    let offset = if lateral > 0.0 {
        rng.random_range(-lateral..=lateral)
    } else {
        0.0
    };
    let turn = if jitter > 0.0 {
        rng.random_range(-jitter..=jitter)
    } else {
        0.0
    };
    let side = [-(heading.sin()), heading.cos()];
    Pose {
        x: center[0] + offset * side[0],
        y: center[1] + offset * side[1],
        heading: (heading + turn + PI).rem_euclid(2.0 * PI) - PI,
    }
}

/// The teammate waits near the dead end of the goal branch.
fn teammate_at_branch_end(goal: &CellGoal, task: &TaskConfig) -> Pose {
    let end = goal.map.center(goal.goal);
    let before = goal
        .map
        .neighbours(goal.goal)
        .next()
        .map_or(end, |n| goal.map.center(n));
    let heading = (before[1] - end[1]).atan2(before[0] - end[0]);
    // Towards the dead end from the cell centre, clear of the end wall.
    let back = 0.5 * goal.map.cell_size - 0.5 * goal.map.wall_thickness - task.robot.radius - 0.01;
    Pose {
        x: end[0] - back * heading.cos(),
        y: end[1] - back * heading.sin(),
        heading,
    }
}

fn lights_for(maze: &MazeLayout, config: u32) -> Vec<LightSpec> {
    maze.lights
        .iter()
        .map(|light| LightSpec {
            position: light.position,
            flashes: light.configurations.contains(&config),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Stream, stream_rng};
    use maze::MAZE_CELL_SIZE;

    /// How far along +y each of `n` samples' starts lie beyond their first cell's centre.
    fn start_advances(task: &TaskConfig, n: u64) -> Vec<f32> {
        let statics = Statics::new(task);
        (0..n)
            .map(|seed| {
                let env = build(
                    task,
                    &statics,
                    None,
                    &mut stream_rng(seed, Stream::Environment),
                );
                let Ground::Cells(goal) = &env.ground else {
                    panic!("corridor tasks are judged on cells");
                };
                env.start.y - goal.map.center(0)[1]
            })
            .collect()
    }

    #[test]
    fn turning_starts_spread_from_the_first_cell_to_the_junction() {
        let advances = start_advances(&TaskConfig::new(TaskKind::TurnLeft), 400);
        assert!(
            advances
                .iter()
                .all(|a| (0.0..=MAZE_CELL_SIZE + 1e-6).contains(a))
        );
        // Uniform over one cell: both ends of the range are reached.
        assert!(advances.iter().any(|&a| a < 0.03));
        assert!(advances.iter().any(|&a| a > MAZE_CELL_SIZE - 0.03));
    }

    #[test]
    fn the_other_branches_ends_are_the_wrong_ends() {
        let task = TaskConfig::new(TaskKind::SolveMaze);
        let statics = Statics::new(&task);
        let radius = task.robot.radius;
        for configuration in 0..4 {
            let env = build(
                &task,
                &statics,
                Some(configuration),
                &mut stream_rng(0, Stream::Environment),
            );
            let Ground::Cells(goal) = &env.ground else {
                panic!("maze tasks are judged on cells");
            };
            // The double T-maze has four branch ends; the goal is one of them.
            assert_eq!(goal.wrong_ends.len(), 3, "configuration {configuration}");
            assert!(!goal.reached_wrong_end(goal.map.center(goal.goal), radius));
            for &end in &goal.wrong_ends {
                assert!(!goal.on_path[end]);
                let center = goal.map.center(end);
                assert!(goal.reached_wrong_end(center, radius));
                // The bounding box meets the central half (0.075 m either side) or not.
                let edge = 0.25 * goal.map.cell_size + radius;
                assert!(goal.reached_wrong_end([center[0] + edge - 0.001, center[1]], radius));
                assert!(!goal.reached_wrong_end([center[0] + edge + 0.001, center[1]], radius));
            }
        }
    }

    #[test]
    fn following_starts_stay_at_the_first_cell_centre() {
        let advances = start_advances(&TaskConfig::new(TaskKind::FollowWall), 100);
        assert!(advances.iter().all(|&a| a.abs() < 1e-6), "{advances:?}");
    }
}
