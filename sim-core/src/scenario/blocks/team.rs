//! The team's fitness quantities and condition atoms (scenarios with `[[robots]]`): how close
//! the robots keep to one another and where they are, over every robot of the team, the focal
//! one included.
//! `team.spread` and `team.nearest` are averages over the cycles judged, so that a team is
//! credited for the whole sample rather than for its last instant; `team.in REGION` is a share
//! at the end. The atoms `team gathered`, `team dispersed` and `team in REGION` hold when
//! every robot is close to the team's centre, far from its nearest neighbour, or in the region. Each refuses a scenario without other robots, where
//! it would say nothing.

use super::atoms::RegionTest;
use super::quantities::MAX_DISTANCE;
use super::{
    Atom, AtomKind, CycleView, EndView, Facts, Quantity, QuantityKind, Recognised, Tracked,
};
use crate::math::float::hypot;

/// Why a team quantity is refused in a scenario without `[[robots]]`.
const NEEDS_A_TEAM: &str = "needs other robots ([[robots]])";

/// `name` compiled to `make()` when the scenario has a team.
fn team_word(
    text: &str,
    name: &str,
    facts: &Facts<'_>,
    make: fn() -> Box<dyn Quantity>,
) -> Recognised<dyn Quantity> {
    if text != name {
        return None;
    }
    Some(if facts.has_team {
        Ok(make())
    } else {
        Err(NEEDS_A_TEAM.into())
    })
}

/// `team.spread`: the mean distance of the robots to their centre (the mean of their
/// positions), metres, averaged over the cycles judged: small for an aggregated team.
pub const TEAM_SPREAD: QuantityKind = QuantityKind {
    syntax: &["team.spread"],
    compile: |text, facts| {
        team_word(text, "team.spread", facts, || {
            Box::new(TeamAverage { of_cycle: spread })
        })
    },
};

/// `team.nearest`: the mean over the robots of each one's distance to its nearest neighbour,
/// metres, averaged over the cycles judged: large for a dispersed team.
pub const TEAM_NEAREST: QuantityKind = QuantityKind {
    syntax: &["team.nearest"],
    compile: |text, facts| {
        team_word(text, "team.nearest", facts, || {
            Box::new(TeamAverage { of_cycle: nearest })
        })
    },
};

/// The centre of `positions` (their mean); the origin for none.
pub fn centre(positions: &[[f32; 2]]) -> [f32; 2] {
    if positions.is_empty() {
        return [0.0; 2];
    }
    let n_robots = positions.len() as f32;
    let (sum_x, sum_y) = positions
        .iter()
        .fold((0.0f32, 0.0f32), |(x, y), p| (x + p[0], y + p[1]));
    [sum_x / n_robots, sum_y / n_robots]
}

/// The mean distance of `positions` to their centre.
pub fn spread(positions: &[[f32; 2]]) -> f32 {
    if positions.is_empty() {
        return 0.0;
    }
    let centre = centre(positions);
    positions
        .iter()
        .map(|p| hypot(p[0] - centre[0], p[1] - centre[1]))
        .sum::<f32>()
        / positions.len() as f32
}

/// The mean over `positions` of each one's distance to the nearest other (0 for fewer than
/// two).
pub fn nearest(positions: &[[f32; 2]]) -> f32 {
    if positions.len() < 2 {
        return 0.0;
    }
    // Squared distances compared, one root a robot: a cycle of n robots costs n * n
    // multiply-adds and n roots.
    let total: f32 = positions
        .iter()
        .enumerate()
        .map(|(idx, p)| {
            positions
                .iter()
                .enumerate()
                .filter(|&(other, _)| other != idx)
                .map(|(_, q)| {
                    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
                    dx * dx + dy * dy
                })
                .fold(f32::INFINITY, f32::min)
                .sqrt()
        })
        .sum();
    total / positions.len() as f32
}

/// A measure of the team's positions, averaged over the cycles judged.
#[derive(Debug)]
struct TeamAverage {
    of_cycle: fn(&[[f32; 2]]) -> f32,
}

impl Quantity for TeamAverage {
    fn tracks(&self) -> bool {
        true
    }

    fn observe(&self, tracked: &mut Tracked, view: &CycleView<'_>) {
        tracked.sum += (self.of_cycle)(view.team);
        tracked.cycles += 1;
    }

    fn value(&self, tracked: &Tracked, _end: &EndView<'_>) -> f32 {
        match tracked.cycles {
            0 => 0.0,
            cycles => (tracked.sum / cycles as f32).min(MAX_DISTANCE),
        }
    }

    fn range(&self, _n_phases: usize) -> (f32, f32) {
        (0.0, MAX_DISTANCE)
    }
}

/// `team.in REGION`: the share of the team's robots whose centre is in the region when the
/// sample ends, in [0, 1].
pub const TEAM_IN: QuantityKind = QuantityKind {
    syntax: &["team.in REGION"],
    compile: |text, facts| {
        let name = text.strip_prefix("team.in ")?.trim();
        if !facts.has_team {
            return Some(Err(NEEDS_A_TEAM.into()));
        }
        Some((facts.region)(name).map(|test| Box::new(TeamIn(test)) as Box<dyn Quantity>))
    },
};

#[derive(Debug)]
struct TeamIn(RegionTest);

impl Quantity for TeamIn {
    fn value(&self, _tracked: &Tracked, end: &EndView<'_>) -> f32 {
        let team = end.cycle.team;
        if team.is_empty() {
            return 0.0;
        }
        let inside = team
            .iter()
            .filter(|&&position| self.0.contains(&end.cycle, position))
            .count();
        inside as f32 / team.len() as f32
    }
}

/// `team gathered`: every robot's centre within `end.near_m` of the team's centre.
pub const TEAM_GATHERED: AtomKind = AtomKind {
    syntax: &["team gathered"],
    compile: |text, facts| {
        if text != "team gathered" {
            return None;
        }
        Some(match (facts.has_team, facts.near_m > 0.0) {
            (false, _) => Err(NEEDS_A_TEAM.into()),
            (true, false) => Err("needs `end.near_m`, how close to the team's centre".into()),
            (true, true) => Ok(Box::new(TeamGathered {
                within: facts.near_m,
            }) as Box<dyn Atom>),
        })
    },
};

#[derive(Debug)]
struct TeamGathered {
    within: f32,
}

impl Atom for TeamGathered {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        let centre = centre(view.team);
        !view.team.is_empty()
            && view
                .team
                .iter()
                .all(|p| hypot(p[0] - centre[0], p[1] - centre[1]) <= self.within)
    }
}

/// `team dispersed`: every robot's nearest neighbour at least `end.near_m` away (centre to
/// centre).
pub const TEAM_DISPERSED: AtomKind = AtomKind {
    syntax: &["team dispersed"],
    compile: |text, facts| {
        if text != "team dispersed" {
            return None;
        }
        Some(match (facts.has_team, facts.near_m > 0.0) {
            (false, _) => Err(NEEDS_A_TEAM.into()),
            (true, false) => Err("needs `end.near_m`, how far apart".into()),
            (true, true) => Ok(Box::new(TeamDispersed {
                apart: facts.near_m,
            }) as Box<dyn Atom>),
        })
    },
};

#[derive(Debug)]
struct TeamDispersed {
    apart: f32,
}

impl Atom for TeamDispersed {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        let apart_sq = self.apart * self.apart;
        view.team.len() > 1
            && view.team.iter().enumerate().all(|(idx, p)| {
                view.team.iter().enumerate().all(|(other, q)| {
                    let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
                    other == idx || dx * dx + dy * dy >= apart_sq
                })
            })
    }
}

/// `team in REGION`: every robot's centre in the region.
pub const TEAM_IN_REGION: AtomKind = AtomKind {
    syntax: &["team in REGION"],
    compile: |text, facts| {
        let name = text.strip_prefix("team in ")?.trim();
        if !facts.has_team {
            return Some(Err(NEEDS_A_TEAM.into()));
        }
        Some((facts.region)(name).map(|test| Box::new(TeamInRegion(test)) as Box<dyn Atom>))
    },
};

#[derive(Debug)]
struct TeamInRegion(RegionTest);

impl Atom for TeamInRegion {
    fn holds(&self, view: &CycleView<'_>) -> bool {
        !view.team.is_empty()
            && view
                .team
                .iter()
                .all(|&position| self.0.contains(view, position))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_is_the_mean_distance_to_the_centre() {
        assert_eq!(spread(&[]), 0.0);
        assert_eq!(spread(&[[1.0, 2.0]]), 0.0);
        // A square of side 2 about the origin: every corner sqrt(2) from the centre.
        let square = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]];
        assert!((spread(&square) - 2f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn nearest_is_the_mean_distance_to_the_nearest_neighbour() {
        assert_eq!(nearest(&[[0.0, 0.0]]), 0.0);
        // Two close robots (0.1 apart) and one far (1 from the nearer): (0.1 + 0.1 + 1) / 3.
        let robots = [[0.0, 0.0], [0.1, 0.0], [1.1, 0.0]];
        assert!((nearest(&robots) - 1.2 / 3.0).abs() < 1e-6);
    }
}
