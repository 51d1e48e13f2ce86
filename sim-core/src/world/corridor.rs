//! Corridors for the maze primitives, built from the maze's own cells (0.30 m, 0.20 m clear
//! width) so a primitive sees exactly the walls it will meet in the maze: straight corridors of
//! several lengths for "follow wall", and corridors with one left or one right turn for the
//! turning primitives. A turn is an L-bend or one of the two junctions of the double T-maze,
//! whose other way is a wrong branch: a T whose corridor ends in a wall (driving up the stem),
//! or a side opening with the corridor going on straight past it (driving back out of a branch
//! and along the cross corridor, as return to room does). A turning primitive that only ever
//! saw L-bends, or only T-ends, learns a rule ("turn at the wall ahead") that the other
//! junction breaks.

use crate::config::MAZE_CELL_SIZE;
use crate::geometry::cells::{Cell, CellMap, Side};

/// The maze's wall thickness, which leaves a 0.20 m corridor in a 0.30 m cell.
pub const MAZE_WALL_THICKNESS: f32 = 0.10;
use serde::{Deserialize, Serialize};

/// Which way a corridor turns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Turn {
    /// No turn: a straight corridor.
    Straight,
    /// One left turn.
    Left,
    /// One right turn.
    Right,
}

/// What the turn cell looks like.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Junction {
    /// An L-bend: the only way on is the turn.
    Bend,
    /// A T: the corridor ends in a wall, the opposite arm is a wrong branch.
    TEnd,
    /// A side opening: the corridor goes on straight past the turn, as a wrong branch.
    Side,
}

impl Junction {
    /// A small index for reports: bend 0, T 1, side 2.
    pub fn index(self) -> u32 {
        match self {
            Junction::Bend => 0,
            Junction::TEnd => 1,
            Junction::Side => 2,
        }
    }
}

/// A generated corridor: cells, the correct path through them (start first, goal last).
#[derive(Debug, Clone)]
pub struct Corridor {
    /// The cells.
    pub map: CellMap,
    /// Cell indices from the start to the goal.
    pub path: Vec<usize>,
}

/// Builds a corridor that starts at cell (0, 0) heading +y, runs `before` cells, then (for a
/// turn) continues `after` cells to the turn's side. At a [`Junction::TEnd`] the opposite arm,
/// at a [`Junction::Side`] the straight continuation (`after` cells long either way) is a dead
/// end that counts as a wrong branch.
pub fn build(turn: Turn, before: u32, after: u32, junction: Junction) -> Corridor {
    // Grid walk: the cells of the path, then the wrong arm if any; walls are derived from which
    // neighbours exist, so every generated shape is closed by construction.
    let mut path_at: Vec<[i32; 2]> = (0..before.max(1) as i32).map(|y| [0, y]).collect();
    let mut wrong_at: Vec<[i32; 2]> = Vec::new();
    let top = before.max(1) as i32 - 1;
    let dx = match turn {
        Turn::Straight => 0,
        Turn::Left => -1,
        Turn::Right => 1,
    };
    if dx != 0 {
        path_at.extend((1..=after.max(1) as i32).map(|i| [dx * i, top]));
        match junction {
            Junction::Bend => {}
            Junction::TEnd => wrong_at.extend((1..=after.max(1) as i32).map(|i| [-dx * i, top])),
            Junction::Side => wrong_at.extend((1..=after.max(1) as i32).map(|i| [0, top + i])),
        }
    }
    let all: Vec<[i32; 2]> = path_at.iter().chain(&wrong_at).copied().collect();
    let connected = |a: [i32; 2], b: [i32; 2]| {
        // Consecutive path cells, and the junction cell with the first wrong-arm cell, and
        // consecutive wrong-arm cells are joined; nothing else.
        let along = |list: &[[i32; 2]]| {
            list.windows(2)
                .any(|w| (w[0] == a && w[1] == b) || (w[0] == b && w[1] == a))
        };
        let junction_cell = [0, top];
        let wrong_link = wrong_at.first().is_some_and(|&first| {
            (a == junction_cell && b == first) || (b == junction_cell && a == first)
        });
        along(&path_at) || along(&wrong_at) || wrong_link
    };
    let cells = all
        .iter()
        .map(|&at| {
            let walls = Side::ALL.map(|side| {
                let [ox, oy] = side.offset();
                !connected(at, [at[0] + ox, at[1] + oy])
            });
            Cell { at, walls }
        })
        .collect();
    let map = CellMap::new(cells, MAZE_CELL_SIZE, MAZE_WALL_THICKNESS);
    Corridor {
        map,
        path: (0..path_at.len()).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_corridor_is_a_closed_tube() {
        let corridor = build(Turn::Straight, 4, 0, Junction::Bend);
        assert_eq!(corridor.path, vec![0, 1, 2, 3]);
        // 4 cells: two long sides of 4 walls and two ends.
        assert_eq!(corridor.map.wall_rects(&[]).len(), 10);
        let table = corridor.map.distances_to(3);
        assert!((table[0] - 0.9).abs() < 1e-5);
    }

    #[test]
    fn turns_go_the_right_way() {
        let left = build(Turn::Left, 2, 2, Junction::Bend);
        let goal = *left.path.last().unwrap();
        assert!(left.map.center(goal)[0] < 0.0);
        let right = build(Turn::Right, 3, 1, Junction::TEnd);
        let goal = *right.path.last().unwrap();
        assert!(right.map.center(goal)[0] > 0.0);
        // The junction has three open sides; the wrong arm is reachable but off the path.
        let junction = right.path[2];
        assert_eq!(right.map.neighbours(junction).count(), 3);
        assert_eq!(right.map.cells.len(), 5);
    }

    #[test]
    fn a_side_junction_goes_on_straight_past_the_turn() {
        let left = build(Turn::Left, 3, 2, Junction::Side);
        let junction = left.path[2];
        assert_eq!(left.map.center(junction)[0], 0.0);
        assert_eq!(left.map.neighbours(junction).count(), 3);
        // Path: 3 cells up, 2 to the left; wrong branch: 2 more straight up.
        assert_eq!(left.map.cells.len(), 7);
        let goal = *left.path.last().unwrap();
        assert!(left.map.center(goal)[0] < 0.0);
        let straight_on = left
            .map
            .neighbours(junction)
            .filter(|&n| !left.path.contains(&n))
            .map(|n| left.map.center(n))
            .collect::<Vec<_>>();
        assert_eq!(straight_on.len(), 1);
        assert_eq!(straight_on[0][0], 0.0);
        assert!(straight_on[0][1] > left.map.center(junction)[1]);
    }
}
