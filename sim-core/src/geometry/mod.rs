//! Geometry: the solids of a world (rectangles and the scene that answers distance, ray and
//! overlap queries about them) and worlds made of square cells (walls, neighbours, paths and
//! corridor distances), the robots of a sample found by place (`crowd.rs`), the movers and
//! boxes robots must not overlap (`bodies.rs`), the movable
//! items robots pick up and deliver (`items.rs`), and the floor a robot can reach from its
//! start (`reach.rs`).

pub mod bodies;
pub mod cells;
pub mod crowd;
pub mod items;
pub mod reach;
pub mod scene;

/// Whether the rectangle `[x0, y0, x1, y1]` holds `point`, its edges included: what `in REGION`
/// and a light triggered by entering a region both test.
#[inline]
pub fn rect_holds([x0, y0, x1, y1]: [f32; 4], [x, y]: [f32; 2]) -> bool {
    (x0..=x1).contains(&x) && (y0..=y1).contains(&y)
}
