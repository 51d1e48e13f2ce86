//! The static scene of one sample: walls and obstacles as rectangles, stored as rapier2d static
//! colliders, plus a per-cell table of candidate rectangles built once when the scene is made.
//!
//! Why the table: one rapier `QueryPipeline::cast_ray` costs about 113 ns here, and a control
//! cycle casts 28 IR rays, which would cap the simulator near 300 thousand cycles per second.
//! So rapier is the scene store and answers the broad query once per grid cell at load
//! (`intersect_aabb_conservative`); the hot path then looks up the robot's cell, keeps the
//! rectangles whose box meets a sensor cone's box, and runs concrete parry `Cuboid` ray casts and
//! point-distance tests against just those.

use rapier2d::math::{Pose, Vector};
use rapier2d::parry::bounding_volume::{Aabb, BoundingVolume};
use rapier2d::parry::query::DefaultQueryDispatcher;
use rapier2d::parry::shape::Cuboid;
use rapier2d::prelude::{
    BroadPhaseBvh, ColliderBuilder, ColliderSet, IntegrationParameters, QueryFilter, RigidBodySet,
};
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
        self.half_extents[0].hypot(self.half_extents[1])
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

    /// A direction in the rectangle's frame.
    #[inline(always)]
    fn dir_to_local(&self, d: [f32; 2]) -> [f32; 2] {
        if self.axis_aligned {
            return d;
        }
        [
            self.axis[0] * d[0] + self.axis[1] * d[1],
            -self.axis[1] * d[0] + self.axis[0] * d[1],
        ]
    }

    /// Slab test of a ray against the rectangle, in its frame: the ray's local origin and the
    /// component-wise inverse of its local direction. Returns the entry distance (0 when the
    /// origin is inside) if the ray meets the rectangle before `max`.
    #[inline(always)]
    fn slab(&self, o: [f32; 2], inverse: [f32; 2], max: f32) -> Option<f32> {
        let tx1 = (-self.half[0] - o[0]) * inverse[0];
        let tx2 = (self.half[0] - o[0]) * inverse[0];
        let ty1 = (-self.half[1] - o[1]) * inverse[1];
        let ty2 = (self.half[1] - o[1]) * inverse[1];
        // f32 min/max drop a NaN operand (0 * inf for a ray along a face), which is what a
        // slab test wants.
        let enter = tx1.min(tx2).max(ty1.min(ty2)).max(0.0);
        let exit = tx1.max(tx2).min(ty1.max(ty2));
        (exit >= enter && enter < max).then_some(enter)
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
    /// Lower-left corner of the grid, metres.
    grid_origin: [f32; 2],
    grid_cell: f32,
    grid_nx: usize,
    grid_ny: usize,
    /// For each cell, the range of `candidates` that lists the solids near it.
    cell_ranges: Vec<(u32, u32)>,
    candidates: Vec<u16>,
    /// Every solid, for a query from outside the grid (never on a legal trajectory).
    all_solids: Vec<u16>,
}

/// The distance beyond a cell that its candidate list must cover: the robot's body, the IR
/// range beyond the body and one cycle's worth of movement, with room to spare.
pub const DEFAULT_QUERY_MARGIN: f32 = 0.25;
const GRID_CELL: f32 = 0.1;

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

impl Scene {
    /// Builds the scene: inserts every rectangle into rapier as a static collider, then asks
    /// rapier's query pipeline, once per grid cell, which rectangles lie within `query_margin`
    /// of that cell. `query_margin` must cover the robot radius plus the IR range.
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

        // rapier holds the scene: colliders without a parent body are static.
        let bodies = RigidBodySet::new();
        let mut colliders = ColliderSet::new();
        let mut broad_phase = BroadPhaseBvh::new();
        let params = IntegrationParameters::default();
        let mut handle_to_solid = Vec::new();
        for (solid_idx, rect) in rects.iter().enumerate() {
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

        let (mut min, mut max) = ([f32::MAX; 2], [f32::MIN; 2]);
        for solid in &solids {
            for axis in 0..2 {
                min[axis] = min[axis].min(solid.aabb.mins[axis]);
                max[axis] = max[axis].max(solid.aabb.maxs[axis]);
            }
        }
        if solids.is_empty() {
            (min, max) = ([0.0; 2], [0.0; 2]);
        }
        let grid_nx = (((max[0] - min[0]) / GRID_CELL).ceil() as usize).max(1);
        let grid_ny = (((max[1] - min[1]) / GRID_CELL).ceil() as usize).max(1);

        let dispatcher = DefaultQueryDispatcher;
        let query =
            broad_phase.as_query_pipeline(&dispatcher, &bodies, &colliders, QueryFilter::default());
        let mut cell_ranges = Vec::with_capacity(grid_nx * grid_ny);
        let mut candidates = Vec::new();
        for iy in 0..grid_ny {
            for ix in 0..grid_nx {
                let x0 = min[0] + ix as f32 * GRID_CELL;
                let y0 = min[1] + iy as f32 * GRID_CELL;
                let cell_box = Aabb::new(
                    Vector::new(x0 - query_margin, y0 - query_margin),
                    Vector::new(x0 + GRID_CELL + query_margin, y0 + GRID_CELL + query_margin),
                );
                let start = candidates.len() as u32;
                let mut here: Vec<u16> = query
                    .intersect_aabb_conservative(cell_box)
                    .map(|(handle, _)| handle_to_solid[handle.into_raw_parts().0 as usize])
                    // The broad phase fattens its boxes, so keep only true box overlaps.
                    .filter(|&solid_idx| solids[solid_idx as usize].aabb.intersects(&cell_box))
                    .collect();
                // Sorted lists make every query visit solids in one order: determinism does
                // not hang on the BVH's internal layout.
                here.sort_unstable();
                candidates.extend(here);
                cell_ranges.push((start, candidates.len() as u32));
            }
        }

        Scene {
            all_solids: (0..solids.len() as u16).collect(),
            rects,
            solids,
            grid_origin: min,
            grid_cell: GRID_CELL,
            grid_nx,
            grid_ny,
            cell_ranges,
            candidates,
        }
    }

    /// Every rectangle of the scene, in insertion order.
    pub fn rects(&self) -> &[Rect] {
        &self.rects
    }

    /// The solids that may lie within the query margin of `point`.
    #[inline]
    fn near(&self, point: [f32; 2]) -> &[u16] {
        let fx = (point[0] - self.grid_origin[0]) / self.grid_cell;
        let fy = (point[1] - self.grid_origin[1]) / self.grid_cell;
        if fx < 0.0 || fy < 0.0 || fx >= self.grid_nx as f32 || fy >= self.grid_ny as f32 {
            return &self.all_solids;
        }
        let (start, end) = self.cell_ranges[fy as usize * self.grid_nx + fx as usize];
        &self.candidates[start as usize..end as usize]
    }

    /// Whether a disc of `radius` centred at `center` overlaps any solid.
    pub fn disc_hits(&self, center: [f32; 2], radius: f32) -> bool {
        let point = Vector::new(center[0], center[1]);
        self.near(center).iter().any(|&solid_idx| {
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
            self.cone_distances(near, &[origin], std::slice::from_ref(cone), max_distance);
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
        cones: &[Cone],
        max_distance: f32,
    ) -> [Option<f32>; N] {
        let mut best = [max_distance; N];
        let mut hit = [false; N];
        for &solid_idx in self.near(near) {
            let solid = &self.solids[solid_idx as usize];
            for ((origin, cone), (best, hit)) in origins
                .iter()
                .zip(cones)
                .zip(best.iter_mut().zip(hit.iter_mut()))
            {
                if let Some(distance) = solid.cone_distance(*origin, cone, *best) {
                    *best = distance;
                    *hit = true;
                }
            }
        }
        std::array::from_fn(|idx| hit[idx].then_some(best[idx]))
    }
}

impl Solid {
    /// The distance from `origin` to the solid's nearest point inside `cone`, if it is below
    /// `best`, the nearest found so far (see [`Scene::cone_distance`]).
    #[inline(always)]
    fn cone_distance(&self, origin: [f32; 2], cone: &Cone, best: f32) -> Option<f32> {
        let solid = self;
        let mut best = best;
        let mut hit = false;
        // Box reject: the cone lies within max_distance of its origin.
        if solid.aabb.maxs.x < origin[0] - best
            || solid.aabb.mins.x > origin[0] + best
            || solid.aabb.maxs.y < origin[1] - best
            || solid.aabb.mins.y > origin[1] + best
        {
            return None;
        }
        // Walls are axis-aligned: their frame is the world's shifted, so the helpers skip
        // the rotation and the boundary rays' inverse directions are the cone's own.
        let local_origin = solid.to_local(origin);
        let (offset, distance) = solid.nearest_offset(local_origin);
        if distance >= best {
            return None;
        }
        let axis = solid.dir_to_local(cone.axis);
        if offset[0] * axis[0] + offset[1] * axis[1] >= distance * cone.cos_half_angle {
            return Some(distance);
        }
        for (boundary, inverse) in cone.boundaries.iter().zip(&cone.inverse_boundaries) {
            let inverse = if solid.axis_aligned {
                *inverse
            } else {
                let d = solid.dir_to_local(*boundary);
                [1.0 / d[0], 1.0 / d[1]]
            };
            if let Some(toi) = solid.slab(local_origin, inverse, best) {
                best = toi;
                hit = true;
            }
        }
        hit.then_some(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rapier2d::parry::query::{PointQuery, Ray, RayCast};

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
}
