//! The robots of one sample at one instant, found by place: a team's sensors and collisions ask
//! which robots lie within some reach of a point, many times a cycle. Sort and sweep: the
//! robots are kept ordered by x (re-sorted each cycle from the last order, which is nearly
//! sorted already), and a query scans only the x-window of its reach, so a cycle of `n` robots
//! costs about `n log n` plus the pairs that are actually near, not `n * n`.

/// Every robot's position in one cycle, ordered by x for queries by place.
#[derive(Debug, Clone, Default)]
pub struct Crowd {
    /// By robot index.
    positions: Vec<[f32; 2]>,
    /// Robot indices in increasing x.
    by_x: Vec<u16>,
    /// `positions[by_x[k]][0]`, in that order: what a query's binary search reads.
    xs: Vec<f32>,
}

impl Crowd {
    /// No robot at all.
    pub const EMPTY: Crowd = Crowd {
        positions: Vec::new(),
        by_x: Vec::new(),
        xs: Vec::new(),
    };

    /// The largest crowd: robot indices are kept as `u16`.
    pub const MAX_ROBOTS: usize = u16::MAX as usize;

    /// Takes this cycle's positions, by robot index (at most [`Crowd::MAX_ROBOTS`]; the
    /// scenario's limit is far lower).
    pub fn set(&mut self, positions: impl IntoIterator<Item = [f32; 2]>) {
        self.positions.clear();
        self.positions.extend(positions);
        let n_robots = self.positions.len().min(Crowd::MAX_ROBOTS);
        if self.by_x.len() != n_robots {
            self.by_x = (0..n_robots as u16).collect();
        }
        let positions = &self.positions;
        // Stable, so robots at one x keep an order that depends on nothing but the last one.
        self.by_x
            .sort_by(|&a, &b| positions[a as usize][0].total_cmp(&positions[b as usize][0]));
        self.xs.clear();
        self.xs
            .extend(self.by_x.iter().map(|&idx| positions[idx as usize][0]));
    }

    /// The number of robots.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Every position, by robot index.
    pub fn positions(&self) -> &[[f32; 2]] {
        &self.positions
    }

    /// The robots whose centre lies within `reach` of `at` (the edge included), as (index,
    /// position, squared distance), in increasing x.
    pub fn near(
        &self,
        at: [f32; 2],
        reach: f32,
    ) -> impl Iterator<Item = (usize, [f32; 2], f32)> + '_ {
        let first = self.xs.partition_point(|&x| x < at[0] - reach);
        let reach_sq = reach * reach;
        self.by_x[first..]
            .iter()
            .map_while(move |&idx| {
                let position = self.positions[idx as usize];
                (position[0] <= at[0] + reach).then_some((idx as usize, position))
            })
            .filter_map(move |(idx, position)| {
                let (dx, dy) = (position[0] - at[0], position[1] - at[1]);
                let distance_sq = dx * dx + dy * dy;
                (distance_sq <= reach_sq).then_some((idx, position, distance_sq))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The sweep finds exactly the robots a scan of all of them finds.
        #[test]
        fn near_finds_what_a_full_scan_finds(
            positions in prop::collection::vec((-2.0f32..2.0, -2.0f32..2.0), 0..40),
            moved in prop::collection::vec((-2.0f32..2.0, -2.0f32..2.0), 0..40),
            at in (-2.5f32..2.5, -2.5f32..2.5),
            reach in 0.0f32..1.5,
        ) {
            let mut crowd = Crowd::default();
            // A second cycle re-sorts from the first's order.
            for cycle in [&positions, &moved] {
                crowd.set(cycle.iter().map(|&(x, y)| [x, y]));
                let mut found: Vec<usize> =
                    crowd.near([at.0, at.1], reach).map(|(idx, _, _)| idx).collect();
                found.sort_unstable();
                let expected: Vec<usize> = cycle
                    .iter()
                    .enumerate()
                    .filter(|(_, (x, y))| {
                        let (dx, dy) = (x - at.0, y - at.1);
                        dx * dx + dy * dy <= reach * reach
                    })
                    .map(|(idx, _)| idx)
                    .collect();
                prop_assert_eq!(found, expected);
            }
        }
    }
}
