//! The worlds a scenario's `[world]` table names: a fixed map, a generated room, a generated
//! corridor, the joins (a room below the map's entrance, a room below a corridor, a corridor
//! beyond a map), and a random maze. Each recognises its combination of `map`, `room` and
//! `corridor`, and draws one sample's layout from the environment stream in a fixed order.

use super::{Built, FixedLayout, Refusal, World, WorldKind};
use crate::config::{MAZE_CELL_SIZE, Params};
use crate::geometry::cells::{CellMap, Side};
use crate::geometry::scene::{Rect, Scene};
use crate::math::rng::SimRng;
use crate::scenario::file::WorldDecl;
use crate::scenario::{CompiledMap, Scenario};
use crate::world::corridor::{self, Junction, Turn};
use crate::world::random_maze::{self, MAX_MAZE_SIDE};
use crate::world::room::{self, Placement, Room};
use rand::RngExt;
use std::sync::Arc;

/// `map` alone: a fixed map, built once per evaluator.
pub const MAP: WorldKind = WorldKind {
    syntax: "a map",
    compile: |decl, _| match (&decl.map, &decl.room, &decl.corridor) {
        (Some(_), None, None) => Some(Ok(Box::new(FixedMap))),
        (Some(_), Some(_), Some(_)) => Some(Err((
            "world.corridor",
            "a map, a room and a corridor do not join: give a map and a corridor, or a room \
             and one of them"
                .into(),
        ))),
        _ => None,
    },
};

#[derive(Debug)]
struct FixedMap;

impl World for FixedMap {
    fn is_map_alone(&self) -> bool {
        true
    }

    fn statics(&self, scenario: &Scenario, params: &Params) -> Option<FixedLayout> {
        let map = &scenario.map.as_ref()?.map;
        let scene = Scene::new(map.wall_rects(&[]), params.query_margin());
        Some((Arc::new(scene), Some(Arc::new(map.clone()))))
    }
}

/// `room = "standalone"`: a generated room, centred, its exit in any wall.
pub const ROOM: WorldKind = WorldKind {
    syntax: "a room (\"standalone\")",
    compile: |decl, _| match (&decl.map, decl.room.as_deref(), &decl.corridor) {
        (None, Some("standalone"), None) => Some(Ok(Box::new(StandaloneRoom))),
        (None, Some(room), None) => Some(Err((
            "world.room",
            format!(
                "'{room}': a room alone is \"standalone\" (\"below corridor\" needs a corridor)"
            ),
        ))),
        _ => None,
    },
};

#[derive(Debug)]
struct StandaloneRoom;

impl World for StandaloneRoom {
    fn has_room(&self) -> bool {
        true
    }

    fn build(
        &self,
        _scenario: &Scenario,
        params: &Params,
        _statics: Option<&FixedLayout>,
        rng: &mut SimRng,
    ) -> Built {
        let room = room::generate(
            &params.room,
            Placement::Standalone,
            params.robot.radius,
            rng,
        );
        let scene = Arc::new(Scene::new(room.rects.clone(), params.query_margin()));
        Built {
            scene,
            cells: None,
            room: Some(room),
            corridor_path: None,
            shape: None,
        }
    }
}

/// `map` and `room = "below entrance"`: a generated room under the map, its exit the map's
/// one-cell region `entrance`.
pub const ROOM_BELOW_MAP: WorldKind = WorldKind {
    syntax: "a map and a room (\"below entrance\")",
    compile: |decl, map| match (&decl.map, decl.room.as_deref(), &decl.corridor) {
        (Some(_), Some("below entrance"), None) => {
            Some(match map.and_then(|m| m.regions.get("entrance")) {
                Some(cells) if cells.len() == 1 => {
                    Ok(Box::new(RoomBelowMap { entrance: cells[0] }))
                }
                _ => Err((
                    "world.room",
                    "a room below the map's entrance needs a one-cell region 'entrance' in the \
                     map"
                    .into(),
                )),
            })
        }
        (Some(_), Some(room), None) => Some(Err((
            "world.room",
            format!("'{room}': a room with a map is \"below entrance\""),
        ))),
        _ => None,
    },
};

#[derive(Debug)]
struct RoomBelowMap {
    /// The map's entrance cell.
    entrance: usize,
}

impl World for RoomBelowMap {
    fn has_room(&self) -> bool {
        true
    }

    fn build(
        &self,
        scenario: &Scenario,
        params: &Params,
        _statics: Option<&FixedLayout>,
        rng: &mut SimRng,
    ) -> Built {
        let map = &scenario.map.as_ref().expect("checked when compiled").map;
        let (scene, room) = room_below(map, self.entrance, params, rng);
        Built {
            scene,
            cells: Some(Arc::new(map.clone())),
            room: Some(room),
            corridor_path: None,
            shape: None,
        }
    }
}

/// `map` and `corridor`: a generated corridor beyond the map's one-cell region `exit`,
/// running outward across the side where the exit is the map's outermost cell.
pub const CORRIDOR_BEYOND_MAP: WorldKind = WorldKind {
    syntax: "a map and a corridor (beyond the map's `exit`)",
    compile: |decl, map| match (&decl.map, &decl.room, decl.corridor.as_deref()) {
        (Some(_), None, Some(turn)) => Some(
            parse_turn(turn)
                .and_then(|turn| corridor_beyond(map.expect("a map world has its map"), turn)),
        ),
        _ => None,
    },
};

/// The map's exit and the side the corridor leaves it by, or why the map cannot have one.
fn corridor_beyond(map: &CompiledMap, turn: Turn) -> Result<Box<dyn World>, Refusal> {
    let cells = &map.map;
    if cells.cell_size != MAZE_CELL_SIZE || cells.wall_thickness != corridor::MAZE_WALL_THICKNESS {
        return Err((
            "world.map",
            format!(
                "a corridor joins a map of {MAZE_CELL_SIZE} m cells with {} m walls, as it is \
                 drawn; this map's cells are {} m with {} m walls",
                corridor::MAZE_WALL_THICKNESS,
                cells.cell_size,
                cells.wall_thickness
            ),
        ));
    }
    let exit = match map.regions.get("exit").map(Vec::as_slice) {
        Some(&[exit]) => exit,
        _ => {
            return Err((
                "world.corridor",
                "a corridor beyond a map leaves by the map's one-cell region 'exit': name one \
                 open cell `exit` in the legend"
                    .into(),
            ));
        }
    };
    // The corridor leaves across the side where the exit is the map's outermost cell, so
    // every cell of it lies beyond the map.
    let [x, y] = cells.cells[exit].at;
    let outermost = |side: Side| {
        cells.cells.iter().all(|cell| match side {
            Side::Top => cell.at[1] <= y,
            Side::Right => cell.at[0] <= x,
            Side::Bottom => cell.at[1] >= y,
            Side::Left => cell.at[0] >= x,
        })
    };
    let outward: Vec<Side> = Side::ALL
        .into_iter()
        .filter(|&side| outermost(side))
        .collect();
    match outward.as_slice() {
        &[outward] => Ok(Box::new(CorridorBeyondMap {
            turn,
            exit,
            outward,
        })),
        sides => Err((
            "world.corridor",
            format!(
                "the corridor leaves the map across the side where its exit is the map's \
                 outermost open cell: the exit (column {x}, row {y} from the origin) must be \
                 outermost on exactly one side (top, right, bottom or left), and it is on {}",
                match sides {
                    [] => "none".to_string(),
                    _ => sides
                        .iter()
                        .map(|side| format!("{side:?}").to_lowercase())
                        .collect::<Vec<_>>()
                        .join(" and "),
                }
            ),
        )),
    }
}

/// A generated corridor beyond a fixed map: the map's cells, then the corridor's.
#[derive(Debug)]
struct CorridorBeyondMap {
    turn: Turn,
    /// The map's exit cell.
    exit: usize,
    /// The exit's side the corridor leaves by.
    outward: Side,
}

impl World for CorridorBeyondMap {
    fn has_corridor(&self) -> bool {
        true
    }

    fn shapes(&self) -> &'static [&'static str] {
        Corridor::shapes_of(self.turn)
    }

    fn build(
        &self,
        scenario: &Scenario,
        params: &Params,
        _statics: Option<&FixedLayout>,
        rng: &mut SimRng,
    ) -> Built {
        let map = &scenario.map.as_ref().expect("a map world has its map").map;
        let (cells, path, junction) = generate_corridor(self.turn, params, rng);
        let corridor = corridor::Corridor { map: cells, path };
        let joined = corridor::join_beyond(map, self.exit, self.outward, &corridor);
        cells_with_path(joined.map, joined.path, Some(junction.index()), params)
    }
}

/// `corridor = "straight" | "left" | "right"`: a generated corridor.
pub const CORRIDOR: WorldKind = WorldKind {
    syntax: "a corridor",
    compile: |decl, _| match (&decl.map, &decl.room, decl.corridor.as_deref()) {
        (None, None, Some(turn)) => Some(parse_turn(turn).map(|turn| {
            Box::new(Corridor {
                turn,
                room_below: false,
            }) as Box<dyn World>
        })),
        _ => None,
    },
};

/// `corridor` and `room = "below corridor"`: a generated room under a generated corridor,
/// its exit the corridor's first cell.
pub const ROOM_BELOW_CORRIDOR: WorldKind = WorldKind {
    syntax: "a corridor and a room (\"below corridor\")",
    compile: |decl, _| match (&decl.map, decl.room.as_deref(), decl.corridor.as_deref()) {
        (None, Some("below corridor"), Some(turn)) => Some(parse_turn(turn).map(|turn| {
            Box::new(Corridor {
                turn,
                room_below: true,
            }) as Box<dyn World>
        })),
        (None, Some(room), Some(_)) => Some(Err((
            "world.room",
            format!("'{room}': a room with a corridor is \"below corridor\""),
        ))),
        _ => None,
    },
};

fn parse_turn(turn: &str) -> Result<Turn, Refusal> {
    match turn {
        "straight" => Ok(Turn::Straight),
        "left" => Ok(Turn::Left),
        "right" => Ok(Turn::Right),
        other => Err((
            "world.corridor",
            format!("'{other}' is not straight, left or right"),
        )),
    }
}

/// A generated corridor, alone or with a room under its first cell.
#[derive(Debug)]
struct Corridor {
    turn: Turn,
    room_below: bool,
}

impl Corridor {
    /// The shapes a corridor turning `turn` reports: its junctions', for a turn.
    fn shapes_of(turn: Turn) -> &'static [&'static str] {
        if turn == Turn::Straight {
            &[]
        } else {
            &["L-bend", "T-junction", "side junction"]
        }
    }
}

impl World for Corridor {
    fn has_room(&self) -> bool {
        self.room_below
    }

    fn has_corridor(&self) -> bool {
        true
    }

    fn advances(&self) -> bool {
        !self.room_below
    }

    fn shapes(&self) -> &'static [&'static str] {
        Corridor::shapes_of(self.turn)
    }

    fn build(
        &self,
        _scenario: &Scenario,
        params: &Params,
        _statics: Option<&FixedLayout>,
        rng: &mut SimRng,
    ) -> Built {
        let (map, path, junction) = generate_corridor(self.turn, params, rng);
        let shape = Some(junction.index());
        if self.room_below {
            // The corridor is drawn first, then the room under its first cell.
            let (scene, room) = room_below(&map, path[0], params, rng);
            Built {
                scene,
                cells: Some(Arc::new(map)),
                room: Some(room),
                corridor_path: Some(path),
                shape,
            }
        } else {
            cells_with_path(map, path, shape, params)
        }
    }
}

/// A world of corridor cells alone, walls all round, with the way to its goal: a generated
/// corridor's or a random maze's.
fn cells_with_path(map: CellMap, path: Vec<usize>, shape: Option<u32>, params: &Params) -> Built {
    let map = Arc::new(map);
    Built {
        scene: Arc::new(Scene::new(map.wall_rects(&[]), params.query_margin())),
        cells: Some(map),
        room: None,
        corridor_path: Some(path),
        shape,
    }
}

/// A room generated under the cell `entrance` of `map`, its exit centred under that cell: the
/// room's top wall is the map's lower border there, so the map leaves that border open and
/// the room's exit gap is the way in. The scene holds both.
fn room_below(
    map: &CellMap,
    entrance: usize,
    params: &Params,
    rng: &mut SimRng,
) -> (Arc<Scene>, Room) {
    let entrance_center = map.center(entrance);
    let half = 0.5 * map.cell_size;
    let room_exit = [
        entrance_center[0],
        entrance_center[1] - half - 0.5 * map.wall_thickness,
    ];
    let room = room::generate(
        &params.room,
        Placement::Below {
            exit_center: room_exit,
        },
        params.robot.radius,
        rng,
    );
    let mut rects: Vec<Rect> = map.wall_rects(&[(entrance, Side::Bottom)]);
    rects.extend(room.rects.iter().copied());
    (Arc::new(Scene::new(rects, params.query_margin())), room)
}

/// A corridor drawn from the stream as the turning and following primitives need it: its
/// cells, its path, and the shape of its turn.
fn generate_corridor(
    turn: Turn,
    params: &Params,
    rng: &mut SimRng,
) -> (CellMap, Vec<usize>, Junction) {
    let c = &params.corridor;
    let (before, after) = match turn {
        Turn::Straight => (
            rng.random_range(c.straight_cells[0]..=c.straight_cells[1]),
            0,
        ),
        _ => (
            rng.random_range(c.cells_before_turn[0]..=c.cells_before_turn[1]),
            rng.random_range(c.cells_after_turn[0]..=c.cells_after_turn[1]),
        ),
    };
    // One draw picks the turn's shape, so tasks without side junctions draw exactly what they
    // drew before side junctions existed.
    let junction = if turn == Turn::Straight {
        Junction::Bend
    } else {
        let draw = rng.random::<f32>();
        if draw < c.junction_share {
            Junction::TEnd
        } else if draw < c.junction_share + c.side_junction_share {
            Junction::Side
        } else {
            Junction::Bend
        }
    };
    let corridor = corridor::build(turn, before, after, junction);
    (corridor.map, corridor.path, junction)
}

/// `solids` alone: a fixed world of solid rectangles, built once per evaluator. (With a map,
/// room or corridor the rectangles are added to that world's solids.)
pub const SOLIDS: WorldKind = WorldKind {
    syntax: "solid rectangles (`solids`)",
    compile: |decl, _| match (&decl.map, &decl.room, &decl.corridor) {
        (None, None, None) if !decl.solids.is_empty() => Some(Ok(Box::new(Solids))),
        _ => None,
    },
};

#[derive(Debug)]
struct Solids;

impl World for Solids {
    fn statics(&self, _scenario: &Scenario, params: &Params) -> Option<FixedLayout> {
        // Empty: the scenario's solids are added to every world's (`env::Statics`), and here
        // they are all there is.
        Some((
            Arc::new(Scene::new(Vec::new(), params.query_margin())),
            None,
        ))
    }
}

/// `maze = { cols, rows }`: a random perfect maze of 0.30 m cells, drawn anew for each sample,
/// from its bottom-left cell (`corridor.start`) to its top-right one (`corridor.end`, the
/// goal): a world of cells with a path to its goal, as a generated corridor is.
pub const RANDOM_MAZE: WorldKind = WorldKind {
    syntax: "a random maze (`maze = { cols, rows }`)",
    compile: |decl, _| {
        let maze = decl.maze?;
        if decl.map.is_some() || decl.room.is_some() || decl.corridor.is_some() {
            return Some(Err((
                "world.maze",
                "a random maze stands alone: no map, room or corridor beside it".into(),
            )));
        }
        for (key, cells) in [
            ("world.maze.cols", maze.cols),
            ("world.maze.rows", maze.rows),
        ] {
            if !(1..=MAX_MAZE_SIDE).contains(&cells) {
                return Some(Err((
                    key,
                    format!("{cells} cells: a random maze has 1 to {MAX_MAZE_SIDE} a side"),
                )));
            }
        }
        if maze.cols * maze.rows < 2 {
            return Some(Err((
                "world.maze",
                "a maze of one cell has no way to its goal: give at least two cells".into(),
            )));
        }
        Some(Ok(Box::new(Maze {
            cols: maze.cols,
            rows: maze.rows,
        })))
    },
};

#[derive(Debug)]
struct Maze {
    cols: u32,
    rows: u32,
}

impl World for Maze {
    fn has_corridor(&self) -> bool {
        true
    }

    fn build(
        &self,
        _scenario: &Scenario,
        params: &Params,
        _statics: Option<&FixedLayout>,
        rng: &mut SimRng,
    ) -> Built {
        let maze = random_maze::generate(self.cols, self.rows, rng);
        cells_with_path(maze.map, maze.path, None, params)
    }
}

/// The world a `[world]` table names, by the first registered kind that recognises it.
pub(crate) fn compile(
    decl: &WorldDecl,
    map: Option<&CompiledMap>,
) -> Result<Box<dyn World>, Refusal> {
    super::WORLDS
        .iter()
        .find_map(|kind| (kind.compile)(decl, map))
        .unwrap_or_else(|| {
            Err((
                "world",
                format!(
                    "give {}",
                    super::listed(super::WORLDS.iter().map(|kind| kind.syntax))
                ),
            ))
        })
}
