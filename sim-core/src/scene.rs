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
use rapier2d::parry::query::{DefaultQueryDispatcher, PointQuery, Ray, RayCast};
use rapier2d::parry::shape::Cuboid;
use rapier2d::prelude::{
    BroadPhaseBvh, ColliderBuilder, ColliderSet, IntegrationParameters,
    QueryFilter, RigidBodySet,
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

/// One rectangle in the hot-path layout: the parry shape, its pose and its box.
#[derive(Debug, Clone)]
struct Solid {
    cuboid: Cuboid,
    pose: Pose,
    aabb: Aabb,
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

impl Scene {
    /// Builds the scene: inserts every rectangle into rapier as a static collider, then asks
    /// rapier's query pipeline, once per grid cell, which rectangles lie within `query_margin`
    /// of that cell. `query_margin` must cover the robot radius plus the IR range.
    pub fn new(rects: Vec<Rect>, query_margin: f32) -> Scene {
        let solids: Vec<Solid> = rects
            .iter()
            .map(|rect| {
                let cuboid = Cuboid::new(Vector::new(rect.half_extents[0], rect.half_extents[1]));
                let pose = rect.pose();
                let aabb = cuboid.aabb(&pose);
                Solid { cuboid, pose, aabb }
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
        let query = broad_phase.as_query_pipeline(
            &dispatcher,
            &bodies,
            &colliders,
            QueryFilter::default(),
        );
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
                && solid.cuboid.distance_to_point(&solid.pose, point, true) < radius
        })
    }

    /// The shortest distance, within `max_distance`, from `origin` to a solid along any of the
    /// given unit `directions` (a sensor cone sampled by rays). `near` is a point whose grid
    /// cell covers the origin (the robot's centre). Returns `None` when no ray hits.
    pub fn cone_distance(
        &self,
        near: [f32; 2],
        origin: [f32; 2],
        directions: &[[f32; 2]],
        max_distance: f32,
    ) -> Option<f32> {
        // The box of all ray segments: a solid outside it cannot be hit by any ray.
        let (mut lo, mut hi) = (origin, origin);
        for dir in directions {
            for axis in 0..2 {
                let end = origin[axis] + dir[axis] * max_distance;
                lo[axis] = lo[axis].min(end);
                hi[axis] = hi[axis].max(end);
            }
        }
        let mut best = max_distance;
        let mut hit = false;
        for &solid_idx in self.near(near) {
            let solid = &self.solids[solid_idx as usize];
            if solid.aabb.maxs.x < lo[0]
                || solid.aabb.mins.x > hi[0]
                || solid.aabb.maxs.y < lo[1]
                || solid.aabb.mins.y > hi[1]
            {
                continue;
            }
            for dir in directions {
                let ray = Ray::new(
                    Vector::new(origin[0], origin[1]),
                    Vector::new(dir[0], dir[1]),
                );
                if let Some(toi) = solid.cuboid.cast_ray(&solid.pose, &ray, best, true) {
                    best = toi;
                    hit = true;
                }
            }
        }
        hit.then_some(best)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let d = scene.cone_distance([0.0, -0.4], [0.0, -0.4], &[[0.0, -1.0]], 0.14);
        assert!((d.unwrap() - 0.1).abs() < 1e-5, "{d:?}");
        // Out of range: nothing.
        assert_eq!(scene.cone_distance([0.0, 0.0], [0.0, 0.0], &[[0.0, -1.0]], 0.14), None);
        // The nearest of several rays wins.
        let dirs = [[0.0, -1.0], [-1.0, 0.0]];
        let d = scene.cone_distance([-0.45, -0.3], [-0.45, -0.3], &dirs, 0.14);
        assert!((d.unwrap() - 0.05).abs() < 1e-5);
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

    #[test]
    fn grid_lookup_matches_brute_force_everywhere() {
        let scene = box_scene();
        let dirs: Vec<[f32; 2]> = (0..16)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 16.0;
                [a.cos(), a.sin()]
            })
            .collect();
        for ix in 0..40 {
            for iy in 0..40 {
                let p = [-0.49 + ix as f32 * 0.025, -0.49 + iy as f32 * 0.025];
                let fast = scene.cone_distance(p, p, &dirs, 0.14);
                // Brute force: every solid.
                let mut best: Option<f32> = None;
                for solid in &scene.solids {
                    for dir in &dirs {
                        let ray = Ray::new(Vector::new(p[0], p[1]), Vector::new(dir[0], dir[1]));
                        if let Some(t) = solid.cuboid.cast_ray(&solid.pose, &ray, 0.14, true) {
                            best = Some(best.map_or(t, |b: f32| b.min(t)));
                        }
                    }
                }
                assert_eq!(fast, best, "at {p:?}");
            }
        }
    }
}
