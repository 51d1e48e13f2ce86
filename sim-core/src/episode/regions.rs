//! The named regions of one sample's world, as rectangles in metres, for pictures
//! (`hevo scenario draw`): the map legend's regions cell by cell, what the generators provide
//! (`room`, `room.exit`, `corridor.start`, `corridor.end`) and the scenario's own rectangles.
//! The shapes are the ones the judge tests: a map region is its whole cells (`in REGION` asks
//! which cell the robot's centre is in), `room` the room's interior.

use crate::task::TaskConfig;
use crate::world::Environment;

/// A named region: its name, as conditions spell it, and the rectangles `[x0, y0, x1, y1]` it
/// covers, metres.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedRegion {
    /// The name.
    pub name: String,
    /// Axis-aligned rectangles, `[x0, y0, x1, y1]`, x0 < x1 and y0 < y1.
    pub rects: Vec<[f32; 4]>,
}

/// Every named region of `env`, a sample of `task`: the map's in name order, then the
/// generators', then the scenario's rectangles. A region the sample's world lacks (a room
/// that was not generated) is left out.
pub fn named_regions(task: &TaskConfig, env: &Environment) -> Vec<NamedRegion> {
    let scenario = &task.scenario;
    let mut regions = Vec::new();
    if let (Some(map), Some(cells)) = (&scenario.map, &env.ground.cells) {
        for (name, members) in &map.regions {
            let rects = members
                .iter()
                .filter(|&&cell| cell < cells.cells.len())
                .map(|&cell| cell_square(cells.center(cell), cells.cell_size))
                .collect();
            regions.push(NamedRegion {
                name: name.clone(),
                rects,
            });
        }
    }
    if let Some(room) = &env.ground.room {
        // `size` is the width along the exit wall, then the depth.
        let along_x = room.exit_outward[1].abs() > room.exit_outward[0].abs();
        let [w, d] = room.size;
        let (half_x, half_y) = if along_x {
            (0.5 * w, 0.5 * d)
        } else {
            (0.5 * d, 0.5 * w)
        };
        regions.push(NamedRegion {
            name: "room".into(),
            rects: vec![[
                room.center[0] - half_x,
                room.center[1] - half_y,
                room.center[0] + half_x,
                room.center[1] + half_y,
            ]],
        });
        // The exit: the gap in the wall, from its inner face through the wall.
        let half_gap = 0.5 * task.params.room.exit_width;
        let thick = task.params.room.wall_thickness;
        let [ox, oy] = room.exit_outward;
        let [cx, cy] = room.exit_center;
        let far = [cx + thick * ox, cy + thick * oy];
        let (side_x, side_y) = (-oy * half_gap, ox * half_gap);
        let xs = [cx + side_x, cx - side_x, far[0] + side_x, far[0] - side_x];
        let ys = [cy + side_y, cy - side_y, far[1] + side_y, far[1] - side_y];
        regions.push(NamedRegion {
            name: "room.exit".into(),
            rects: vec![[
                xs.iter().copied().fold(f32::INFINITY, f32::min),
                ys.iter().copied().fold(f32::INFINITY, f32::min),
                xs.iter().copied().fold(f32::NEG_INFINITY, f32::max),
                ys.iter().copied().fold(f32::NEG_INFINITY, f32::max),
            ]],
        });
    }
    if scenario.world.has_corridor()
        && let Some(goal) = &env.ground.goal
    {
        // A generated corridor's cells follow the map's, if any: the first is its start.
        let size = goal.map.cell_size;
        let start = scenario.map.as_ref().map_or(0, |map| map.map.cells.len());
        for (name, cell) in [("corridor.start", start), ("corridor.end", goal.goal)] {
            if cell < goal.map.cells.len() {
                regions.push(NamedRegion {
                    name: name.into(),
                    rects: vec![cell_square(goal.map.center(cell), size)],
                });
            }
        }
    }
    for (name, rect) in &scenario.rect_regions {
        regions.push(NamedRegion {
            name: name.clone(),
            rects: vec![*rect],
        });
    }
    regions.retain(|region| !region.rects.is_empty());
    regions
}

fn cell_square(center: [f32; 2], size: f32) -> [f32; 4] {
    let half = 0.5 * size;
    [
        center[0] - half,
        center[1] - half,
        center[0] + half,
        center[1] + half,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::setup::{Statics, build};
    use crate::math::rng::{Stream, stream_rng};

    fn regions_of(name: &str, seed: u64) -> Vec<NamedRegion> {
        let task = TaskConfig::shipped(name).unwrap();
        let env = build(
            &task,
            &Statics::new(&task),
            Some(0),
            &mut stream_rng(seed, Stream::Environment),
        );
        named_regions(&task, &env)
    }

    fn names(regions: &[NamedRegion]) -> Vec<&str> {
        regions.iter().map(|r| r.name.as_str()).collect()
    }

    #[test]
    fn the_rescue_has_the_maze_regions_and_the_room() {
        let regions = regions_of("rescue", 3);
        let mut got = names(&regions);
        got.sort();
        assert_eq!(
            got,
            [
                "branch_a",
                "branch_b",
                "branch_c",
                "branch_d",
                "entrance",
                "room",
                "room.exit"
            ]
        );
        // The double T-maze's entrance is the cell (0, -5) of 0.30 m cells.
        let entrance = regions.iter().find(|r| r.name == "entrance").unwrap();
        let [x0, y0, x1, y1] = entrance.rects[0];
        assert!((x0 + 0.15).abs() < 1e-5 && (x1 - 0.15).abs() < 1e-5);
        assert!((y0 + 1.65).abs() < 1e-5 && (y1 + 1.35).abs() < 1e-5);
        // The room lies below the entrance and its exit on the room's top face, under it.
        let room = regions.iter().find(|r| r.name == "room").unwrap().rects[0];
        let exit = regions
            .iter()
            .find(|r| r.name == "room.exit")
            .unwrap()
            .rects[0];
        assert!(room[3] <= y0 + 1e-4, "room {room:?} entrance {entrance:?}");
        // The exit is the gap, `room.exit_width` wide, through the wall of the map's border.
        let half_gap = 0.5
            * TaskConfig::shipped("rescue")
                .unwrap()
                .params
                .room
                .exit_width;
        assert!((exit[0] + half_gap).abs() < 1e-4, "{exit:?}");
        assert!((exit[2] - half_gap).abs() < 1e-4, "{exit:?}");
        assert!((exit[1] - room[3]).abs() < 1e-4, "{exit:?} {room:?}");
        assert!((exit[3] - (y0 + 0.05)).abs() < 1e-4, "{exit:?}");
    }

    #[test]
    fn a_corridor_has_its_start_and_end_cells() {
        let regions = regions_of("turn_left", 1);
        assert_eq!(names(&regions), ["corridor.start", "corridor.end"]);
        let start = regions[0].rects[0];
        // The first cell is centred on the origin.
        assert!((start[0] + 0.15).abs() < 1e-5 && (start[3] - 0.15).abs() < 1e-5);
        assert_ne!(regions[0].rects, regions[1].rects);
    }
}
