//! The world's floor: what a sample's world is made of, with no notion of a scenario file.
//! The generators ([`room`], [`corridor`], [`random_maze`], the paper's maze in [`maze`]), the
//! lights and what triggers them ([`lights`]), and one sample's environment as the episode sets
//! it up ([`Environment`]: the scene, the start, the teammate, the lights and the ground truth
//! the task judges against).

pub mod corridor;
pub mod lights;
#[cfg(test)]
pub mod maze;
pub mod random_maze;
pub mod room;

use crate::body::Pose;
use crate::geometry::bodies::Disc;
use crate::geometry::cells::CellMap;
use crate::geometry::scene::Scene;
use lights::LightSpec;
use room::Room;
use std::sync::Arc;

/// What a sample's task judges progress against.
#[derive(Debug, Clone, Default)]
pub struct Ground {
    /// The room, in worlds with one.
    pub room: Option<Room>,
    /// The goal in cells and the path to it, when the variant has one.
    pub goal: Option<CellGoal>,
    /// The cells of the world, in worlds made of cells ("in maze").
    pub cells: Option<Arc<CellMap>>,
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
    pub(crate) fn new(map: Arc<CellMap>, path: &[usize]) -> CellGoal {
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
    /// The team's other robots' start poses, group by group (`[[robots]]`).
    pub team: Vec<Pose>,
    /// Where the items lie at the start, group by group (`[[objects]]`).
    pub items: Vec<[f32; 2]>,
    /// Where the boxes stand at the start, group by group (`[[boxes]]`).
    pub boxes: Vec<Disc>,
    /// The lights.
    pub lights: Vec<LightSpec>,
    /// The ground truth.
    pub ground: Ground,
    /// The variant (light configuration, start branch), or a turning corridor's shape.
    pub variant: u32,
}
