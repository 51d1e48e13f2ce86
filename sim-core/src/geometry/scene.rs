//! The static scene of one sample: walls and obstacles as rectangles with their parry (rapier2d)
//! boxes, plus a per-cell table of candidate rectangles built once when the scene is made.
//!
//! Why the table: one rapier `QueryPipeline::cast_ray` costs about 113 ns here, and a control
//! cycle casts 28 IR rays, which would cap the simulator near 300 thousand cycles per second.
//! So the broad question (which rectangles are near this place) is answered once per grid cell
//! when the scene is made, by binning parry's boxes of the rectangles into the cells; the hot
//! path then looks up the robot's cell and tests its rectangles against every sensor cone at
//! once, one cone per vector lane, with exact point-distance and slab tests written against a
//! flat layout of each rectangle. The tests hold the table to the one rapier's broad phase
//! gives and the distances to parry's ray casts.

use crate::math::float::hypot;
use rapier2d::math::{Pose, Vector};
use rapier2d::parry::bounding_volume::{Aabb, BoundingVolume};
use rapier2d::parry::shape::Cuboid;
use serde::{Deserialize, Serialize};

/// What a rectangle of the scene is, for drawing and for the tasks' bookkeeping.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RectKind {
    /// A wall of a room, maze or corridor.
    Wall,
    /// An obstacle inside the room.
    Obstacle,
}

/// A solid rectangle, possibly rotated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Rect {
    /// Centre, metres.
    pub center: [f32; 2],
    /// Half the side lengths along the rectangle's own axes, metres.
    pub half_extents: [f32; 2],
    /// Rotation of the rectangle's axes, radians.
    pub angle: f32,
    /// Wall or obstacle.
    pub kind: RectKind,
}

impl Rect {
    /// An axis-aligned rectangle between two corners.
    pub fn from_corners(kind: RectKind, x0: f32, y0: f32, x1: f32, y1: f32) -> Rect {
        Rect {
            center: [(x0 + x1) * 0.5, (y0 + y1) * 0.5],
            half_extents: [(x1 - x0).abs() * 0.5, (y1 - y0).abs() * 0.5],
            angle: 0.0,
            kind,
        }
    }

    /// The four corners, counter-clockwise, for drawing and clearance checks.
    pub fn corners(&self) -> [[f32; 2]; 4] {
        let (s, c) = self.angle.sin_cos();
        let [hx, hy] = self.half_extents;
        let local = [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]];
        local.map(|[lx, ly]| {
            [
                self.center[0] + c * lx - s * ly,
                self.center[1] + s * lx + c * ly,
            ]
        })
    }

    /// Radius of the circle around the centre that contains the rectangle.
    pub fn circumradius(&self) -> f32 {
        hypot(self.half_extents[0], self.half_extents[1])
    }

    fn pose(&self) -> Pose {
        Pose::new(Vector::new(self.center[0], self.center[1]), self.angle)
    }
}

/// One rectangle in the hot-path layout: centre, axes and half extents for exact tests in the
/// rectangle's own frame, and its box for cheap rejects. parry's generic `Cuboid::cast_ray`
/// transforms the ray through a full pose on every call and was more than half of a control
/// cycle's cost; the same slab test written against this layout is several times cheaper, and
/// the tests check it against parry.
#[derive(Debug, Clone)]
struct Solid {
    center: [f32; 2],
    /// cos and sin of the rectangle's angle.
    axis: [f32; 2],
    half: [f32; 2],
    aabb: Aabb,
    /// True for rectangles aligned with the world axes (every wall): their box is the solid
    /// itself, so rays need no rotation into a local frame.
    axis_aligned: bool,
}

impl Solid {
    /// A point in the rectangle's frame.
    #[inline(always)]
    fn to_local(&self, p: [f32; 2]) -> [f32; 2] {
        let (dx, dy) = (p[0] - self.center[0], p[1] - self.center[1]);
        if self.axis_aligned {
            return [dx, dy];
        }
        [
            self.axis[0] * dx + self.axis[1] * dy,
            -self.axis[1] * dx + self.axis[0] * dy,
        ]
    }

    /// The offset from a local point to the rectangle's nearest point, and its length.
    #[inline(always)]
    fn nearest_offset(&self, q: [f32; 2]) -> ([f32; 2], f32) {
        let offset = [
            q[0].clamp(-self.half[0], self.half[0]) - q[0],
            q[1].clamp(-self.half[1], self.half[1]) - q[1],
        ];
        (
            offset,
            (offset[0] * offset[0] + offset[1] * offset[1]).sqrt(),
        )
    }
}

/// The static geometry of a sample, with the spatial table the sensors and the collision test use.
#[derive(Debug)]
pub struct Scene {
    rects: Vec<Rect>,
    solids: Vec<Solid>,
    /// The grid the table is over.
    grid: Grid,
    /// For each cell, the range of `candidates` that lists the solids near it.
    cell_ranges: Vec<(u32, u32)>,
    candidates: Vec<u16>,
    /// Every solid, for a query from outside the grid (never on a legal trajectory).
    all_solids: Vec<u16>,
    /// How far beyond its cell a cell's list reaches, metres: the widest disc the grid answers.
    query_margin: f32,
}

/// The distance beyond a cell that its candidate list must cover: the robot's body, the IR
/// range beyond the body and one cycle's worth of movement, with room to spare.
#[cfg(test)]
pub const DEFAULT_QUERY_MARGIN: f32 = 0.25;
const GRID_CELL: f32 = 0.1;
const CELLS_PER_METRE: f32 = 1.0 / GRID_CELL;

/// A sensor cone in world coordinates: its axis, the cosine of half its opening, and its two
/// boundary rays (unit vectors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cone {
    /// Unit vector along the cone's axis.
    pub axis: [f32; 2],
    /// cos(opening / 2).
    pub cos_half_angle: f32,
    /// Unit vectors along the two boundary rays.
    pub boundaries: [[f32; 2]; 2],
    /// Component-wise inverses of the boundary rays, for slab tests without division.
    pub inverse_boundaries: [[f32; 2]; 2],
}

impl Cone {
    /// The cone around direction `angle` (radians) with the given opening (radians).
    pub fn new(angle: f32, opening: f32) -> Cone {
        let half = 0.5 * opening;
        let unit = |a: f32| [a.cos(), a.sin()];
        Cone::from_parts(
            unit(angle),
            half.cos(),
            [unit(angle - half), unit(angle + half)],
        )
    }

    fn from_parts(axis: [f32; 2], cos_half_angle: f32, boundaries: [[f32; 2]; 2]) -> Cone {
        let inverse_boundaries = boundaries.map(|d| [1.0 / d[0], 1.0 / d[1]]);
        Cone {
            axis,
            cos_half_angle,
            boundaries,
            inverse_boundaries,
        }
    }

    /// The same cone turned by an angle given by its sine and cosine.
    #[inline(always)]
    pub fn rotated(&self, sin: f32, cos: f32) -> Cone {
        let turn = |d: [f32; 2]| [cos * d[0] - sin * d[1], sin * d[0] + cos * d[1]];
        Cone::from_parts(
            turn(self.axis),
            self.cos_half_angle,
            self.boundaries.map(turn),
        )
    }
}

/// The table's grid: 0.1 m cells over the solids' boxes, and the margin each cell's list covers.
#[derive(Debug)]
struct Grid {
    /// Lower-left corner, metres.
    origin: [f32; 2],
    nx: usize,
    ny: usize,
    /// `nx` and `ny` as floats, for the lookup's range test.
    extent: [f32; 2],
    margin: f32,
}

impl Grid {
    fn around(solids: &[Solid], margin: f32) -> Grid {
        let (mut min, mut max) = ([f32::MAX; 2], [f32::MIN; 2]);
        for solid in solids {
            for axis in 0..2 {
                min[axis] = min[axis].min(solid.aabb.mins[axis]);
                max[axis] = max[axis].max(solid.aabb.maxs[axis]);
            }
        }
        if solids.is_empty() {
            (min, max) = ([0.0; 2], [0.0; 2]);
        }
        let nx = (((max[0] - min[0]) / GRID_CELL).ceil() as usize).max(1);
        let ny = (((max[1] - min[1]) / GRID_CELL).ceil() as usize).max(1);
        Grid {
            origin: min,
            nx,
            ny,
            extent: [nx as f32, ny as f32],
            margin,
        }
    }

    /// Cell `(ix, iy)` widened by the margin: a solid is listed there when its box meets this.
    fn cell_box(&self, ix: usize, iy: usize) -> Aabb {
        let x0 = self.origin[0] + ix as f32 * GRID_CELL;
        let y0 = self.origin[1] + iy as f32 * GRID_CELL;
        Aabb::new(
            Vector::new(x0 - self.margin, y0 - self.margin),
            Vector::new(x0 + GRID_CELL + self.margin, y0 + GRID_CELL + self.margin),
        )
    }

    /// Calls `visit` with the index of every cell whose widened box meets `aabb`, row by row.
    /// The index range is estimated one cell wide on each side and the exact test decides, so
    /// rounding in the estimate cannot drop a cell.
    fn for_each_cell_near(&self, aabb: &Aabb, mut visit: impl FnMut(usize)) {
        let span = |low: f32, high: f32, origin: f32, n: usize| {
            let first = ((low - self.margin - origin) / GRID_CELL).floor() - 2.0;
            let last = ((high + self.margin - origin) / GRID_CELL).ceil() + 1.0;
            let clamp = |v: f32| (v.max(0.0) as usize).min(n - 1);
            clamp(first)..=clamp(last)
        };
        let xs = span(aabb.mins.x, aabb.maxs.x, self.origin[0], self.nx);
        for iy in span(aabb.mins.y, aabb.maxs.y, self.origin[1], self.ny) {
            for ix in xs.clone() {
                if aabb.intersects(&self.cell_box(ix, iy)) {
                    visit(iy * self.nx + ix);
                }
            }
        }
    }
}

impl Scene {
    /// Builds the scene: each rectangle's box (parry's), and the per-cell table listing, for
    /// every 0.1 m grid cell, the rectangles whose boxes come within `query_margin` of it.
    /// `query_margin` must cover the robot radius plus the IR range.
    ///
    /// The table is binned: each box visits the few cells near it and the exact box test
    /// (`Aabb::intersects` against the cell's box widened by the margin) decides. Rectangles are
    /// visited in order, so every list comes out sorted and no query depends on a tree's
    /// layout. It is the table a broad-phase query per cell gives (the test
    /// `binned_table_is_the_broad_phase_table` builds that one through rapier and compares),
    /// at a small part of the cost (decision 0033).
    pub fn new(rects: Vec<Rect>, query_margin: f32) -> Scene {
        let solids: Vec<Solid> = rects
            .iter()
            .map(|rect| {
                let cuboid = Cuboid::new(Vector::new(rect.half_extents[0], rect.half_extents[1]));
                Solid {
                    center: rect.center,
                    axis: [rect.angle.cos(), rect.angle.sin()],
                    half: rect.half_extents,
                    aabb: cuboid.aabb(&rect.pose()),
                    axis_aligned: rect.angle == 0.0,
                }
            })
            .collect();
        let grid = Grid::around(&solids, query_margin);

        // Two passes over the same cells: count per cell, then fill the slots.
        let n_cells = grid.nx * grid.ny;
        let mut counts = vec![0u32; n_cells + 1];
        for solid in &solids {
            grid.for_each_cell_near(&solid.aabb, |cell| counts[cell + 1] += 1);
        }
        for cell in 0..n_cells {
            counts[cell + 1] += counts[cell];
        }
        let cell_ranges: Vec<(u32, u32)> = counts.windows(2).map(|w| (w[0], w[1])).collect();
        let mut filled = counts;
        let mut candidates = vec![0u16; cell_ranges.last().map_or(0, |r| r.1 as usize)];
        for (solid_idx, solid) in solids.iter().enumerate() {
            grid.for_each_cell_near(&solid.aabb, |cell| {
                candidates[filled[cell] as usize] = solid_idx as u16;
                filled[cell] += 1;
            });
        }

        Scene {
            all_solids: (0..solids.len() as u16).collect(),
            query_margin,
            rects,
            solids,
            grid,
            cell_ranges,
            candidates,
        }
    }

    /// Every rectangle of the scene, in insertion order.
    pub fn rects(&self) -> &[Rect] {
        &self.rects
    }

    /// The solids that may lie within the query margin of `point`.
    ///
    /// The cell is found by a multiplication, not a division: the division's latency sits on
    /// the chain from one cycle's pose to the next. The two can disagree about a point within
    /// a hair of a cell border, and either cell is right: its list holds every solid within the
    /// margin of the point but for that hair, and the margin has centimetres to spare over what
    /// the cones and the disc test reach (a solid farther away fails their box test, and a
    /// list holds its solids in index order, so the ones that matter meet the tests in the same
    /// order from either list).
    #[inline]
    fn near(&self, point: [f32; 2]) -> &[u16] {
        let grid = &self.grid;
        let fx = (point[0] - grid.origin[0]) * CELLS_PER_METRE;
        let fy = (point[1] - grid.origin[1]) * CELLS_PER_METRE;
        // Outside the grid (or not a number): every solid.
        if !(fx >= 0.0 && fy >= 0.0 && fx < grid.extent[0] && fy < grid.extent[1]) {
            return &self.all_solids;
        }
        // Within the grid the cell indices fit a u32, whose conversion is cheaper than a
        // usize's.
        let (ix, iy) = (fx as u32 as usize, fy as u32 as usize);
        let (start, end) = self.cell_ranges[iy * grid.nx + ix];
        &self.candidates[start as usize..end as usize]
    }

    /// Whether a disc of `radius` centred at `center` overlaps any solid.
    pub fn disc_hits(&self, center: [f32; 2], radius: f32) -> bool {
        self.disc_hits_among(self.near(center), center, radius)
    }

    /// [`Scene::disc_hits`] for a disc of any radius (a mover's, a box's): one wider than the
    /// grid's margin (less a centimetre for the hair `near` may miss by) is tested against
    /// every solid.
    pub fn disc_hits_wide(&self, center: [f32; 2], radius: f32) -> bool {
        if radius <= self.query_margin - 0.01 {
            self.disc_hits(center, radius)
        } else {
            self.disc_hits_among(&self.all_solids, center, radius)
        }
    }

    /// [`Scene::disc_hits`] over the solids of `candidates`.
    #[inline(always)]
    fn disc_hits_among(&self, candidates: &[u16], center: [f32; 2], radius: f32) -> bool {
        let point = Vector::new(center[0], center[1]);
        candidates.iter().any(|&solid_idx| {
            let solid = &self.solids[solid_idx as usize];
            // The box test is a cheap reject before parry's exact distance.
            solid.aabb.mins.x - radius < point.x
                && point.x < solid.aabb.maxs.x + radius
                && solid.aabb.mins.y - radius < point.y
                && point.y < solid.aabb.maxs.y + radius
                && solid.nearest_offset(solid.to_local(center)).1 < radius
        })
    }

    /// The distance from `origin` to the nearest point of any solid inside a cone, within
    /// `max_distance`: the exact "nearest surface in the sensor's cone". `near` is a point whose
    /// grid cell covers the origin (the robot's centre). Returns `None` when nothing is in range.
    ///
    /// Exact and cheap because a solid and the cone (opening below 180 degrees) are both convex:
    /// the nearest point of their intersection is the solid's own nearest point when that lies
    /// inside the cone, and otherwise lies on one of the cone's two boundary rays.
    pub fn cone_distance(
        &self,
        near: [f32; 2],
        origin: [f32; 2],
        cone: &Cone,
        max_distance: f32,
    ) -> Option<f32> {
        let [distance] =
            self.cone_distances(near, &[origin], std::array::from_ref(cone), max_distance);
        distance
    }

    /// [`Scene::cone_distance`] for several cones whose origins share the grid cell of `near`
    /// (a robot's sensors): one pass over the cell's candidates serves every cone. Each cone
    /// meets the candidates in the same order as on its own, so its distance is bit for bit the
    /// one [`Scene::cone_distance`] gives.
    pub fn cone_distances<const N: usize>(
        &self,
        near: [f32; 2],
        origins: &[[f32; 2]; N],
        cones: &[Cone; N],
        max_distance: f32,
    ) -> [Option<f32>; N] {
        let origin_lanes = [
            std::array::from_fn(|l| origins[l][0]),
            std::array::from_fn(|l| origins[l][1]),
        ];
        self.cone_lane_distances(near, &origin_lanes, &ConeLanes::new(cones), max_distance)
    }

    /// [`Scene::cone_distances`] with the cones and their origins (`origins[axis][lane]`)
    /// already laid out lane by lane, as the control loop keeps them.
    ///
    /// The cones are tested side by side: every step is the same operation in every lane,
    /// without branches, so the compiler turns the lane loops into vector instructions. Each
    /// lane makes exactly the decisions of the one-cone test (`reference` in the tests below
    /// keeps it): reject by box, reject by the solid's nearest distance, take that distance
    /// when it lies inside the cone, else cast the two boundary rays, the second against the
    /// first's result.
    #[inline(always)]
    pub fn cone_lane_distances<const N: usize>(
        &self,
        near: [f32; 2],
        origins: &[[f32; N]; 2],
        cones: &ConeLanes<N>,
        max_distance: f32,
    ) -> [Option<f32>; N] {
        self.cone_lane_distances_among(self.near(near), origins, cones, max_distance)
    }

    /// [`Scene::cone_lane_distances`] over the solids of `candidates`, in their order.
    #[inline(always)]
    fn cone_lane_distances_among<const N: usize>(
        &self,
        candidates: &[u16],
        origins: &[[f32; N]; 2],
        cones: &ConeLanes<N>,
        max_distance: f32,
    ) -> [Option<f32>; N] {
        let mut best = [max_distance; N];
        let mut hit = [0u32; N];
        for &solid_idx in candidates {
            self.solids[solid_idx as usize].cone_lanes(origins, cones, &mut best, &mut hit);
        }
        std::array::from_fn(|lane| (hit[lane] != 0).then_some(best[lane]))
    }
}

/// Several cones laid out lane by lane (structure of arrays): cone `lane`'s numbers at index
/// `lane` of each array. [`Cone`]'s fields, transposed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConeLanes<const N: usize> {
    /// `axis[component][lane]`.
    axis: [[f32; N]; 2],
    cos_half_angle: [f32; N],
    /// `boundaries[ray][component][lane]`.
    boundaries: [[[f32; N]; 2]; 2],
    inverse_boundaries: [[[f32; N]; 2]; 2],
}

impl<const N: usize> ConeLanes<N> {
    /// The cones, lane by lane.
    pub fn new(cones: &[Cone; N]) -> ConeLanes<N> {
        let vector = |of: [[f32; 2]; N]| -> [[f32; N]; 2] {
            [
                std::array::from_fn(|l| of[l][0]),
                std::array::from_fn(|l| of[l][1]),
            ]
        };
        ConeLanes {
            axis: vector(cones.map(|cone| cone.axis)),
            cos_half_angle: cones.map(|cone| cone.cos_half_angle),
            boundaries: [
                vector(cones.map(|cone| cone.boundaries[0])),
                vector(cones.map(|cone| cone.boundaries[1])),
            ],
            inverse_boundaries: [
                vector(cones.map(|cone| cone.inverse_boundaries[0])),
                vector(cones.map(|cone| cone.inverse_boundaries[1])),
            ],
        }
    }

    /// Every cone turned by an angle given by its sine and cosine: lane by lane what
    /// [`Cone::rotated`] computes, bit for bit.
    #[inline(always)]
    pub fn rotated(&self, sin: f32, cos: f32) -> ConeLanes<N> {
        let turn = |[x, y]: &[[f32; N]; 2]| -> [[f32; N]; 2] {
            [
                std::array::from_fn(|l| cos * x[l] - sin * y[l]),
                std::array::from_fn(|l| sin * x[l] + cos * y[l]),
            ]
        };
        let boundaries = [turn(&self.boundaries[0]), turn(&self.boundaries[1])];
        ConeLanes {
            axis: turn(&self.axis),
            cos_half_angle: self.cos_half_angle,
            boundaries,
            inverse_boundaries: boundaries.map(|ray| ray.map(|c| c.map(|v| 1.0 / v))),
        }
    }
}

impl<const N: usize> ConeLanes<N> {
    /// Tests a disc (another robot's body: centre `center`, radius `radius`) against every
    /// cone: where the disc holds a point inside a cone nearer than that cone's `best`, lowers
    /// `best` to it and sets `hit`. Exact as the solids' test is, for the same reason (a disc
    /// and a cone are convex): the disc's own nearest point when it lies inside the cone, else
    /// the nearer entry of the two boundary rays into the disc.
    #[inline]
    pub fn disc_lanes(
        &self,
        origins: &[[f32; N]; 2],
        center: [f32; 2],
        radius: f32,
        best: &mut [f32; N],
        hit: &mut [u32; N],
    ) {
        for l in 0..N {
            let (dx, dy) = (center[0] - origins[0][l], center[1] - origins[1][l]);
            let to_center_sq = dx * dx + dy * dy;
            // Beyond the best so far: no root taken (most sensors of most neighbours).
            let beyond = best[l] + radius;
            if to_center_sq >= beyond * beyond {
                continue;
            }
            let to_center = to_center_sq.sqrt();
            let surface = (to_center - radius).max(0.0);
            // Within the cone: the direction to the centre (the nearest point's) inside it.
            if dx * self.axis[0][l] + dy * self.axis[1][l] >= to_center * self.cos_half_angle[l] {
                best[l] = surface;
                hit[l] = u32::MAX;
                continue;
            }
            for ray in 0..2 {
                let (bx, by) = (self.boundaries[ray][0][l], self.boundaries[ray][1][l]);
                let along = dx * bx + dy * by;
                let across_sq = dx * dx + dy * dy - along * along;
                let chord_sq = radius * radius - across_sq;
                if along < 0.0 || chord_sq < 0.0 {
                    continue;
                }
                let enter = (along - chord_sq.sqrt()).max(0.0);
                if enter < best[l] {
                    best[l] = enter;
                    hit[l] = u32::MAX;
                }
            }
        }
    }
}

/// A lane's yes or no as all ones or all zeros: masks of this form, unlike `bool`s, stay in
/// vector registers, and selecting with them is two bitwise operations.
#[inline(always)]
fn mask(yes: bool) -> u32 {
    0u32.wrapping_sub(u32::from(yes))
}

/// `yes` where `mask` is set, else `no`.
#[inline(always)]
fn pick(mask: u32, yes: f32, no: f32) -> f32 {
    f32::from_bits((yes.to_bits() & mask) | (no.to_bits() & !mask))
}

/// Whether any lane's mask is set.
#[inline(always)]
fn any<const N: usize>(masks: &[u32; N]) -> bool {
    masks.iter().fold(0, |all, &m| all | m) != 0
}

/// `f32::min` as x86-64 computes it (`minss` with a NaN first operand dropped), written out
/// so that a lane loop vectorises to the same values; a NaN appears when a ray runs along a
/// face (0 * inf), and the slab test wants it dropped.
#[inline(always)]
fn min_num(a: f32, b: f32) -> f32 {
    pick(mask(a.is_nan() | (b < a)), b, a)
}

/// `f32::max` likewise.
#[inline(always)]
fn max_num(a: f32, b: f32) -> f32 {
    pick(mask(a.is_nan() | (b > a)), b, a)
}

/// `f32::clamp` for `low <= high`, written out for lane loops (`maxps`, `minps`).
#[inline(always)]
fn clamp_num(x: f32, low: f32, high: f32) -> f32 {
    let x = if x < low { low } else { x };
    if x > high { high } else { x }
}

/// The slab test of one ray per lane against a rectangle of half extents `half`, in its
/// frame: the ray's local origin and the component-wise inverse of its local direction. Gives
/// the entry distance (0 when the origin is inside) and the exit distance; the ray meets the
/// rectangle where `exit >= entry`.
#[inline(always)]
fn slab_lanes<const N: usize>(
    half: [f32; 2],
    [qx, qy]: [&[f32; N]; 2],
    [inverse_x, inverse_y]: [&[f32; N]; 2],
) -> ([f32; N], [f32; N]) {
    let mut enter = [0.0; N];
    let mut exit = [0.0; N];
    for l in 0..N {
        let tx1 = (-half[0] - qx[l]) * inverse_x[l];
        let tx2 = (half[0] - qx[l]) * inverse_x[l];
        let ty1 = (-half[1] - qy[l]) * inverse_y[l];
        let ty2 = (half[1] - qy[l]) * inverse_y[l];
        enter[l] = max_num(max_num(min_num(tx1, tx2), min_num(ty1, ty2)), 0.0);
        exit[l] = min_num(max_num(tx1, tx2), max_num(ty1, ty2));
    }
    (enter, exit)
}

impl Solid {
    /// Tests the solid against every cone of `lanes`: where it holds a point inside a cone
    /// nearer than that cone's `best`, lowers `best` to it and sets `hit`.
    #[inline(always)]
    fn cone_lanes<const N: usize>(
        &self,
        origins: &[[f32; N]; 2],
        lanes: &ConeLanes<N>,
        best: &mut [f32; N],
        hit: &mut [u32; N],
    ) {
        let [ox, oy] = origins;
        let (mins, maxs) = (self.aabb.mins, self.aabb.maxs);
        // Box reject: a cone lies within its `best` of its origin.
        let in_box: [u32; N] = std::array::from_fn(|l| {
            !mask(
                (maxs.x < ox[l] - best[l])
                    | (mins.x > ox[l] + best[l])
                    | (maxs.y < oy[l] - best[l])
                    | (mins.y > oy[l] + best[l]),
            )
        });
        if !any(&in_box) {
            return;
        }
        // Walls are axis-aligned: their frame is the world's shifted, so the rotation is
        // skipped and the boundary rays' inverse directions are the cone's own.
        let [qx, qy] = self.lanes_to_local(ox, oy);
        let offset_x: [f32; N] =
            std::array::from_fn(|l| clamp_num(qx[l], -self.half[0], self.half[0]) - qx[l]);
        let offset_y: [f32; N] =
            std::array::from_fn(|l| clamp_num(qy[l], -self.half[1], self.half[1]) - qy[l]);
        let distance: [f32; N] =
            std::array::from_fn(|l| (offset_x[l] * offset_x[l] + offset_y[l] * offset_y[l]).sqrt());
        // Not `distance < best`: a NaN distance goes on, as in the one-cone test.
        let live: [u32; N] = std::array::from_fn(|l| in_box[l] & !mask(distance[l] >= best[l]));
        if !any(&live) {
            return;
        }
        let [axis_x, axis_y] = self.lanes_dir_to_local(&lanes.axis[0], &lanes.axis[1]);
        let within: [u32; N] = std::array::from_fn(|l| {
            live[l]
                & mask(
                    offset_x[l] * axis_x[l] + offset_y[l] * axis_y[l]
                        >= distance[l] * lanes.cos_half_angle[l],
                )
        });
        let mut ray_best = *best;
        let mut ray_hit = [0u32; N];
        for ray in 0..2 {
            let [inverse_x, inverse_y] = if self.axis_aligned {
                lanes.inverse_boundaries[ray]
            } else {
                let [dx, dy] = &lanes.boundaries[ray];
                let [lx, ly] = self.lanes_dir_to_local(dx, dy);
                [lx.map(|v| 1.0 / v), ly.map(|v| 1.0 / v)]
            };
            let (enter, exit) = slab_lanes(self.half, [&qx, &qy], [&inverse_x, &inverse_y]);
            for l in 0..N {
                let meets =
                    live[l] & !within[l] & mask((exit[l] >= enter[l]) & (enter[l] < ray_best[l]));
                ray_best[l] = pick(meets, enter[l], ray_best[l]);
                ray_hit[l] |= meets;
            }
        }
        for l in 0..N {
            best[l] = pick(within[l], distance[l], ray_best[l]);
            hit[l] |= within[l] | ray_hit[l];
        }
    }

    /// Points given lane by lane, in the rectangle's frame.
    #[inline(always)]
    fn lanes_to_local<const N: usize>(&self, x: &[f32; N], y: &[f32; N]) -> [[f32; N]; 2] {
        let dx: [f32; N] = std::array::from_fn(|l| x[l] - self.center[0]);
        let dy: [f32; N] = std::array::from_fn(|l| y[l] - self.center[1]);
        self.lanes_dir_to_local(&dx, &dy)
    }

    /// Directions given lane by lane, in the rectangle's frame.
    #[inline(always)]
    fn lanes_dir_to_local<const N: usize>(&self, x: &[f32; N], y: &[f32; N]) -> [[f32; N]; 2] {
        if self.axis_aligned {
            return [*x, *y];
        }
        let [c, s] = self.axis;
        [
            std::array::from_fn(|l| c * x[l] + s * y[l]),
            std::array::from_fn(|l| -s * x[l] + c * y[l]),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier2d::parry::query::{PointQuery, Ray, RayCast};

    /// The one-cone test as first written, branch by branch: the lane code must make the same
    /// decisions, so its distances are this one's bit for bit.
    fn reference(
        scene: &Scene,
        near: [f32; 2],
        origin: [f32; 2],
        cone: &Cone,
        max_distance: f32,
    ) -> Option<f32> {
        let dir_to_local = |solid: &Solid, d: [f32; 2]| {
            if solid.axis_aligned {
                return d;
            }
            [
                solid.axis[0] * d[0] + solid.axis[1] * d[1],
                -solid.axis[1] * d[0] + solid.axis[0] * d[1],
            ]
        };
        let slab = |solid: &Solid, o: [f32; 2], inverse: [f32; 2], max: f32| {
            let tx1 = (-solid.half[0] - o[0]) * inverse[0];
            let tx2 = (solid.half[0] - o[0]) * inverse[0];
            let ty1 = (-solid.half[1] - o[1]) * inverse[1];
            let ty2 = (solid.half[1] - o[1]) * inverse[1];
            let enter = tx1.min(tx2).max(ty1.min(ty2)).max(0.0);
            let exit = tx1.max(tx2).min(ty1.max(ty2));
            (exit >= enter && enter < max).then_some(enter)
        };
        let mut best = max_distance;
        let mut hit = false;
        for &solid_idx in scene.near(near) {
            let solid = &scene.solids[solid_idx as usize];
            if solid.aabb.maxs.x < origin[0] - best
                || solid.aabb.mins.x > origin[0] + best
                || solid.aabb.maxs.y < origin[1] - best
                || solid.aabb.mins.y > origin[1] + best
            {
                continue;
            }
            let local_origin = solid.to_local(origin);
            let (offset, distance) = solid.nearest_offset(local_origin);
            if distance >= best {
                continue;
            }
            let axis = dir_to_local(solid, cone.axis);
            if offset[0] * axis[0] + offset[1] * axis[1] >= distance * cone.cos_half_angle {
                best = distance;
                hit = true;
                continue;
            }
            for (boundary, inverse) in cone.boundaries.iter().zip(&cone.inverse_boundaries) {
                let inverse = if solid.axis_aligned {
                    *inverse
                } else {
                    let d = dir_to_local(solid, *boundary);
                    [1.0 / d[0], 1.0 / d[1]]
                };
                if let Some(toi) = slab(solid, local_origin, inverse, best) {
                    best = toi;
                    hit = true;
                }
            }
        }
        hit.then_some(best)
    }

    #[test]
    fn disc_test_agrees_with_parry_on_rotated_rectangles() {
        let rect = Rect {
            center: [0.1, -0.2],
            half_extents: [0.08, 0.03],
            angle: 0.9,
            kind: RectKind::Obstacle,
        };
        let scene = Scene::new(vec![rect], DEFAULT_QUERY_MARGIN);
        let cuboid = Cuboid::new(Vector::new(0.08, 0.03));
        for ix in 0..60 {
            for iy in 0..60 {
                let p = [-0.2 + ix as f32 * 0.01, -0.5 + iy as f32 * 0.01];
                let exact = cuboid.distance_to_point(&rect.pose(), Vector::new(p[0], p[1]), true);
                let solid = &scene.solids[0];
                let ours = solid.nearest_offset(solid.to_local(p)).1;
                assert!((exact - ours).abs() < 1e-5, "at {p:?}: {exact} vs {ours}");
            }
        }
    }

    /// The table as the broad phase gives it: every rectangle a static collider in rapier, and
    /// one conservative box query per grid cell, narrowed by the exact box test and sorted.
    fn broad_phase_table(scene: &Scene, query_margin: f32) -> (Vec<(u32, u32)>, Vec<u16>) {
        use rapier2d::parry::query::DefaultQueryDispatcher;
        use rapier2d::prelude::{
            BroadPhaseBvh, ColliderBuilder, ColliderSet, IntegrationParameters, QueryFilter,
            RigidBodySet,
        };
        let bodies = RigidBodySet::new();
        let mut colliders = ColliderSet::new();
        let mut broad_phase = BroadPhaseBvh::new();
        let params = IntegrationParameters::default();
        let mut handle_to_solid = Vec::new();
        for (solid_idx, rect) in scene.rects.iter().enumerate() {
            let collider = ColliderBuilder::cuboid(rect.half_extents[0], rect.half_extents[1])
                .position(rect.pose())
                .build();
            let aabb = collider.compute_aabb();
            let handle = colliders.insert(collider);
            broad_phase.set_aabb(&params, handle, aabb);
            let raw = handle.into_raw_parts().0 as usize;
            if handle_to_solid.len() <= raw {
                handle_to_solid.resize(raw + 1, u16::MAX);
            }
            handle_to_solid[raw] = solid_idx as u16;
        }
        let grid = Grid::around(&scene.solids, query_margin);
        let dispatcher = DefaultQueryDispatcher;
        let query =
            broad_phase.as_query_pipeline(&dispatcher, &bodies, &colliders, QueryFilter::default());
        let (mut cell_ranges, mut candidates) = (Vec::new(), Vec::new());
        for iy in 0..grid.ny {
            for ix in 0..grid.nx {
                let cell_box = grid.cell_box(ix, iy);
                let start = candidates.len() as u32;
                let mut here: Vec<u16> = query
                    .intersect_aabb_conservative(cell_box)
                    .map(|(handle, _)| handle_to_solid[handle.into_raw_parts().0 as usize])
                    .filter(|&idx| scene.solids[idx as usize].aabb.intersects(&cell_box))
                    .collect();
                here.sort_unstable();
                candidates.extend(here);
                cell_ranges.push((start, candidates.len() as u32));
            }
        }
        (cell_ranges, candidates)
    }

    fn assert_broad_phase_table(rects: Vec<Rect>, query_margin: f32, what: &str) {
        let scene = Scene::new(rects, query_margin);
        let (cell_ranges, candidates) = broad_phase_table(&scene, query_margin);
        assert_eq!(scene.cell_ranges, cell_ranges, "{what}: cell ranges");
        assert_eq!(scene.candidates, candidates, "{what}: candidates");
        assert!(
            !scene.candidates.is_empty() || scene.rects.is_empty(),
            "{what}: empty table"
        );
    }

    #[test]
    fn binned_table_is_the_broad_phase_table() {
        use crate::{Sample, Scenario, TaskConfig};
        assert_broad_phase_table(box_scene().rects, DEFAULT_QUERY_MARGIN, "the box scene");
        let examples = [
            include_str!("../../../scenarios/examples/t_maze.toml"),
            include_str!("../../../scenarios/examples/triple_t_maze.toml"),
            include_str!("../../../scenarios/examples/cross_yard.toml"),
            include_str!("../../../scenarios/examples/room_to_yard.toml"),
            include_str!("../../../scenarios/examples/room_to_corridor.toml"),
            include_str!("../../../scenarios/examples/find_wanderer.toml"),
        ];
        let mut tasks: Vec<TaskConfig> = Scenario::shipped_names()
            .into_iter()
            .map(|name| TaskConfig::shipped(name).expect("shipped"))
            .collect();
        for text in examples {
            let scenario = Scenario::parse(text, "example.toml").expect("the example compiles");
            tasks.push(TaskConfig::from_scenario(std::sync::Arc::new(scenario)));
        }
        for task in tasks {
            let evaluator = crate::Evaluator::new(task.clone()).expect("valid");
            for seed in 0..6 {
                let env = evaluator.environment(Sample::seeded(seed));
                let what = format!("{} seed {seed}", task.name());
                assert_broad_phase_table(
                    env.scene.rects.clone(),
                    task.params.query_margin(),
                    &what,
                );
            }
        }
    }

    proptest::proptest! {
        /// Random rectangles, rotated or not, at any margin: lists touching at an edge, boxes
        /// beyond the grid's border and cells with nothing near them included.
        #[test]
        fn binned_table_is_the_broad_phase_table_for_random_rectangles(
            rects in proptest::collection::vec(
                (-2.0f32..2.0, -2.0f32..2.0, 0.005f32..0.6, 0.005f32..0.6, 0u8..3, -3.2f32..3.2),
                0..24,
            ),
            margin in 0.0f32..0.4,
        ) {
            let rects = rects
                .into_iter()
                .map(|(x, y, hx, hy, kind, angle)| Rect {
                    center: [x, y],
                    half_extents: [hx, hy],
                    // Walls are axis-aligned; obstacles may turn.
                    angle: if kind == 0 { 0.0 } else { angle },
                    kind: if kind == 0 { RectKind::Wall } else { RectKind::Obstacle },
                })
                .collect();
            let scene = Scene::new(rects, margin);
            let (cell_ranges, candidates) = broad_phase_table(&scene, margin);
            proptest::prop_assert_eq!(&scene.cell_ranges, &cell_ranges);
            proptest::prop_assert_eq!(&scene.candidates, &candidates);
        }
    }

    proptest::proptest! {
        /// Which list a query reads does not change its answer, as long as the list holds
        /// every solid within the margin: the cell's own, a neighbour's for a point a hair from
        /// their border (the cell lookup multiplies where the table's borders were made by
        /// multiplying the other way), or every solid. Robot-sized discs and the IR cones of
        /// the shipped e-puck, at random poses in the shipped worlds.
        #[test]
        fn any_list_covering_the_margin_gives_the_same_answer(
            task_idx in 0usize..7,
            seed in 0u64..1000,
            at in (-2.0f32..2.0, -2.0f32..2.0, -3.2f32..3.2),
            border_nudge in proptest::option::of(0u8..4),
        ) {
            use crate::sensors::IR_ANGLES;
            use crate::{Sample, Scenario, TaskConfig};
            let name = Scenario::shipped_names()[task_idx % Scenario::shipped_names().len()];
            let task = TaskConfig::shipped(name).expect("shipped");
            let evaluator = crate::Evaluator::new(task.clone()).expect("valid");
            let env = evaluator.environment(Sample::seeded(seed));
            let scene = &env.scene;
            let grid = &scene.grid;
            // A point in the world, or one moved onto the nearest cell border.
            let mut point = [env.start.x + at.0, env.start.y + at.1];
            if let Some(side) = border_nudge {
                let axis = usize::from(side / 2);
                let cells = ((point[axis] - grid.origin[axis]) / GRID_CELL).round();
                point[axis] = grid.origin[axis] + cells * GRID_CELL;
                if side % 2 == 1 {
                    point[axis] = point[axis].next_up();
                }
            }
            let radius = task.params.robot.radius;
            let (sin_h, cos_h) = at.2.sin_cos();
            let cones = ConeLanes::new(&IR_ANGLES.map(|angle| Cone::new(angle, task.params.ir.cone_deg.to_radians())))
                .rotated(sin_h, cos_h);
            let origins = [
                IR_ANGLES.map(|a| point[0] + radius * (at.2 + a).cos()),
                IR_ANGLES.map(|a| point[1] + radius * (at.2 + a).sin()),
            ];
            let range = task.params.ir.range_m;
            let bits = |d: [Option<f32>; 4]| d.map(|d| d.map(f32::to_bits));
            let all = &scene.all_solids;
            let expected_cones = bits(scene.cone_lane_distances_among(all, &origins, &cones, range));
            let expected_disc = scene.disc_hits_among(all, point, radius);
            proptest::prop_assert_eq!(bits(scene.cone_lane_distances(point, &origins, &cones, range)), expected_cones);
            proptest::prop_assert_eq!(scene.disc_hits(point, radius), expected_disc);
            // Every cell the point lies in or within a hair of.
            let hair = 1e-4;
            for dx in [-hair, 0.0, hair] {
                for dy in [-hair, 0.0, hair] {
                    let list = scene.near([point[0] + dx, point[1] + dy]);
                    proptest::prop_assert_eq!(
                        bits(scene.cone_lane_distances_among(list, &origins, &cones, range)),
                        expected_cones
                    );
                    proptest::prop_assert_eq!(scene.disc_hits_among(list, point, radius), expected_disc);
                }
            }
        }
    }

    fn box_scene() -> Scene {
        // A 1 m square room with 0.1 m walls and one rotated obstacle.
        let mut rects = vec![
            Rect::from_corners(RectKind::Wall, -0.6, -0.6, 0.6, -0.5),
            Rect::from_corners(RectKind::Wall, -0.6, 0.5, 0.6, 0.6),
            Rect::from_corners(RectKind::Wall, -0.6, -0.6, -0.5, 0.6),
            Rect::from_corners(RectKind::Wall, 0.5, -0.6, 0.6, 0.6),
        ];
        rects.push(Rect {
            center: [0.2, 0.2],
            half_extents: [0.05, 0.02],
            angle: 0.7,
            kind: RectKind::Obstacle,
        });
        Scene::new(rects, DEFAULT_QUERY_MARGIN)
    }

    #[test]
    fn rays_measure_the_distance_to_the_nearest_wall() {
        let scene = box_scene();
        let down = Cone::new(-std::f32::consts::FRAC_PI_2, 70f32.to_radians());
        let d = scene.cone_distance([0.0, -0.4], [0.0, -0.4], &down, 0.14);
        assert!((d.unwrap() - 0.1).abs() < 1e-5, "{d:?}");
        // Out of range: nothing.
        assert_eq!(
            scene.cone_distance([0.0, 0.0], [0.0, 0.0], &down, 0.14),
            None
        );
        // A wall beside the cone but not in it is not seen; one at the cone's edge is, at the
        // distance along the boundary ray.
        let left = Cone::new(std::f32::consts::PI, 70f32.to_radians());
        let d = scene.cone_distance([-0.45, -0.2], [-0.45, -0.2], &left, 0.14);
        assert!((d.unwrap() - 0.05).abs() < 1e-5);
        let narrow = Cone::new(0.0, 20f32.to_radians());
        // From (0.4, -0.45) looking +x: the east wall at x = 0.5 is 0.1 away, inside the cone.
        let d = scene
            .cone_distance([0.4, -0.45], [0.4, -0.45], &narrow, 0.14)
            .unwrap();
        assert!((d - 0.1).abs() < 1e-5, "{d}");
    }

    #[test]
    fn disc_test_agrees_with_geometry() {
        let scene = box_scene();
        assert!(!scene.disc_hits([0.0, 0.0], 0.0375));
        assert!(scene.disc_hits([0.0, 0.47], 0.0375));
        assert!(!scene.disc_hits([0.0, 0.46], 0.0375));
        // Rotated obstacle: its centre is inside, a point a little off its long axis too.
        assert!(scene.disc_hits([0.2, 0.2], 0.01));
        assert!(!scene.disc_hits([0.2, 0.32], 0.0375));
    }

    /// Brute force with parry: the nearest hit over a dense fan of rays filling the cone. The
    /// exact cone distance is never larger, and a dense fan comes within a hair of it.
    #[test]
    fn cone_distance_matches_a_dense_parry_ray_fan() {
        let scene = box_scene();
        let opening = 70f32.to_radians();
        for ix in 0..40 {
            for iy in 0..40 {
                for heading_idx in 0..8 {
                    let p = [-0.49 + ix as f32 * 0.025, -0.49 + iy as f32 * 0.025];
                    let heading = heading_idx as f32 * std::f32::consts::TAU / 8.0 + 0.1;
                    let cone = Cone::new(heading, opening);
                    let fast = scene.cone_distance(p, p, &cone, 0.14);
                    let mut fan: Option<f32> = None;
                    for rect in scene.rects() {
                        let cuboid =
                            Cuboid::new(Vector::new(rect.half_extents[0], rect.half_extents[1]));
                        for k in 0..=400 {
                            let a = heading - 0.5 * opening + opening * k as f32 / 400.0;
                            let ray =
                                Ray::new(Vector::new(p[0], p[1]), Vector::new(a.cos(), a.sin()));
                            if let Some(t) = cuboid.cast_ray(&rect.pose(), &ray, 0.14, true) {
                                fan = Some(fan.map_or(t, |b: f32| b.min(t)));
                            }
                        }
                    }
                    match (fast, fan) {
                        (None, None) => {}
                        (Some(a), Some(b)) => assert!(
                            a <= b + 1e-5 && b - a < 2e-3,
                            "at {p:?} heading {heading}: {a} vs fan {b}"
                        ),
                        (Some(a), None) => {
                            assert!(a > 0.139, "at {p:?}: {a} but the fan saw nothing")
                        }
                        (None, Some(b)) => panic!("at {p:?}: fan hit at {b}, exact saw nothing"),
                    }
                }
            }
        }
    }

    /// Asserts that the lane code gives every cone the reference's distance, bit for bit, and
    /// returns how many cones saw a solid.
    fn assert_lanes_match_reference(
        scene: &Scene,
        near: [f32; 2],
        origins: &[[f32; 2]; 4],
        cones: &[Cone; 4],
    ) -> usize {
        let lanes = scene.cone_distances(near, origins, cones, 0.14);
        let mut seen = 0;
        for sensor in 0..4 {
            let one = reference(scene, near, origins[sensor], &cones[sensor], 0.14);
            assert_eq!(
                lanes[sensor].map(f32::to_bits),
                one.map(f32::to_bits),
                "scene {:?}, near {near:?}, origin {:?}, sensor {sensor}",
                scene.rects(),
                origins[sensor]
            );
            seen += usize::from(one.is_some());
        }
        seen
    }

    /// The lane code against the one-cone reference, bit for bit, on random scenes of
    /// axis-aligned walls and rotated obstacles, from random robot poses with the e-puck's
    /// four sensor cones (and cones along the axes, whose inverse directions are infinite).
    #[test]
    fn lanes_give_the_reference_distances_bit_for_bit() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(29);
        let mut compared = 0usize;
        let mut seen = 0usize;
        for _ in 0..200 {
            let mut rects = Vec::new();
            for _ in 0..rng.random_range(1..12) {
                let (x, y) = (rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6));
                let (w, h) = (rng.random_range(0.005..0.4), rng.random_range(0.005..0.4));
                let rect = if rng.random_bool(0.7) {
                    Rect::from_corners(RectKind::Wall, x, y, x + w, y + h)
                } else {
                    Rect {
                        center: [x, y],
                        half_extents: [w * 0.5, h * 0.5],
                        angle: rng.random_range(-3.2..3.2),
                        kind: RectKind::Obstacle,
                    }
                };
                rects.push(rect);
            }
            let scene = Scene::new(rects, DEFAULT_QUERY_MARGIN);
            for _ in 0..200 {
                let centre = [rng.random_range(-0.7..0.7), rng.random_range(-0.7..0.7)];
                let heading: f32 = if rng.random_bool(0.1) {
                    std::f32::consts::FRAC_PI_2 * rng.random_range(0..4) as f32
                } else {
                    rng.random_range(-3.2..3.2)
                };
                let opening = if rng.random_bool(0.2) {
                    0.0
                } else {
                    70f32.to_radians()
                };
                let angles = [0.3f32, 0.8, -0.8, -0.3];
                let cones =
                    angles.map(|a| Cone::new(a, opening).rotated(heading.sin(), heading.cos()));
                let origins = angles.map(|a| {
                    let r = if rng.random_bool(0.1) { 0.0 } else { 0.0375 };
                    [
                        centre[0] + r * (heading + a).cos(),
                        centre[1] + r * (heading + a).sin(),
                    ]
                });
                seen += assert_lanes_match_reference(&scene, centre, &origins, &cones);
                compared += 4;
            }
        }
        // The comparison means something only if many cones see a solid.
        assert!(
            seen * 5 > compared,
            "{seen} of {compared} cones saw a solid"
        );
    }

    /// Rays along a face: cones pointing exactly along +x (inverse direction infinite in y)
    /// from origins exactly on the faces' lines of dyadic walls, where a slab bound is
    /// 0 * inf = NaN and must be dropped as `f32::min` drops it.
    #[test]
    fn lanes_drop_nan_slab_bounds_as_the_reference_does() {
        let eighth = |k: i32| k as f32 * 0.125;
        let rects = vec![
            Rect::from_corners(RectKind::Wall, eighth(1), eighth(-1), eighth(2), eighth(1)),
            Rect::from_corners(RectKind::Wall, eighth(-2), eighth(1), eighth(2), eighth(2)),
            Rect::from_corners(
                RectKind::Wall,
                eighth(-1),
                eighth(-3),
                eighth(3),
                eighth(-2),
            ),
        ];
        let scene = Scene::new(rects, DEFAULT_QUERY_MARGIN);
        let along_x = Cone::new(0.0, 0.0);
        assert_eq!(along_x.boundaries[0], [1.0, 0.0]);
        let mut seen = 0;
        for ix in -16..16 {
            for iy in -24..24 {
                let origin = [ix as f32 / 64.0, iy as f32 / 64.0];
                let cones = [along_x, Cone::new(0.0, 0.4), along_x, along_x];
                let origins = [
                    origin,
                    origin,
                    [origin[0], eighth(1)],
                    [origin[0], eighth(-1)],
                ];
                seen += assert_lanes_match_reference(&scene, origin, &origins, &cones);
            }
        }
        assert!(seen > 100, "{seen}");
    }
}
