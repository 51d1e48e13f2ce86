//! Setting a sample's world up: from the task's scenario and the sample's environment stream
//! this builds the scene, the start pose, the teammate, the lights and the ground truth the
//! task judges against (the goal's cells and path, the room's exit). The draws come in one
//! order for every scenario: the variant (when there are several and the sample does not fix
//! one), the world's generators, the start anywhere in its region, the start's turn, its
//! jitter, its advance (each only when the scenario asks for it), then the team's other
//! robots, the items and the boxes, each only in a scenario that has them. Movers draw
//! nothing: their paths are the scenario's, and every robot, item and box is drawn clear of
//! their starts. Layouts that never change (a
//! fixed map) are built once per evaluator and shared ([`Statics`]).

use crate::body::Pose;
use crate::geometry::bodies::{Disc, MoverPath, overlaps_any};
use crate::geometry::cells::{self, CellMap};
use crate::geometry::items::ITEM_RADIUS;
use crate::geometry::scene::Scene;
use crate::math::rng::SimRng;
use crate::scenario::blocks::FixedLayout;
use crate::scenario::{Facing, PlaceAt, Scenario};
use crate::task::TaskConfig;
use crate::world::lights::LightSpec;
use crate::world::{CellGoal, Environment, Ground};
use rand::RngExt;
use std::f32::consts::PI;
use std::sync::Arc;

/// Geometry shared by all samples of an evaluator: built once.
#[derive(Debug)]
pub struct Statics {
    closed_map: Option<FixedLayout>,
}

impl Statics {
    /// Builds what never changes between samples of this task.
    pub fn new(task: &TaskConfig) -> Statics {
        let scenario = &task.scenario;
        let closed_map = scenario.world.statics(scenario, &task.params);
        Statics {
            closed_map: closed_map.map(|(scene, cells)| (with_solids(scene, task), cells)),
        }
    }
}

/// `scene` with the scenario's solid rectangles added after its own, or `scene` itself when
/// the scenario has none.
fn with_solids(scene: Arc<Scene>, task: &TaskConfig) -> Arc<Scene> {
    let solids = &task.scenario.solids;
    if solids.is_empty() {
        return scene;
    }
    let rects = scene.rects().iter().chain(solids).copied().collect();
    Arc::new(Scene::new(rects, task.params.query_margin()))
}

/// How often a start anywhere in its region is drawn again for touching a solid before it
/// falls back to the region's centre (which `Evaluator::check_starts` refuses if it touches).
const ANYWHERE_TRIES: u32 = 64;

/// A point drawn uniformly over a start region (`at`: a map region's cells, the variant's
/// start region or a `[regions]` rectangle) where a disc of `radius` (a robot's, an item's)
/// touches no wall or obstacle and `clear` holds (no other robot or item there).
#[allow(clippy::too_many_arguments)]
fn draw_anywhere(
    scenario: &Scenario,
    at: &PlaceAt,
    variant_start: Option<&str>,
    scene: &Scene,
    cells: Option<&CellMap>,
    radius: f32,
    rng: &mut SimRng,
    clear: impl Fn([f32; 2]) -> bool,
) -> [f32; 2] {
    let in_cells = |name: &str| {
        let cells = cells.expect("map regions are in cell worlds");
        let map = scenario.map.as_ref().expect("checked when compiled");
        (cells, map.regions[name].as_slice())
    };
    let region = match at {
        PlaceAt::Rect(rect) => Err(*rect),
        PlaceAt::Region(name) => Ok(in_cells(name)),
        _ => Ok(in_cells(variant_start.expect("checked when compiled"))),
    };
    let mut draw = || match region {
        Err([x0, y0, x1, y1]) => [rng.random_range(x0..=x1), rng.random_range(y0..=y1)],
        Ok((cells, of_region)) => {
            let center = cells.center(of_region[rng.random_range(0..of_region.len())]);
            let half = cells.cell_size / 2.0;
            [
                center[0] + rng.random_range(-half..=half),
                center[1] + rng.random_range(-half..=half),
            ]
        }
    };
    let fallback = match region {
        Err(rect) => rect_centre(&rect),
        Ok((cells, of_region)) => cells.center(of_region[0]),
    };
    (0..ANYWHERE_TRIES)
        .map(|_| draw())
        .find(|&at| !scene.disc_hits(at, radius) && clear(at))
        .unwrap_or(fallback)
}

/// The centre of a rectangle `[x0, y0, x1, y1]`.
fn rect_centre(rect: &[f32; 4]) -> [f32; 2] {
    [(rect[0] + rect[2]) / 2.0, (rect[1] + rect[3]) / 2.0]
}

/// The cell of a map region (its first cell).
fn region_cell(scenario: &Scenario, region: &str) -> usize {
    scenario
        .map
        .as_ref()
        .and_then(|map| map.regions.get(region))
        .map(|cells| cells[0])
        .expect("regions are checked when the scenario is compiled")
}

/// Builds the environment of one sample. `variant` fixes the variant; `None` draws it from
/// the stream when there are several.
pub fn build(
    task: &TaskConfig,
    statics: &Statics,
    variant: Option<u32>,
    rng: &mut SimRng,
) -> Environment {
    let scenario = &task.scenario;
    let n_variants = scenario.n_variants();
    let variant_idx = match variant {
        Some(v) => v.min(n_variants - 1),
        None if n_variants > 1 => rng.random_range(0..n_variants),
        None => 0,
    };
    let plan = &scenario.variants[variant_idx as usize];

    // The world: its scene, cells, room, and a generated corridor's path and shape.
    let built = scenario
        .world
        .build(scenario, &task.params, statics.closed_map.as_ref(), rng);
    let reported = built.shape.unwrap_or(variant_idx);
    // A fixed world's scene has the scenario's solids already; a generated one gets them now.
    let scene = match statics.closed_map {
        Some(_) => built.scene,
        None => with_solids(built.scene, task),
    };
    let (cells, room_made, corridor_path) = (built.cells, built.room, built.corridor_path);

    // Anywhere in the start region: drawn first, as the path starts from the cell drawn.
    let place = &scenario.place;
    // Robots, items and boxes are drawn clear of the movers' starts (none without movers: the
    // test then holds everywhere and the draws are as they were).
    let mover_starts: Vec<Disc> = scenario.movers.iter().map(MoverPath::start_disc).collect();
    let radius = task.params.robot.radius;
    let drawn = place.anywhere.then(|| {
        draw_anywhere(
            scenario,
            &scenario.place.at,
            plan.start.as_deref(),
            &scene,
            cells.as_deref(),
            radius,
            rng,
            |at| !overlaps_any(&mover_starts, at, radius),
        )
    });

    // The path from the start to the goal, in cells.
    let start_cell = |cells: &CellMap| -> Option<usize> {
        if let Some(at) = drawn {
            return cells.cell_at(at);
        }
        match &scenario.place.at {
            PlaceAt::Rect(rect) => cells.cell_at(rect_centre(rect)),
            PlaceAt::VariantStart => plan.start.as_deref().map(|r| region_cell(scenario, r)),
            PlaceAt::Region(region) => Some(region_cell(scenario, region)),
            PlaceAt::CorridorStart => corridor_path.as_ref().map(|p| p[0]),
            // From the room the robot enters the map at its entrance.
            PlaceAt::RoomStart => scenario
                .map
                .as_ref()
                .filter(|m| m.regions.contains_key("entrance"))
                .map(|_| region_cell(scenario, "entrance"))
                .filter(|&c| c < cells.cells.len()),
        }
    };
    let path: Option<Vec<usize>> = match (&corridor_path, &cells, &plan.goal) {
        // A corridor beyond a map: from the start, through the map, to the corridor's end.
        (Some(path), Some(cells), _) if scenario.map.is_some() => {
            start_cell(cells).and_then(|from| cells::path_between(cells, from, *path.last()?))
        }
        (Some(path), _, _) => Some(path.clone()),
        (None, Some(cells), Some(goal)) => start_cell(cells)
            .and_then(|from| cells::path_between(cells, from, region_cell(scenario, goal))),
        _ => None,
    };
    let goal = match (&cells, &path) {
        (Some(cells), Some(path)) => Some(CellGoal::new(cells.clone(), path)),
        _ => None,
    };

    // The start.
    let mut facing = (0.0f32, [0.0f32, 0.0]);
    let start = match &place.at {
        PlaceAt::RoomStart => room_made.as_ref().expect("a room world").start,
        _ => {
            let center = match (drawn, &place.at) {
                (Some(at), _) => at,
                (None, PlaceAt::Rect(rect)) => rect_centre(rect),
                _ => {
                    let cells = cells.as_ref().expect("cell starts are in cell worlds");
                    let from = match &path {
                        Some(path) => path[0],
                        None => start_cell(cells).expect("checked when compiled"),
                    };
                    cells.center(from)
                }
            };
            let mut heading = match place.facing.expect("checked when compiled") {
                Facing::Heading(heading) => heading,
                Facing::Path => {
                    let next = match (&cells, &path) {
                        (Some(cells), Some(path)) => path.get(1).map(|&c| cells.center(c)),
                        _ => None,
                    };
                    let next = next.unwrap_or(center);
                    (next[1] - center[1]).atan2(next[0] - center[0])
                }
            };
            // Drawn only when asked for, so tasks without a turn keep their draws.
            if let Some([from, to]) = place.turn {
                heading = (heading + rng.random_range(from..=to) + PI).rem_euclid(2.0 * PI) - PI;
            }
            let dir = [heading.cos(), heading.sin()];
            facing = (heading, dir);
            if drawn.is_some() {
                // Already drawn over its region: no stem jitter on top.
                Pose {
                    x: center[0],
                    y: center[1],
                    heading,
                }
            } else {
                let at = if place.ahead_m != 0.0 {
                    [
                        center[0] + place.ahead_m * dir[0],
                        center[1] + place.ahead_m * dir[1],
                    ]
                } else {
                    center
                };
                let mut start = stem_start(at, heading, task, rng);
                // Drawn only when asked for, so tasks without an advance keep their draws.
                if place.advance && task.params.corridor.start_advance > 0.0 {
                    start.y += rng.random_range(0.0..=task.params.corridor.start_advance);
                }
                start
            }
        }
    };

    // The teammate.
    let teammate = scenario.teammate.as_ref().map(|mate| {
        let pose = if mate.branch_end {
            teammate_at_branch_end(goal.as_ref().expect("checked when compiled"), task)
        } else if mate.centre {
            // The region's first cell, facing as the robot does (a wanderer draws its own).
            let region = match (&mate.region, mate.at_goal) {
                (Some(region), _) => Some(region),
                (None, true) => plan.goal.as_ref(),
                (None, false) => plan.start.as_ref(),
            };
            let cells = cells.as_ref().expect("cell worlds");
            let at = cells.center(region_cell(
                scenario,
                region.expect("checked when compiled"),
            ));
            Pose {
                x: at[0],
                y: at[1],
                heading: facing.0,
            }
        } else {
            let cells = cells.as_ref().expect("cell worlds");
            let end = match &path {
                Some(path) => cells.center(path[0]),
                None => start_cell(cells).map_or([start.x, start.y], |c| cells.center(c)),
            };
            let (heading, dir) = facing;
            Pose {
                x: end[0] - mate.behind_m * dir[0],
                y: end[1] - mate.behind_m * dir[1],
                heading,
            }
        };
        (pose, mate.following)
    });

    let lights = scenario
        .lights
        .iter()
        .zip(&plan.flashes)
        .map(|(light, &flashes)| LightSpec {
            position: light.position,
            flashes,
            trigger: light.trigger,
        })
        .collect();

    // The team's other robots: drawn last, so a scenario without them draws as it did.
    let mut team: Vec<Pose> = Vec::new();
    for group in &scenario.robot_groups {
        for _ in 0..group.count {
            let clear = |at: [f32; 2]| {
                std::iter::once(&start)
                    .chain(&team)
                    .all(|other| other.distance_to(at) >= 2.0 * radius)
                    && !overlaps_any(&mover_starts, at, radius)
            };
            let at = draw_anywhere(
                scenario,
                &group.region,
                plan.start.as_deref(),
                &scene,
                cells.as_deref(),
                radius,
                rng,
                clear,
            );
            let heading = rng.random_range(-PI..PI);
            team.push(Pose {
                x: at[0],
                y: at[1],
                heading,
            });
        }
    }

    // The items: drawn after the team, so a scenario without them draws as it did; each
    // clear of every robot (none is picked up before the first cycle) and of the items
    // before it.
    let mut items: Vec<[f32; 2]> = Vec::new();
    let robot_reach = radius + ITEM_RADIUS;
    for group in &scenario.object_groups {
        for _ in 0..group.count {
            let clear = |at: [f32; 2]| {
                std::iter::once(&start)
                    .chain(&team)
                    .all(|robot| robot.distance_to(at) > robot_reach)
                    && items.iter().all(|item| {
                        let (dx, dy) = (item[0] - at[0], item[1] - at[1]);
                        dx * dx + dy * dy >= (2.0 * ITEM_RADIUS) * (2.0 * ITEM_RADIUS)
                    })
                    && !overlaps_any(&mover_starts, at, ITEM_RADIUS)
            };
            let at = draw_anywhere(
                scenario,
                &group.region,
                plan.start.as_deref(),
                &scene,
                cells.as_deref(),
                ITEM_RADIUS,
                rng,
                clear,
            );
            items.push(at);
        }
    }

    // The boxes: drawn after the items, so a scenario without them draws as it did; each
    // clear of the walls (whatever its size), every robot, item and mover, and the boxes
    // before it.
    let mut boxes: Vec<Disc> = Vec::new();
    for group in &scenario.box_groups {
        for _ in 0..group.count {
            let box_radius = group.radius;
            let clear = |at: [f32; 2]| {
                !scene.disc_hits_wide(at, box_radius)
                    && std::iter::once(&start)
                        .chain(&team)
                        .all(|robot| robot.distance_to(at) >= radius + box_radius)
                    && items.iter().all(|item| {
                        let (dx, dy) = (item[0] - at[0], item[1] - at[1]);
                        let apart = ITEM_RADIUS + box_radius;
                        dx * dx + dy * dy >= apart * apart
                    })
                    && !overlaps_any(&mover_starts, at, box_radius)
                    && !overlaps_any(&boxes, at, box_radius)
            };
            let center = draw_anywhere(
                scenario,
                &group.region,
                plan.start.as_deref(),
                &scene,
                cells.as_deref(),
                box_radius,
                rng,
                clear,
            );
            boxes.push(Disc {
                center,
                radius: box_radius,
            });
        }
    }

    Environment {
        scene,
        start,
        teammate,
        team,
        items,
        boxes,
        lights,
        ground: Ground {
            room: room_made,
            goal,
            cells,
        },
        variant: reported,
    }
}

/// A start pose at a corridor cell: jittered sideways and in heading (SPEC is silent; the
/// amounts are config values).
fn stem_start(center: [f32; 2], heading: f32, task: &TaskConfig, rng: &mut SimRng) -> Pose {
    let lateral = task.params.start.lateral_offset;
    let jitter = task.params.start.heading_jitter_deg.to_radians();
    let offset = if lateral > 0.0 {
        rng.random_range(-lateral..=lateral)
    } else {
        0.0
    };
    let turn = if jitter > 0.0 {
        rng.random_range(-jitter..=jitter)
    } else {
        0.0
    };
    let side = [-(heading.sin()), heading.cos()];
    Pose {
        x: center[0] + offset * side[0],
        y: center[1] + offset * side[1],
        heading: (heading + turn + PI).rem_euclid(2.0 * PI) - PI,
    }
}

/// The teammate waits near the dead end of the goal branch.
fn teammate_at_branch_end(goal: &CellGoal, task: &TaskConfig) -> Pose {
    let end = goal.map.center(goal.goal);
    let before = goal
        .map
        .neighbours(goal.goal)
        .next()
        .map_or(end, |n| goal.map.center(n));
    let heading = (before[1] - end[1]).atan2(before[0] - end[0]);
    // Towards the dead end from the cell centre, clear of the end wall.
    let back =
        0.5 * goal.map.cell_size - 0.5 * goal.map.wall_thickness - task.params.robot.radius - 0.01;
    Pose {
        x: end[0] - back * heading.cos(),
        y: end[1] - back * heading.sin(),
        heading,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::MAZE_CELL_SIZE;
    use crate::math::rng::{Stream, stream_rng};

    /// How far along +y each of `n` samples' starts lie beyond their first cell's centre.
    fn start_advances(task: &TaskConfig, n: u64) -> Vec<f32> {
        let statics = Statics::new(task);
        (0..n)
            .map(|seed| {
                let env = build(
                    task,
                    &statics,
                    None,
                    &mut stream_rng(seed, Stream::Environment),
                );
                let Some(goal) = &env.ground.goal else {
                    panic!("corridor tasks are judged on cells");
                };
                env.start.y - goal.map.center(0)[1]
            })
            .collect()
    }

    #[test]
    fn turning_starts_spread_from_the_first_cell_to_the_junction() {
        let advances = start_advances(&TaskConfig::shipped("turn_left").unwrap(), 400);
        assert!(
            advances
                .iter()
                .all(|a| (0.0..=MAZE_CELL_SIZE + 1e-6).contains(a))
        );
        // Uniform over one cell: both ends of the range are reached.
        assert!(advances.iter().any(|&a| a < 0.03));
        assert!(advances.iter().any(|&a| a > MAZE_CELL_SIZE - 0.03));
    }

    #[test]
    fn the_other_branches_ends_are_the_wrong_ends() {
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let statics = Statics::new(&task);
        let radius = task.params.robot.radius;
        for configuration in 0..4 {
            let env = build(
                &task,
                &statics,
                Some(configuration),
                &mut stream_rng(0, Stream::Environment),
            );
            let Some(goal) = &env.ground.goal else {
                panic!("maze tasks are judged on cells");
            };
            // The double T-maze has four branch ends; the goal is one of them.
            assert_eq!(goal.wrong_ends.len(), 3, "configuration {configuration}");
            assert!(!goal.reached_wrong_end(goal.map.center(goal.goal), radius));
            for &end in &goal.wrong_ends {
                assert!(!goal.on_path[end]);
                let center = goal.map.center(end);
                assert!(goal.reached_wrong_end(center, radius));
                // The bounding box meets the central half (0.075 m either side) or not.
                let edge = 0.25 * goal.map.cell_size + radius;
                assert!(goal.reached_wrong_end([center[0] + edge - 0.001, center[1]], radius));
                assert!(!goal.reached_wrong_end([center[0] + edge + 0.001, center[1]], radius));
            }
        }
    }

    #[test]
    fn following_starts_stay_at_the_first_cell_centre() {
        let advances = start_advances(&TaskConfig::shipped("follow_wall").unwrap(), 100);
        assert!(advances.iter().all(|&a| a.abs() < 1e-6), "{advances:?}");
    }
}
