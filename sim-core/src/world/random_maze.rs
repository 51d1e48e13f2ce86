//! Random mazes: a perfect maze (every cell reachable from every other by exactly one way) of
//! `cols` x `rows` corridor cells, carved by a recursive backtracker from one sample's
//! environment stream, so each sample has its own maze and the same seed the same one. The
//! start is the bottom-left cell, the goal the top-right one; being a spanning tree of the
//! grid, the maze always connects them.

use crate::config::MAZE_CELL_SIZE;
use crate::geometry::cells::{self, Cell, CellMap, Side};
use crate::math::rng::SimRng;
use crate::world::corridor::MAZE_WALL_THICKNESS;
use rand::RngExt;

/// The most cells a random maze may have along a side: 32 x 32 cells are 9.6 m square and
/// about 2,100 wall rectangles, built anew for every sample.
pub const MAX_MAZE_SIDE: u32 = 32;

/// A maze drawn for one sample.
#[derive(Debug, Clone)]
pub struct RandomMaze {
    /// The cells; the start (bottom-left, at the origin) is cell 0.
    pub map: CellMap,
    /// The cells from the start to the goal (top-right), both included: the maze's one way.
    pub path: Vec<usize>,
}

/// Carves a `cols` x `rows` maze (each 1 to [`MAX_MAZE_SIDE`], checked when the scenario
/// compiles) from `rng`: from the start cell, step to a neighbour not yet visited, drawn
/// uniformly among them, knocking down the wall between; where there is none, back up.
pub fn generate(cols: u32, rows: u32, rng: &mut SimRng) -> RandomMaze {
    let (cols, rows) = (cols as i32, rows as i32);
    let index = |at: [i32; 2]| (at[1] * cols + at[0]) as usize;
    // Row by row from the bottom-left: the start is cell 0, the goal the last.
    let mut cells: Vec<Cell> = (0..rows)
        .flat_map(|y| (0..cols).map(move |x| [x, y]))
        .map(|at| Cell {
            at,
            walls: [true; 4],
        })
        .collect();
    let mut visited = vec![false; cells.len()];
    let mut stack = vec![[0, 0]];
    visited[0] = true;
    while let Some(&at) = stack.last() {
        let unvisited: Vec<Side> = Side::ALL
            .into_iter()
            .filter(|side| {
                let [dx, dy] = side.offset();
                let next = [at[0] + dx, at[1] + dy];
                (0..cols).contains(&next[0])
                    && (0..rows).contains(&next[1])
                    && !visited[index(next)]
            })
            .collect();
        if unvisited.is_empty() {
            stack.pop();
            continue;
        }
        let side = unvisited[rng.random_range(0..unvisited.len())];
        let [dx, dy] = side.offset();
        let next = [at[0] + dx, at[1] + dy];
        cells[index(at)].walls[side as usize] = false;
        cells[index(next)].walls[side.opposite() as usize] = false;
        visited[index(next)] = true;
        stack.push(next);
    }
    let map = CellMap::new(cells, MAZE_CELL_SIZE, MAZE_WALL_THICKNESS);
    let goal = map.cells.len() - 1;
    let path = cells::path_between(&map, 0, goal).expect("a perfect maze connects every cell");
    RandomMaze { map, path }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::{Stream, stream_rng};
    use proptest::prelude::*;

    /// The cells reachable from cell 0 through open borders.
    fn reachable(map: &CellMap) -> usize {
        let mut seen = vec![false; map.cells.len()];
        let mut todo = vec![0];
        seen[0] = true;
        while let Some(cell) = todo.pop() {
            for next in map.neighbours(cell) {
                if !seen[next] {
                    seen[next] = true;
                    todo.push(next);
                }
            }
        }
        seen.iter().filter(|&&s| s).count()
    }

    /// Open borders, each counted once.
    fn passages(map: &CellMap) -> usize {
        (0..map.cells.len())
            .map(|cell| map.neighbours(cell).count())
            .sum::<usize>()
            / 2
    }

    proptest! {
        /// Every cell is reachable, and the maze is a tree (one passage fewer than cells: no
        /// loops), so the path from start to goal is the one way; the outer border is closed.
        #[test]
        fn every_maze_is_perfect_and_its_goal_reachable(
            seed in any::<u64>(),
            cols in 1u32..=12,
            rows in 1u32..=12,
        ) {
            let maze = generate(cols, rows, &mut stream_rng(seed, Stream::Environment));
            let n_cells = (cols * rows) as usize;
            prop_assert_eq!(maze.map.cells.len(), n_cells);
            prop_assert_eq!(reachable(&maze.map), n_cells);
            prop_assert_eq!(passages(&maze.map), n_cells - 1);
            prop_assert_eq!(maze.path[0], 0);
            prop_assert_eq!(*maze.path.last().unwrap(), n_cells - 1);
            prop_assert_eq!(maze.map.cells[n_cells - 1].at, [cols as i32 - 1, rows as i32 - 1]);
            for pair in maze.path.windows(2) {
                prop_assert!(maze.map.neighbours(pair[0]).any(|next| next == pair[1]));
            }
            for cell in &maze.map.cells {
                let [x, y] = cell.at;
                prop_assert!(x > 0 || cell.walls[Side::Left as usize]);
                prop_assert!(y > 0 || cell.walls[Side::Bottom as usize]);
                prop_assert!(x < cols as i32 - 1 || cell.walls[Side::Right as usize]);
                prop_assert!(y < rows as i32 - 1 || cell.walls[Side::Top as usize]);
            }
        }
    }

    #[test]
    fn the_same_seed_draws_the_same_maze_and_others_differ() {
        let walls = |seed: u64| {
            let maze = generate(8, 8, &mut stream_rng(seed, Stream::Environment));
            maze.map.cells.iter().map(|c| c.walls).collect::<Vec<_>>()
        };
        assert_eq!(walls(5), walls(5));
        let distinct: std::collections::BTreeSet<_> = (0..20).map(walls).collect();
        assert_eq!(distinct.len(), 20);
    }

    #[test]
    fn the_largest_maze_has_a_bounded_count_of_walls() {
        // What a sample's scene is built from each time: the count of wall rectangles.
        let maze = generate(
            MAX_MAZE_SIDE,
            MAX_MAZE_SIDE,
            &mut stream_rng(1, Stream::Environment),
        );
        let walls = maze.map.wall_rects(&[]).len();
        assert!(walls < 2200, "{walls}");
    }
}
