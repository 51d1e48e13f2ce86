//! Where a robot can get to: the floor a robot's disc can reach from where the robots start,
//! walking a grid of points clear of every solid. Scenario checks use it to refuse, before any
//! evaluation, a nest or an item that no robot could ever reach (a region walled off, an item
//! behind a wall). The test is generous on purpose: a point is open when a disc a grid step
//! smaller than the robot fits there, so a passage as wide as the robot always counts as open,
//! and only what no robot can reach by any margin is refused.

use super::scene::Scene;
use std::collections::VecDeque;

/// The most grid points a reach covers: a large map gets a coarser grid, not more memory.
const MAX_POINTS: f32 = 1_000_000.0;
/// The finest grid step, metres.
const MIN_STEP: f32 = 0.01;

/// The grid points a robot's centre can reach from its starts, over a rectangle.
#[derive(Debug)]
pub struct Reach {
    origin: [f32; 2],
    step: f32,
    cols: usize,
    rows: usize,
    reached: Vec<bool>,
}

impl Reach {
    /// Floods the open floor of `scene` over `bounds` (`[x0, y0, x1, y1]`, metres) from every
    /// grid point within a step of one of `starts`, for a robot of `radius`.
    pub fn flood(scene: &Scene, radius: f32, bounds: [f32; 4], starts: &[[f32; 2]]) -> Reach {
        let [x0, y0, x1, y1] = bounds;
        let (width, height) = ((x1 - x0).max(0.0), (y1 - y0).max(0.0));
        let step = MIN_STEP.max((width * height / MAX_POINTS).sqrt());
        let cols = (width / step) as usize + 1;
        let rows = (height / step) as usize + 1;
        let mut reach = Reach {
            origin: [x0, y0],
            step,
            cols,
            rows,
            reached: vec![false; cols * rows],
        };
        let clearance = (radius - step).max(0.0);
        let origin = reach.origin;
        let open = |idx: usize| {
            let at = grid_point(origin, step, cols, idx);
            !scene.disc_hits(at, clearance)
        };
        let mut queue = VecDeque::new();
        for start in starts {
            let near: Vec<usize> = reach.points_near(*start, step).collect();
            for idx in near {
                if !reach.reached[idx] && open(idx) {
                    reach.reached[idx] = true;
                    queue.push_back(idx);
                }
            }
        }
        while let Some(idx) = queue.pop_front() {
            let (col, row) = (idx % cols, idx / cols);
            let neighbours = [
                (col > 0).then(|| idx - 1),
                (col + 1 < cols).then(|| idx + 1),
                (row > 0).then(|| idx - cols),
                (row + 1 < rows).then(|| idx + cols),
            ];
            for next in neighbours.into_iter().flatten() {
                if !reach.reached[next] && open(next) {
                    reach.reached[next] = true;
                    queue.push_back(next);
                }
            }
        }
        reach
    }

    /// Whether a robot's centre can come within `within` metres of `at`.
    pub fn comes_within(&self, at: [f32; 2], within: f32) -> bool {
        self.points_near(at, within + self.step)
            .any(|idx| self.reached[idx])
    }

    /// Whether a robot's centre can be inside the rectangle `[x0, y0, x1, y1]`.
    pub fn enters(&self, [x0, y0, x1, y1]: [f32; 4]) -> bool {
        let centre = [(x0 + x1) / 2.0, (y0 + y1) / 2.0];
        let half = [(x1 - x0) / 2.0 + self.step, (y1 - y0) / 2.0 + self.step];
        self.points_in(centre, half).any(|idx| self.reached[idx])
    }

    fn point(&self, idx: usize) -> [f32; 2] {
        grid_point(self.origin, self.step, self.cols, idx)
    }

    /// The grid points within `distance` of `at`.
    fn points_near(&self, at: [f32; 2], distance: f32) -> impl Iterator<Item = usize> + '_ {
        self.points_in(at, [distance; 2]).filter(move |&idx| {
            let point = self.point(idx);
            let (dx, dy) = (point[0] - at[0], point[1] - at[1]);
            dx * dx + dy * dy <= distance * distance
        })
    }

    /// The grid points in the box of half sides `half` around `centre`.
    fn points_in(&self, centre: [f32; 2], half: [f32; 2]) -> impl Iterator<Item = usize> + '_ {
        let span = |value: f32, origin: f32, n: usize| {
            let lo = ((value - origin) / self.step).ceil().max(0.0) as usize;
            let hi = ((value - origin) / self.step).floor();
            (
                lo,
                if hi < 0.0 {
                    None
                } else {
                    Some((hi as usize).min(n - 1))
                },
            )
        };
        let (col_lo, _) = span(centre[0] - half[0], self.origin[0], self.cols);
        let (_, col_hi) = span(centre[0] + half[0], self.origin[0], self.cols);
        let (row_lo, _) = span(centre[1] - half[1], self.origin[1], self.rows);
        let (_, row_hi) = span(centre[1] + half[1], self.origin[1], self.rows);
        let cols = col_hi.map_or(0..0, |hi| col_lo..hi + 1);
        let rows = row_hi.map_or(0..0, |hi| row_lo..hi + 1);
        rows.flat_map(move |row| cols.clone().map(move |col| row * self.cols + col))
    }
}

/// The point `idx` of a grid of `cols` columns, `step` apart, from `origin`, row by row.
fn grid_point(origin: [f32; 2], step: f32, cols: usize, idx: usize) -> [f32; 2] {
    let (col, row) = (idx % cols, idx / cols);
    [origin[0] + col as f32 * step, origin[1] + row as f32 * step]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::scene::{Rect, RectKind};

    const RADIUS: f32 = 0.037;

    /// A 1 m square box of walls, with a wall across it at x = 0 leaving a gap of `gap` metres
    /// at its top (none for 0).
    fn split_box(gap: f32) -> Scene {
        let wall = |x0, y0, x1, y1| Rect::from_corners(RectKind::Wall, x0, y0, x1, y1);
        let mut rects = vec![
            wall(-0.55, -0.55, 0.55, -0.5),
            wall(-0.55, 0.5, 0.55, 0.55),
            wall(-0.55, -0.5, -0.5, 0.5),
            wall(0.5, -0.5, 0.55, 0.5),
        ];
        rects.push(wall(-0.02, -0.5, 0.02, 0.5 - gap));
        Scene::new(rects, 0.1)
    }

    fn reach(gap: f32) -> Reach {
        Reach::flood(
            &split_box(gap),
            RADIUS,
            [-0.6, -0.6, 0.6, 0.6],
            &[[-0.25, 0.0]],
        )
    }

    #[test]
    fn a_wall_across_the_box_keeps_the_robot_on_its_side() {
        let closed = reach(0.0);
        assert!(closed.enters([-0.4, -0.4, -0.3, -0.3]));
        assert!(!closed.enters([0.3, -0.4, 0.4, -0.3]));
        assert!(closed.comes_within([-0.1, 0.3], 0.0));
        assert!(!closed.comes_within([0.25, 0.0], 0.05));
        // Outside the walls is not reached either.
        assert!(!closed.comes_within([0.58, 0.0], 0.01));
    }

    #[test]
    fn a_gap_as_wide_as_the_robot_lets_it_through_and_a_narrower_one_does_not() {
        let open = reach(2.0 * RADIUS);
        assert!(open.enters([0.3, -0.4, 0.4, -0.3]));
        let narrow = reach(RADIUS);
        assert!(!narrow.enters([0.3, -0.4, 0.4, -0.3]));
    }

    #[test]
    fn a_start_inside_a_solid_reaches_nothing() {
        let reach = Reach::flood(
            &split_box(0.0),
            RADIUS,
            [-0.6, -0.6, 0.6, 0.6],
            &[[0.0, 0.0]],
        );
        assert!(!reach.enters([-0.5, -0.5, 0.5, 0.5]));
    }

    #[test]
    fn a_large_world_gets_a_coarser_grid_not_more_points() {
        let reach = Reach::flood(
            &split_box(0.1),
            RADIUS,
            [-50.0, -50.0, 50.0, 50.0],
            &[[-0.25, 0.0]],
        );
        assert!(
            reach.cols * reach.rows <= 1_002_001,
            "{}",
            reach.cols * reach.rows
        );
        assert!(reach.enters([-0.4, -0.4, -0.3, -0.3]));
    }
}
