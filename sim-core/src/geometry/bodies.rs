//! The bodies of a sample that are neither robots nor walls (`[[movers]]`, `[[boxes]]`): discs
//! that robots see and must not overlap. A *mover* patrols a fixed path at a fixed speed and
//! waits while its next step would overlap a robot or a box; a *box* stands until a robot's
//! move pushes it ([`Boxes::push`]). This is their state and their rules of change; where the
//! paths run and where the boxes start are the scenario's. Nothing here draws a number, so a
//! sample with bodies is as deterministic as one without.

use crate::geometry::scene::{Rect, Scene};
use crate::math::float::hypot;

/// A disc: a body as the sensors and the overlap tests see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disc {
    /// Its centre, metres.
    pub center: [f32; 2],
    /// Its radius, metres.
    pub radius: f32,
}

impl Disc {
    /// Whether a disc of `radius` at `at` overlaps this one (touching is no overlap).
    #[inline]
    pub fn overlaps(&self, at: [f32; 2], radius: f32) -> bool {
        let (dx, dy) = (self.center[0] - at[0], self.center[1] - at[1]);
        let touching = self.radius + radius;
        dx * dx + dy * dy < touching * touching
    }
}

/// Whether a disc of `radius` at `at` overlaps any of `discs`.
#[inline]
pub fn overlaps_any(discs: &[Disc], at: [f32; 2], radius: f32) -> bool {
    discs.iter().any(|disc| disc.overlaps(at, radius))
}

/// Whether a disc of `radius` swept along the segment from `from` to `to` overlaps a solid of
/// `scene` (touching is no overlap): what a mover's leg must not do.
pub fn leg_meets_solid(scene: &Scene, from: [f32; 2], to: [f32; 2], radius: f32) -> bool {
    scene
        .rects()
        .iter()
        .any(|rect| segment_rect_distance(rect, from, to) < radius)
}

/// The distance between the segment from `a` to `b` and the rectangle `rect`, 0 when they
/// meet. Both are convex: when apart, the nearest pair has an endpoint of the segment or a
/// corner of the rectangle in it.
pub fn segment_rect_distance(rect: &Rect, a: [f32; 2], b: [f32; 2]) -> f32 {
    let (sin, cos) = rect.angle.sin_cos();
    // In the rectangle's own frame, where it is the box |x| <= hx, |y| <= hy.
    let local = |p: [f32; 2]| {
        let (dx, dy) = (p[0] - rect.center[0], p[1] - rect.center[1]);
        [cos * dx + sin * dy, -sin * dx + cos * dy]
    };
    let (a, b) = (local(a), local(b));
    let half = rect.half_extents;
    // The slab test: the share of the segment inside each axis's slab, intersected.
    let (mut enter, mut exit) = (0.0f32, 1.0f32);
    for axis in 0..2 {
        let delta = b[axis] - a[axis];
        if delta == 0.0 {
            if a[axis].abs() > half[axis] {
                exit = -1.0;
            }
            continue;
        }
        let (t0, t1) = (
            (-half[axis] - a[axis]) / delta,
            (half[axis] - a[axis]) / delta,
        );
        enter = enter.max(t0.min(t1));
        exit = exit.min(t0.max(t1));
    }
    if enter <= exit {
        return 0.0;
    }
    let to_box = |p: [f32; 2]| {
        hypot(
            (p[0].abs() - half[0]).max(0.0),
            (p[1].abs() - half[1]).max(0.0),
        )
    };
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let length_sq = dx * dx + dy * dy;
    let to_segment = |p: [f32; 2]| {
        let share = (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / length_sq).clamp(0.0, 1.0);
        hypot(a[0] + share * dx - p[0], a[1] + share * dy - p[1])
    };
    let [hx, hy] = half;
    let corners = [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]];
    let from_corners = corners.into_iter().map(to_segment);
    let from_ends = [a, b].into_iter().map(to_box);
    from_corners.chain(from_ends).fold(f32::INFINITY, f32::min)
}

/// How a mover runs its path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathMode {
    /// From the first point to the last, then straight back to the first, and round again.
    Loop,
    /// From the first point to the last, then back along the path, and again.
    BackAndForth,
}

/// A mover's path as the scenario gives it (`[[movers]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct MoverPath {
    /// The mover's name, for messages and replays.
    pub name: String,
    /// Its radius, metres.
    pub radius: f32,
    /// The waypoints, at least two, no two in a row the same.
    pub points: Vec<[f32; 2]>,
    /// Metres a second.
    pub speed: f32,
    /// How it runs the path.
    pub mode: PathMode,
    /// Where it starts: a share of one lap, in [0, 1).
    pub start: f32,
}

impl MoverPath {
    /// The legs it runs, in order: each pair of points in a row, and for a loop the leg from
    /// the last point back to the first.
    pub fn legs(&self) -> impl Iterator<Item = ([f32; 2], [f32; 2])> + '_ {
        let closing = (self.mode == PathMode::Loop)
            .then(|| (self.points[self.points.len() - 1], self.points[0]));
        self.points
            .windows(2)
            .map(|pair| (pair[0], pair[1]))
            .chain(closing)
    }

    /// The length of one lap, metres: the legs' lengths, twice over back and forth.
    pub fn lap(&self) -> f32 {
        let legs: f32 = self.legs().map(|(a, b)| leg_length(a, b)).sum();
        match self.mode {
            PathMode::Loop => legs,
            PathMode::BackAndForth => 2.0 * legs,
        }
    }

    /// Where it stands `along` metres into a lap (`0 <= along < lap`).
    pub fn at(&self, along: f32) -> [f32; 2] {
        let lap = self.lap();
        // Back and forth: the second half of the lap runs the path backwards.
        let mut left = match self.mode {
            PathMode::BackAndForth if along > 0.5 * lap => lap - along,
            _ => along,
        };
        let mut end = self.points[0];
        for (from, to) in self.legs() {
            let length = leg_length(from, to);
            if left <= length {
                let share = left / length;
                return [
                    from[0] + share * (to[0] - from[0]),
                    from[1] + share * (to[1] - from[1]),
                ];
            }
            left -= length;
            end = to;
        }
        // Only rounding leaves anything past the last leg.
        end
    }

    /// How far into a lap it starts, metres.
    pub fn start_along(&self) -> f32 {
        self.start * self.lap()
    }

    /// Its disc where it starts.
    pub fn start_disc(&self) -> Disc {
        Disc {
            center: self.at(self.start_along()),
            radius: self.radius,
        }
    }
}

fn leg_length(from: [f32; 2], to: [f32; 2]) -> f32 {
    hypot(to[0] - from[0], to[1] - from[1])
}

/// Every mover of a sample: how far each is into its lap, and where it stands.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Movers {
    /// By mover, metres into its lap.
    along: Vec<f32>,
    /// By mover.
    discs: Vec<Disc>,
}

impl Movers {
    /// The movers of `paths`, each at its start.
    pub fn new(paths: &[MoverPath]) -> Movers {
        Movers {
            along: paths.iter().map(MoverPath::start_along).collect(),
            discs: paths.iter().map(MoverPath::start_disc).collect(),
        }
    }

    /// One cycle of `dt` seconds, mover by mover in index order: each advances its speed's
    /// distance along its path unless its disc there would be `blocked` (overlap a robot or a
    /// box), in which case it waits where it is for this cycle. Movers pass through each other.
    pub fn step(&mut self, paths: &[MoverPath], dt: f32, blocked: impl Fn(&Disc) -> bool) {
        for ((path, along), disc) in paths.iter().zip(&mut self.along).zip(&mut self.discs) {
            let next_along = (*along + path.speed * dt) % path.lap();
            let next = Disc {
                center: path.at(next_along),
                radius: path.radius,
            };
            if !blocked(&next) {
                *along = next_along;
                *disc = next;
            }
        }
    }

    /// Each mover's disc, by mover.
    pub fn discs(&self) -> &[Disc] {
        &self.discs
    }
}

/// The gap a push leaves between robot and box, metres: without it rounding could leave the
/// two a hair inside each other.
pub const PUSH_CLEARANCE: f32 = 1e-4;

/// Every box of a sample: discs that robots push.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Boxes {
    /// By box.
    discs: Vec<Disc>,
}

impl Boxes {
    /// Boxes where `discs` stand.
    pub fn new(discs: Vec<Disc>) -> Boxes {
        Boxes { discs }
    }

    /// Each box's disc, by box.
    pub fn discs(&self) -> &[Disc] {
        &self.discs
    }

    /// A robot of `radius` moving to `to` (its centre): whether it may, pushing the box its
    /// disc there would overlap. A robot that overlaps no box moves freely. One that overlaps
    /// exactly one box pushes that box along the line from the robot's new centre through the
    /// box's centre just far enough that the two touch ([`PUSH_CLEARANCE`] apart), unless the box there would be
    /// `blocked` (overlap a wall, a robot, a mover; the box's index is given) or overlap another
    /// box: then nothing moves and the robot's move is refused, as a move into a wall is. A
    /// robot overlapping two boxes at once, or landing on a box's very centre, is refused too
    /// (no chains, no direction to push in).
    pub fn push(
        &mut self,
        to: [f32; 2],
        radius: f32,
        blocked: impl Fn(usize, &Disc) -> bool,
    ) -> bool {
        let mut touched = self
            .discs
            .iter()
            .enumerate()
            .filter(|(_, disc)| disc.overlaps(to, radius));
        let Some((box_idx, disc)) = touched.next() else {
            return true;
        };
        if touched.next().is_some() {
            return false;
        }
        let (dx, dy) = (disc.center[0] - to[0], disc.center[1] - to[1]);
        let distance = hypot(dx, dy);
        if distance == 0.0 {
            return false;
        }
        let reach = radius + disc.radius + PUSH_CLEARANCE;
        let pushed = Disc {
            center: [to[0] + dx / distance * reach, to[1] + dy / distance * reach],
            radius: disc.radius,
        };
        let on_another_box =
            self.discs.iter().enumerate().any(|(other, disc)| {
                other != box_idx && disc.overlaps(pushed.center, pushed.radius)
            });
        if on_another_box || pushed.overlaps(to, radius) || blocked(box_idx, &pushed) {
            return false;
        }
        self.discs[box_idx] = pushed;
        true
    }
}

/// The movers and boxes of a sample, and the one rule a robot's move meets them by.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bodies {
    movers: Movers,
    boxes: Boxes,
    /// Every body where it stood at the end of the last cycle, the movers first, then the
    /// boxes: what the sensors see.
    discs: Vec<Disc>,
}

impl Bodies {
    /// The movers of `paths` at their starts and boxes at `boxes`.
    pub fn new(paths: &[MoverPath], boxes: Vec<Disc>) -> Bodies {
        let mut bodies = Bodies {
            movers: Movers::new(paths),
            boxes: Boxes::new(boxes),
            discs: Vec::new(),
        };
        bodies.note_discs();
        bodies
    }

    fn note_discs(&mut self) {
        self.discs.clear();
        self.discs.extend_from_slice(self.movers.discs());
        self.discs.extend_from_slice(self.boxes.discs());
    }

    /// Every body at the start of the cycle, the movers first, then the boxes.
    pub fn discs(&self) -> &[Disc] {
        &self.discs
    }

    /// The movers.
    pub fn movers(&self) -> &Movers {
        &self.movers
    }

    /// The boxes.
    pub fn boxes(&self) -> &Boxes {
        &self.boxes
    }

    /// A robot of `radius` moving to `to`, a place clear of walls and of the other robots:
    /// whether it may. A move onto a mover is refused; one onto a box pushes it
    /// ([`Boxes::push`]), the box kept clear of the walls of `scene`, of the movers and of the
    /// robots `on_robot` says its disc would overlap (the pushing one excepted).
    pub fn admit(
        &mut self,
        to: [f32; 2],
        radius: f32,
        scene: &Scene,
        on_robot: impl Fn(&Disc) -> bool,
    ) -> bool {
        if overlaps_any(self.movers.discs(), to, radius) {
            return false;
        }
        let movers = self.movers.discs();
        self.boxes.push(to, radius, |_, pushed| {
            scene.disc_hits_wide(pushed.center, pushed.radius)
                || overlaps_any(movers, pushed.center, pushed.radius)
                || on_robot(pushed)
        })
    }

    /// The cycle's end, after every robot's move: each mover advances unless it would then
    /// overlap a robot (of `robot_radius`, at `robots`) or a box ([`Movers::step`]).
    pub fn end_cycle(
        &mut self,
        paths: &[MoverPath],
        dt: f32,
        robots: &[[f32; 2]],
        robot_radius: f32,
    ) {
        let boxes = self.boxes.discs();
        self.movers.step(paths, dt, |next| {
            robots
                .iter()
                .any(|&robot| next.overlaps(robot, robot_radius))
                || overlaps_any(boxes, next.center, next.radius)
        });
        self.note_discs();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn path(points: &[[f32; 2]], mode: PathMode, start: f32) -> MoverPath {
        MoverPath {
            name: "m".into(),
            radius: 0.05,
            points: points.to_vec(),
            speed: 0.1,
            mode,
            start,
        }
    }

    /// Boxes of radius 0.05 at `centers`.
    fn discs(centers: &[[f32; 2]]) -> Vec<Disc> {
        centers
            .iter()
            .map(|&center| Disc {
                center,
                radius: 0.05,
            })
            .collect()
    }

    #[test]
    fn a_loop_runs_round_and_back_and_forth_turns_back() {
        let square = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        let looped = path(&square, PathMode::Loop, 0.0);
        assert!((looped.lap() - (2.0 + 2f32.sqrt())).abs() < 1e-6);
        assert_eq!(looped.at(0.5), [0.5, 0.0]);
        assert_eq!(looped.at(1.5), [1.0, 0.5]);
        // The closing leg runs back to the first point.
        let closing = looped.at(2.0 + 0.5 * 2f32.sqrt());
        assert!((closing[0] - 0.5).abs() < 1e-6 && (closing[1] - 0.5).abs() < 1e-6);
        let back = path(&square, PathMode::BackAndForth, 0.0);
        assert!((back.lap() - 4.0).abs() < 1e-6);
        assert_eq!(back.at(1.5), [1.0, 0.5]);
        // Three metres into the lap: one metre back from the far end.
        assert_eq!(back.at(3.0), [1.0, 0.0]);
        assert_eq!(back.at(3.5), [0.5, 0.0]);
    }

    #[test]
    fn a_mover_starts_at_its_share_of_the_lap_and_waits_when_blocked() {
        let paths = [path(
            &[[0.0, 0.0], [1.0, 0.0]],
            PathMode::BackAndForth,
            0.25,
        )];
        let mut movers = Movers::new(&paths);
        assert_eq!(movers.discs()[0].center, [0.5, 0.0]);
        movers.step(&paths, 1.0, |_| true);
        assert_eq!(movers.discs()[0].center, [0.5, 0.0]);
        movers.step(&paths, 1.0, |_| false);
        assert!((movers.discs()[0].center[0] - 0.6).abs() < 1e-6);
        // Past the lap's end it comes round again.
        for _ in 0..20 {
            movers.step(&paths, 1.0, |_| false);
        }
        assert!((movers.discs()[0].center[0] - 0.6).abs() < 1e-5);
    }

    #[test]
    fn a_push_moves_the_box_just_clear_along_the_line_of_centres() {
        let mut boxes = Boxes::new(discs(&[[1.0, 0.0]]));
        // A robot of radius 0.04 moving to 0.92 overlaps the box by 0.01.
        assert!(boxes.push([0.92, 0.0], 0.04, |_, _| false));
        let center = boxes.discs()[0].center;
        assert!(
            (center[0] - 1.01 - PUSH_CLEARANCE).abs() < 1e-6 && center[1] == 0.0,
            "{center:?}"
        );
        // Blocked: nothing moves, the robot's move is refused.
        assert!(!boxes.push([0.95, 0.0], 0.04, |_, _| true));
        assert_eq!(boxes.discs()[0].center, center);
        // A move that touches no box is free.
        assert!(boxes.push([0.0, 0.0], 0.04, |_, _| true));
    }

    #[test]
    fn a_robot_on_two_boxes_or_pushing_into_another_box_is_refused() {
        let mut boxes = Boxes::new(discs(&[[0.0, 0.1], [0.0, -0.1]]));
        assert!(!boxes.push([0.0, 0.0], 0.08, |_, _| false));
        let mut boxes = Boxes::new(discs(&[[0.1, 0.0], [0.2, 0.0]]));
        assert!(!boxes.push([0.02, 0.0], 0.04, |_, _| false));
        assert_eq!(boxes.discs()[0].center, [0.1, 0.0]);
    }

    #[test]
    fn a_segment_is_as_far_from_a_rectangle_as_its_nearest_points() {
        use crate::geometry::scene::RectKind;
        let square = Rect::from_corners(RectKind::Obstacle, -1.0, -1.0, 1.0, 1.0);
        // Through it, above it, beside a corner, ending short of a side.
        assert_eq!(segment_rect_distance(&square, [-2.0, 0.0], [2.0, 0.0]), 0.0);
        assert_eq!(segment_rect_distance(&square, [-2.0, 1.5], [2.0, 1.5]), 0.5);
        let corner = segment_rect_distance(&square, [2.0, 1.0], [1.0, 2.0]);
        assert!((corner - 0.5f32.sqrt()).abs() < 1e-6, "{corner}");
        assert_eq!(
            segment_rect_distance(&square, [3.0, 0.0], [1.25, 0.0]),
            0.25
        );
        // Turned by 45 degrees, its corner reaches sqrt(2) along x.
        let diamond = Rect {
            angle: std::f32::consts::FRAC_PI_4,
            ..square
        };
        let beside = segment_rect_distance(&diamond, [1.5, -1.0], [1.5, 1.0]);
        assert!((beside - (1.5 - 2f32.sqrt())).abs() < 1e-5, "{beside}");
    }

    #[test]
    fn a_move_onto_a_mover_is_refused_and_a_mover_waits_for_a_box() {
        // A mover running east along the x axis from x = 0, a box ahead of it at x = 0.2.
        let paths = [path(&[[0.0, 0.0], [1.0, 0.0]], PathMode::Loop, 0.0)];
        let boxes = discs(&[[0.2, 0.0]]);
        let mut bodies = Bodies::new(&paths, boxes);
        assert_eq!(bodies.discs().len(), 2);
        let scene = Scene::new(Vec::new(), 0.25);
        // A robot moving onto the mover is refused; one beside it moves.
        assert!(!bodies.admit([0.05, 0.05], 0.037, &scene, |_| false));
        assert!(bodies.admit([0.0, 0.5], 0.037, &scene, |_| false));
        // The mover advances 1 cm a cycle until it touches the box, then waits.
        for _ in 0..30 {
            bodies.end_cycle(&paths, 0.1, &[[0.0, 0.5]], 0.037);
        }
        let mover = bodies.movers().discs()[0];
        assert!(mover.center[0] <= 0.1 + 1e-6, "{mover:?}");
        assert!(mover.center[0] > 0.09, "{mover:?}");
        // A robot in its way holds it up as well.
        let mut bodies = Bodies::new(&paths, Vec::new());
        bodies.end_cycle(&paths, 0.1, &[[0.09, 0.0]], 0.037);
        assert_eq!(bodies.movers().discs()[0].center, [0.0, 0.0]);
    }

    proptest! {
        /// Whatever a robot does, no two boxes ever overlap, a box never lands where `blocked`
        /// says it may not be, and a refused push moves nothing.
        #[test]
        fn pushes_keep_boxes_apart_and_out_of_blocked_places(
            starts in prop::collection::vec((-0.5f32..0.5, -0.5f32..0.5), 1..8),
            walk in prop::collection::vec((-0.6f32..0.6, -0.6f32..0.6), 1..80),
        ) {
            let radius = 0.04;
            let mut discs: Vec<Disc> = Vec::new();
            for (x, y) in starts {
                if !overlaps_any(&discs, [x, y], radius) {
                    discs.push(Disc { center: [x, y], radius });
                }
            }
            let mut boxes = Boxes::new(discs);
            // A wall: x > 0.55.
            let blocked = |_: usize, disc: &Disc| disc.center[0] + disc.radius > 0.55;
            for (x, y) in walk {
                let before = boxes.clone();
                if !boxes.push([x, y], 0.037, blocked) {
                    prop_assert_eq!(&boxes, &before);
                }
                for (idx, disc) in boxes.discs().iter().enumerate() {
                    if before.discs()[idx] != *disc {
                        prop_assert!(!blocked(idx, disc));
                        prop_assert!(!disc.overlaps([x, y], 0.037));
                    }
                    for other in &boxes.discs()[idx + 1..] {
                        prop_assert!(!disc.overlaps(other.center, other.radius));
                    }
                }
            }
        }
    }
}
