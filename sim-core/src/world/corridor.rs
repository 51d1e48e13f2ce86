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

/// A corridor turned and moved to run outward from a map's cell `exit` across its side
/// `outward`, its first cell next to `exit` and the border between them open: one map of the
/// map's cells (same indices) followed by the corridor's, and the corridor's path in it.
/// With `exit` on the map's outermost row or column on that side, every corridor cell lies
/// beyond the map: none lands on a map cell, whatever the corridor's lengths.
pub fn join_beyond(map: &CellMap, exit: usize, outward: Side, corridor: &Corridor) -> Corridor {
    let turns = outward as usize;
    let [ex, ey] = map.cells[exit].at;
    let [ox, oy] = outward.offset();
    let mut cells = map.cells.clone();
    cells[exit].walls[outward as usize] = false;
    let first = cells.len();
    cells.extend(corridor.map.cells.iter().map(|cell| {
        let [x, y] = turn_cell(cell.at, outward);
        let mut walls = [false; 4];
        for (side_idx, &wall) in cell.walls.iter().enumerate() {
            walls[(side_idx + turns) % 4] = wall;
        }
        Cell {
            at: [ex + ox + x, ey + oy + y],
            walls,
        }
    }));
    // The corridor's first cell opens back onto the exit.
    cells[first + corridor.path[0]].walls[outward.opposite() as usize] = false;
    Corridor {
        map: CellMap::new(cells, map.cell_size, map.wall_thickness),
        path: corridor.path.iter().map(|&idx| first + idx).collect(),
    }
}

/// A corridor cell's grid offset from its first cell, turned from heading +y to `outward`.
fn turn_cell([x, y]: [i32; 2], outward: Side) -> [i32; 2] {
    match outward {
        Side::Top => [x, y],
        Side::Right => [y, -x],
        Side::Bottom => [-x, -y],
        Side::Left => [-y, x],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corridor_joins_beyond_an_exit_on_any_side() {
        // A plus of five cells: each arm's end is outermost on one side.
        let at = [[0, 0], [0, 1], [1, 0], [0, -1], [-1, 0]];
        let cells = at
            .iter()
            .map(|&at| Cell {
                at,
                // Open only between the centre and an arm.
                walls: Side::ALL.map(|side| {
                    let [dx, dy] = side.offset();
                    let next = [at[0] + dx, at[1] + dy];
                    !(next == [0, 0] || at == [0, 0])
                }),
            })
            .collect();
        let plus = CellMap::new(cells, MAZE_CELL_SIZE, MAZE_WALL_THICKNESS);
        let corridor = build(Turn::Left, 2, 3, Junction::Bend);
        for (exit, outward) in [
            (1, Side::Top),
            (2, Side::Right),
            (3, Side::Bottom),
            (4, Side::Left),
        ] {
            let joined = join_beyond(&plus, exit, outward, &corridor);
            // The map's cells first, unchanged but for the exit's open side.
            assert_eq!(joined.map.cells.len(), 5 + corridor.map.cells.len());
            for (idx, (before, after)) in plus.cells.iter().zip(&joined.map.cells).enumerate() {
                assert_eq!(before.at, after.at);
                let mut walls = before.walls;
                if idx == exit {
                    walls[outward as usize] = false;
                }
                assert_eq!(walls, after.walls, "{outward:?}, cell {idx}");
            }
            // The corridor's first cell lies across the exit's side and opens onto it; the way
            // runs from the plus's centre to the corridor's end, turning left of `outward`.
            let first = joined.path[0];
            let [ox, oy] = outward.offset();
            let [ex, ey] = plus.cells[exit].at;
            assert_eq!(joined.map.cells[first].at, [ex + ox, ey + oy]);
            let way =
                crate::geometry::cells::path_between(&joined.map, 0, *joined.path.last().unwrap())
                    .expect("the corridor's end is reached through the exit");
            assert_eq!(way.len(), 2 + joined.path.len(), "{outward:?}");
            let end = joined.map.cells[*joined.path.last().unwrap()].at;
            let left = Side::ALL[(outward as usize + 3) % 4].offset();
            let along = |v: [i32; 2], d: [i32; 2]| v[0] * d[0] + v[1] * d[1];
            assert_eq!(
                along([end[0] - ex, end[1] - ey], [ox, oy]),
                2,
                "{outward:?}"
            );
            assert_eq!(along([end[0] - ex, end[1] - ey], left), 3, "{outward:?}");
            // The walls close the whole: no open border leads out of the cells.
            for (idx, cell) in joined.map.cells.iter().enumerate() {
                for side in Side::ALL {
                    let [dx, dy] = side.offset();
                    let next = joined.map.index_of([cell.at[0] + dx, cell.at[1] + dy]);
                    assert!(
                        cell.walls[side as usize] || next.is_some(),
                        "{outward:?} {idx}"
                    );
                }
            }
        }
    }

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
