//! Worlds made of square corridor cells: the double T-maze and the corridors the maze
//! primitives are evolved in. One cell map gives the walls (0.10 m thick on cell borders, so a
//! 0.30 m cell leaves a 0.20 m corridor), tells which cell a point is in, and measures the
//! distance along the corridors to a goal cell, which f2 and the corridor fitness need.

use crate::geometry::scene::{Rect, RectKind};
use crate::math::float::{floor_to_i32, hypot};
use std::collections::VecDeque;

/// Side of a square cell: top (+y), right (+x), bottom (-y), left (-x).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// +y
    Top = 0,
    /// +x
    Right = 1,
    /// -y
    Bottom = 2,
    /// -x
    Left = 3,
}

impl Side {
    /// All four sides, in index order.
    pub const ALL: [Side; 4] = [Side::Top, Side::Right, Side::Bottom, Side::Left];

    /// Grid offset to the neighbour across this side.
    pub fn offset(self) -> [i32; 2] {
        match self {
            Side::Top => [0, 1],
            Side::Right => [1, 0],
            Side::Bottom => [0, -1],
            Side::Left => [-1, 0],
        }
    }

    /// The side seen from the neighbour.
    pub fn opposite(self) -> Side {
        Side::ALL[(self as usize + 2) % 4]
    }
}

/// One square cell and which of its borders carry a wall.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cell {
    /// Grid coordinates, in cells.
    pub at: [i32; 2],
    /// Wall on top, right, bottom, left.
    pub walls: [bool; 4],
}

/// A set of corridor cells with their geometry.
#[derive(Debug, Clone)]
pub struct CellMap {
    /// The cells, in file or construction order (paths refer to these indices).
    pub cells: Vec<Cell>,
    /// Side of a cell, metres.
    pub cell_size: f32,
    /// Thickness of a wall, metres, centred on the cell border.
    pub wall_thickness: f32,
    /// For each cell, the neighbour across each side if that border is open on both cells.
    neighbours: Vec<[Option<u16>; 4]>,
    /// Grid bounds for `cell_at`: min x, min y, width, height (cells), and the lookup table.
    bounds: [i32; 4],
    lookup: Vec<Option<u16>>,
}

impl CellMap {
    /// Builds the map and its adjacency. A border is open when neither cell has a wall there.
    pub fn new(cells: Vec<Cell>, cell_size: f32, wall_thickness: f32) -> CellMap {
        let min_x = cells.iter().map(|c| c.at[0]).min().unwrap_or(0);
        let min_y = cells.iter().map(|c| c.at[1]).min().unwrap_or(0);
        let max_x = cells.iter().map(|c| c.at[0]).max().unwrap_or(0);
        let max_y = cells.iter().map(|c| c.at[1]).max().unwrap_or(0);
        let (width, height) = (max_x - min_x + 1, max_y - min_y + 1);
        let mut lookup = vec![None; (width * height) as usize];
        for (cell_idx, cell) in cells.iter().enumerate() {
            let slot = ((cell.at[1] - min_y) * width + (cell.at[0] - min_x)) as usize;
            lookup[slot] = Some(cell_idx as u16);
        }
        let mut map = CellMap {
            neighbours: Vec::new(),
            bounds: [min_x, min_y, width, height],
            lookup,
            cells,
            cell_size,
            wall_thickness,
        };
        map.neighbours = (0..map.cells.len())
            .map(|cell_idx| {
                let cell = map.cells[cell_idx];
                Side::ALL.map(|side| {
                    if cell.walls[side as usize] {
                        return None;
                    }
                    let [dx, dy] = side.offset();
                    let other = map.index_of([cell.at[0] + dx, cell.at[1] + dy])?;
                    (!map.cells[other].walls[side.opposite() as usize]).then_some(other as u16)
                })
            })
            .collect();
        map
    }

    /// Index of the cell at grid coordinates, if there is one.
    pub fn index_of(&self, at: [i32; 2]) -> Option<usize> {
        let [min_x, min_y, width, height] = self.bounds;
        let (gx, gy) = (at[0] - min_x, at[1] - min_y);
        if gx < 0 || gy < 0 || gx >= width || gy >= height {
            return None;
        }
        self.lookup[(gy * width + gx) as usize].map(usize::from)
    }

    /// Centre of a cell, metres.
    pub fn center(&self, cell_idx: usize) -> [f32; 2] {
        let at = self.cells[cell_idx].at;
        [at[0] as f32 * self.cell_size, at[1] as f32 * self.cell_size]
    }

    /// The cell containing a point, if any.
    pub fn cell_at(&self, point: [f32; 2]) -> Option<usize> {
        let gx = floor_to_i32(point[0] / self.cell_size + 0.5);
        let gy = floor_to_i32(point[1] / self.cell_size + 0.5);
        self.index_of([gx, gy])
    }

    /// The open neighbours of a cell.
    pub fn neighbours(&self, cell_idx: usize) -> impl Iterator<Item = usize> + '_ {
        self.neighbours[cell_idx]
            .iter()
            .flatten()
            .map(|&n| usize::from(n))
    }

    /// The wall rectangles. Each border wall is extended by half a wall thickness at both ends
    /// so corners close; a border shared by two cells gets one wall. `open` lists borders to
    /// leave open even though the file closes them (the maze entrance in the rescue world).
    pub fn wall_rects(&self, open: &[(usize, Side)]) -> Vec<Rect> {
        let half_cell = 0.5 * self.cell_size;
        let half_wall = 0.5 * self.wall_thickness;
        let mut seen = std::collections::HashSet::new();
        let mut rects = Vec::new();
        for (cell_idx, cell) in self.cells.iter().enumerate() {
            let [cx, cy] = self.center(cell_idx);
            for side in Side::ALL {
                if !cell.walls[side as usize] || open.contains(&(cell_idx, side)) {
                    continue;
                }
                // Identify a border by its midpoint in half-cell units, so the two cells that
                // share it agree.
                let [dx, dy] = side.offset();
                let key = (2 * cell.at[0] + dx, 2 * cell.at[1] + dy);
                if !seen.insert(key) {
                    continue;
                }
                let (mx, my) = (cx + dx as f32 * half_cell, cy + dy as f32 * half_cell);
                let rect = if dx == 0 {
                    Rect::from_corners(
                        RectKind::Wall,
                        mx - half_cell - half_wall,
                        my - half_wall,
                        mx + half_cell + half_wall,
                        my + half_wall,
                    )
                } else {
                    Rect::from_corners(
                        RectKind::Wall,
                        mx - half_wall,
                        my - half_cell - half_wall,
                        mx + half_wall,
                        my + half_cell + half_wall,
                    )
                };
                rects.push(rect);
            }
        }
        rects
    }

    /// Corridor distance from every cell centre to the centre of `goal` (breadth-first over open
    /// borders, one cell size per step). Unreachable cells get `f32::INFINITY`.
    pub fn distances_to(&self, goal: usize) -> Vec<f32> {
        let mut distance = vec![f32::INFINITY; self.cells.len()];
        let mut queue = VecDeque::from([goal]);
        distance[goal] = 0.0;
        while let Some(cell_idx) = queue.pop_front() {
            for next in self.neighbours(cell_idx) {
                if distance[next].is_infinite() {
                    distance[next] = distance[cell_idx] + self.cell_size;
                    queue.push_back(next);
                }
            }
        }
        distance
    }

    /// Corridor distance from a point to the goal whose `distances_to` table is given: through
    /// the best of the point's cell and its open neighbours, so the measure is continuous
    /// across cell borders. `None` when the point is in no cell.
    pub fn distance_from(&self, point: [f32; 2], table: &[f32]) -> Option<f32> {
        let cell_idx = self.cell_at(point)?;
        let via = |idx: usize| {
            let c = self.center(idx);
            hypot(point[0] - c[0], point[1] - c[1]) + table[idx]
        };
        Some(
            self.neighbours(cell_idx)
                .map(via)
                .fold(via(cell_idx), f32::min),
        )
    }
}

/// The cells of a shortest path from `from` to `to` through open borders, both ends included;
/// `None` when `to` cannot be reached. Ties go to the first neighbour in side order (top,
/// right, bottom, left), so the path is the same on every run.
pub fn path_between(map: &CellMap, from: usize, to: usize) -> Option<Vec<usize>> {
    let mut previous = vec![usize::MAX; map.cells.len()];
    previous[from] = from;
    let mut queue = VecDeque::from([from]);
    while let Some(cell_idx) = queue.pop_front() {
        if cell_idx == to {
            let mut path = vec![to];
            while *path.last().expect("non-empty") != from {
                path.push(previous[*path.last().expect("non-empty")]);
            }
            path.reverse();
            return Some(path);
        }
        for next in map.neighbours(cell_idx) {
            if previous[next] == usize::MAX {
                previous[next] = cell_idx;
                queue.push_back(next);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An L: three cells up, then two to the left.
    fn l_corridor() -> CellMap {
        let cells = vec![
            Cell {
                at: [0, 0],
                walls: [false, true, true, true],
            },
            Cell {
                at: [0, 1],
                walls: [false, true, false, true],
            },
            Cell {
                at: [0, 2],
                walls: [true, true, false, false],
            },
            Cell {
                at: [-1, 2],
                walls: [true, false, true, false],
            },
            Cell {
                at: [-2, 2],
                walls: [true, false, true, true],
            },
        ];
        CellMap::new(cells, 0.3, 0.1)
    }

    #[test]
    fn adjacency_follows_open_borders() {
        let map = l_corridor();
        let n: Vec<usize> = map.neighbours(2).collect();
        assert_eq!(n, vec![1, 3]);
        assert_eq!(map.cell_at([0.01, 0.31]), Some(1));
        assert_eq!(map.cell_at([0.5, 0.0]), None);
    }

    #[test]
    fn corridor_distance_is_along_the_path() {
        let map = l_corridor();
        let table = map.distances_to(4);
        assert_eq!(table[0], 4.0 * 0.3);
        let d = map.distance_from([0.0, 0.0], &table).unwrap();
        assert!((d - 1.2).abs() < 1e-5);
        // Continuous across a border: just below and above y = 0.15.
        let below = map.distance_from([0.0, 0.149], &table).unwrap();
        let above = map.distance_from([0.0, 0.151], &table).unwrap();
        assert!((below - above).abs() < 0.01, "{below} vs {above}");
    }

    #[test]
    fn shared_borders_give_one_wall() {
        let map = l_corridor();
        let rects = map.wall_rects(&[]);
        // Count borders with a wall, shared ones once: 3 + 2 + 2 + 2 + 3 = 12.
        assert_eq!(rects.len(), 12);
        let open = map.wall_rects(&[(0, Side::Bottom)]);
        assert_eq!(open.len(), 11);
    }
}
