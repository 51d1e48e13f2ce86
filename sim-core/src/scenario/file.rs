//! The scenario file as written: the serde schema of `hevo.scenario/1`, strict (an unknown key
//! is an error), and the map file format. Nothing here checks that the parts fit together;
//! compiling it ([`super::Scenario::parse`]) does.

use crate::config::{
    CorridorConfig, IrConfig, LightConfig, Params, RabConfig, RobotConfig, RoomConfig, StartConfig,
};
use crate::sensors::frame::InputGroup;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One scenario file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// `hevo.scenario/1`.
    pub schema: String,
    /// A short name, used in outputs and to refer to a shipped scenario.
    pub name: String,
    /// Other names a shipped scenario answers to (`maze_single` for `solve_maze`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub aliases: Vec<String>,
    /// Shipped paper tasks only: the task name that content hashes of this scenario are
    /// computed under, so that runs made before scenarios existed keep their fingerprints.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub legacy: Option<String>,
    /// Free text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Cycle limit of a sample.
    pub max_cycles: u32,
    /// Whether touching a wall ends the sample.
    #[serde(default = "default_true")]
    pub end_on_collision: bool,
    /// The input groups the robot's sensors give (`"ir"`, `"light"`, `"near_robot"`, `"rab"`);
    /// the first three, the e-puck's, when omitted. The others read 0 and draw no noise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensors: Option<Vec<InputGroup>>,
    /// The robot's body and motors.
    #[serde(default)]
    pub robot: RobotConfig,
    /// The IR proximity sensors.
    #[serde(default)]
    pub ir: IrConfig,
    /// Light-flash sensing and how long a flash lasts (`[light_sensor]`; `[[light]]` lists
    /// the lights themselves).
    #[serde(default, rename = "light_sensor")]
    pub light: LightConfig,
    /// The range-and-bearing board (`[rab]`), read by the `rab` sensor.
    #[serde(default, skip_serializing_if = "RabConfig::is_default")]
    pub rab: RabConfig,
    /// The room generator's numbers, for worlds with a room.
    #[serde(default)]
    pub room: RoomConfig,
    /// The corridor generator's numbers, for corridor worlds.
    #[serde(default)]
    pub corridor: CorridorConfig,
    /// How a start pose is jittered.
    #[serde(default)]
    pub start: StartConfig,
    /// What the world is made of.
    pub world: WorldDecl,
    /// Named regions besides those the world provides.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub regions: BTreeMap<String, RegionDecl>,
    /// Lights.
    #[serde(default, rename = "light", skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<LightDecl>,
    /// The variants a sample may be: which lights flash, where the goal and the start are.
    #[serde(default, rename = "variant", skip_serializing_if = "Vec::is_empty")]
    pub variants: Vec<VariantDecl>,
    /// Where the robot starts.
    pub place: PlaceDecl,
    /// Another robot, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub teammate: Option<TeammateDecl>,
    /// Other robots besides the one `[place]` starts (the *focal* robot, whose controller is
    /// evolved or evaluated): a team, group by group.
    #[serde(default, rename = "robots", skip_serializing_if = "Vec::is_empty")]
    pub robot_groups: Vec<RobotGroupDecl>,
    /// Movable items on the floor, group by group, which robots pick up and deliver in the
    /// nest (`[[objects]]`).
    #[serde(default, rename = "objects", skip_serializing_if = "Vec::is_empty")]
    pub object_groups: Vec<ObjectGroupDecl>,
    /// Where items are delivered (`[nest]`), in a scenario with `[[objects]]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nest: Option<NestDecl>,
    /// Moving obstacles, each a disc patrolling a path (`[[movers]]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub movers: Vec<MoverDecl>,
    /// Boxes the robots push, group by group (`[[boxes]]`).
    #[serde(default, rename = "boxes", skip_serializing_if = "Vec::is_empty")]
    pub box_groups: Vec<BoxGroupDecl>,
    /// When a sample ends.
    pub end: EndDecl,
    /// The fitness of a sample, per way of ending.
    pub fitness: FitnessDecl,
    /// For an arbitrator: the phases of the derived fitness, each asking for one child.
    #[serde(default, rename = "phase", skip_serializing_if = "Vec::is_empty")]
    pub phases: Vec<PhaseDecl>,
    /// The stages post-evaluation reports, in order; a solved sample has passed them all.
    #[serde(default, rename = "stage", skip_serializing_if = "Vec::is_empty")]
    pub stages: Vec<StageDecl>,
    /// The behaviour descriptor: the quantities that say what a sample's robot did, for
    /// searches over behaviours; the final position when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub descriptor: Option<DescriptorDecl>,
}

/// `[descriptor]`: the quantities of a sample's behaviour descriptor, in order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DescriptorDecl {
    /// Each a fitness quantity's text (`final.x`, `approach room.exit`, ...), which also
    /// names it.
    pub quantities: Vec<String>,
}

impl ScenarioFile {
    /// The file's seven tables of numbers, as a task's defaults.
    pub fn params(&self) -> Params {
        Params {
            robot: self.robot.clone(),
            ir: self.ir,
            light: self.light,
            rab: self.rab,
            room: self.room.clone(),
            corridor: self.corridor.clone(),
            start: self.start.clone(),
        }
    }
}

fn default_true() -> bool {
    true
}

/// `[world]`: a fixed map, a generated room or corridor, or a room joined under a map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldDecl {
    /// A map: the name of a shipped map, or the map itself.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub map: Option<MapRef>,
    /// A generated room (`[room]` has its numbers): `"standalone"` (centred, the exit in any
    /// wall, a short corridor stub outside) or `"below entrance"` (under the map, its exit the
    /// map's entrance).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub room: Option<String>,
    /// A generated corridor (`[corridor]` has its numbers): `"straight"`, `"left"` or
    /// `"right"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub corridor: Option<String>,
    /// Solid rectangles `[x0, y0, x1, y1]`, metres: obstacles added to the world's own solids,
    /// or, alone, the whole world.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub solids: Vec<[f32; 4]>,
    /// A random maze, drawn anew for each sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maze: Option<MazeDecl>,
}

/// `world.maze`: a random perfect maze of corridor cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MazeDecl {
    /// Cells across (x), 1 to 32.
    pub cols: u32,
    /// Cells up (y), 1 to 32.
    pub rows: u32,
}

/// A map, by shipped name or written out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum MapRef {
    /// A shipped map (`scenarios/maps/NAME.toml`).
    Shipped(String),
    /// The map itself.
    Inline(MapFile),
}

/// A map of square cells drawn as text: one character per cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapFile {
    /// Cell side, metres.
    pub cell_size: f32,
    /// Wall thickness on the border between an open and a solid cell, metres.
    pub wall_thickness: f32,
    /// The cell coordinates of the grid's top-left character (x right, y up; a cell's centre
    /// is its coordinates times the cell size).
    pub origin: [i32; 2],
    /// Rows of characters, the top row first.
    pub grid: String,
    /// What each character means: `"open"`, `"solid"`, or the name of a region of open
    /// cells.
    pub legend: BTreeMap<String, String>,
}

/// A named region written in the scenario.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegionDecl {
    /// A rectangle `[x0, y0, x1, y1]`, metres.
    pub rect: [f32; 4],
}

/// `[[light]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDecl {
    /// Its name, for variants.
    pub name: String,
    /// Position in cell units of the map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell: Option<[f32; 2]>,
    /// Position in metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at: Option<[f32; 2]>,
    /// When it lights: `"passed"` (once, when the robot's centre first crosses its row going
    /// up, within its distance from the centre line, for `light.flash_cycles` cycles),
    /// `"always"` (a beacon), `{ after_cycles = N }` (once, at cycle N), `{ entered =
    /// "REGION" }` (once, when the robot's centre is first inside a `[regions]` rectangle), or
    /// a schedule: `{ blink = { from = K, lit = N, dark = M } }` (lit N cycles, dark M, from
    /// cycle K) or `{ lit_until = N }` (lit from the start, dark from cycle N).
    pub trigger: TriggerDecl,
}

/// When a light lights. Read by hand ([`TriggerTable`]) rather than as an untagged enum, so
/// that a wrong key or number in a table is refused with what is wrong with it.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum TriggerDecl {
    /// `"passed"` or `"always"`.
    Named(String),
    /// At a cycle.
    AfterCycles {
        /// The cycle.
        after_cycles: u32,
    },
    /// When the robot enters a region.
    Entered {
        /// A `[regions]` rectangle's name.
        entered: String,
    },
    /// A blinking schedule.
    Blink {
        /// Its cycles.
        blink: BlinkDecl,
    },
    /// Lit from the start until a cycle.
    LitUntil {
        /// The first dark cycle.
        lit_until: u32,
    },
}

/// A trigger written as a table: exactly one of its keys.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct TriggerTable {
    after_cycles: Option<u32>,
    entered: Option<String>,
    blink: Option<BlinkDecl>,
    lit_until: Option<u32>,
}

impl TriggerTable {
    /// The trigger the table names, or why it names none or several.
    fn into_decl(self) -> Result<TriggerDecl, &'static str> {
        match self {
            TriggerTable {
                after_cycles: Some(after_cycles),
                entered: None,
                blink: None,
                lit_until: None,
            } => Ok(TriggerDecl::AfterCycles { after_cycles }),
            TriggerTable {
                after_cycles: None,
                entered: Some(entered),
                blink: None,
                lit_until: None,
            } => Ok(TriggerDecl::Entered { entered }),
            TriggerTable {
                after_cycles: None,
                entered: None,
                blink: Some(blink),
                lit_until: None,
            } => Ok(TriggerDecl::Blink { blink }),
            TriggerTable {
                after_cycles: None,
                entered: None,
                blink: None,
                lit_until: Some(lit_until),
            } => Ok(TriggerDecl::LitUntil { lit_until }),
            _ => Err(
                "a trigger table holds exactly one of `after_cycles`, `entered`, `blink`, \
                      `lit_until`",
            ),
        }
    }
}

impl<'de> Deserialize<'de> for TriggerDecl {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        /// A name, or a table read as [`TriggerTable`] (whose errors say what is wrong).
        struct TriggerVisitor;

        impl<'de> serde::de::Visitor<'de> for TriggerVisitor {
            type Value = TriggerDecl;

            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a trigger's name or a table such as { lit_until = N }")
            }

            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<TriggerDecl, E> {
                Ok(TriggerDecl::Named(name.to_string()))
            }

            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<TriggerDecl, A::Error> {
                let table =
                    TriggerTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                table.into_decl().map_err(serde::de::Error::custom)
            }
        }

        deserializer.deserialize_any(TriggerVisitor)
    }
}

/// `trigger = { blink = { from = K, lit = N, dark = M } }`: dark before cycle K, then lit for
/// N cycles and dark for M, over and over.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlinkDecl {
    /// The first lit cycle, counted from 0 (0 by default).
    #[serde(default)]
    pub from: u32,
    /// Cycles lit in each period.
    pub lit: u32,
    /// Cycles dark in each period.
    pub dark: u32,
}

/// `[[variant]]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VariantDecl {
    /// Its name, in reports.
    pub name: String,
    /// The lights that flash in it (the others stay dark).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub flash: Vec<String>,
    /// The goal region.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<String>,
    /// The start region.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<String>,
}

/// `[place]`: where and how the robot starts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaceDecl {
    /// `room.start` (the room generator's start), `corridor.start`, `start` (the variant's
    /// start region), or a region's name: the centre of a map region's first cell, or of a
    /// `[regions]` rectangle.
    pub at: String,
    /// `"up"`, `"down"`, `"left"`, `"right"`, or `"path"` (towards the next cell of the path
    /// to the goal). Not for `room.start`, which draws its own heading.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub facing: Option<String>,
    /// How far ahead, along the facing, of the cell's centre, metres.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub ahead_m: f32,
    /// Also move the start a uniform distance of up to `corridor.start_advance` along the
    /// corridor.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub advance: bool,
    /// Start anywhere in the region, uniformly, clear of walls and obstacles: over a map
    /// region's cells or a `[regions]` rectangle. Not with `ahead_m` or `advance`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub anywhere: bool,
    /// A heading range, degrees, `[from, to]`: the start turns from its facing by a uniform
    /// angle in it (`[-180, 180]`: any heading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_deg: Option<[f32; 2]>,
}

fn is_zero(value: &f32) -> bool {
    *value == 0.0
}

/// `[teammate]`: the robot to rescue.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TeammateDecl {
    /// `"goal"` (the variant's goal region), `"start"` (the variant's start region) or the
    /// name of a region of the map.
    pub at: String,
    /// `"branch_end"`: in the goal cell, towards its dead end, clear of the end wall;
    /// `"centre"`: the centre of the region's first cell; absent: behind the robot's start by
    /// `behind_m`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub placement: Option<String>,
    /// With no placement: this far behind the robot's start, metres.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub behind_m: f32,
    /// Whether it follows from the start (else once the robot comes within range).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub following: bool,
    /// `"follow"` (the default: once met, follows the robot's trail, keeping a gap),
    /// `"fixed"` (stays where it is) or `"wander"` (walks at random until met, then follows;
    /// docs/scenario-file.md gives the walk).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behaviour: Option<String>,
}

/// `[[robots]]`: a group of robots that join the focal robot, each of the scenario's body and
/// sensors, seen by every robot's IR and colliding with walls and with each other.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotGroupDecl {
    /// The group's name, for messages and replays.
    pub name: String,
    /// How many robots, at least 1; a team holds at most `scenario::MAX_ROBOTS` robots in all.
    pub count: u32,
    /// Where they start: a `[regions]` rectangle or a map region, each robot anywhere in it
    /// clear of solids and of the robots placed before it, at any heading.
    pub region: String,
    /// What drives them ([`GroupControllerDecl`]).
    pub controller: GroupControllerDecl,
}

/// `robots[i].controller`: a name, or a controller file.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum GroupControllerDecl {
    /// `"evolved"`: each runs its own copy of the controller being evaluated, with its own
    /// network state (a homogeneous team); `"wander"` or `"fixed"`: a scripted robot (the
    /// teammate's walk, or standing still).
    Named(String),
    /// `{ file = "PATH" }`: each runs its own copy of the complete controller tree in that
    /// controller file (`hevo.controller/1`), the path relative to the scenario file.
    File(ControllerFileRef),
}

/// `{ file = "PATH" }`: a controller file a group runs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerFileRef {
    /// The path as written, relative to the scenario file: the key its text travels under.
    pub file: String,
}

impl<'de> Deserialize<'de> for GroupControllerDecl {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        // By hand rather than `untagged`, whose error names neither form nor the inner key.
        struct Either;
        impl<'de> serde::de::Visitor<'de> for Either {
            type Value = GroupControllerDecl;

            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(
                    "\"evolved\", \"wander\", \"fixed\" or a controller file, \
                     { file = \"PATH\" }",
                )
            }

            fn visit_str<E: serde::de::Error>(self, name: &str) -> Result<Self::Value, E> {
                Ok(GroupControllerDecl::Named(name.to_string()))
            }

            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<Self::Value, A::Error> {
                ControllerFileRef::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(GroupControllerDecl::File)
            }
        }
        deserializer.deserialize_any(Either)
    }
}

/// `[[objects]]`: a group of items on the floor, small discs the robots drive over, pick up
/// on contact, carry one at a time and deliver in the nest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectGroupDecl {
    /// The group's name, for messages and replays.
    pub name: String,
    /// How many items, at least 1; a scenario holds at most `scenario::MAX_ITEMS` in all.
    pub count: u32,
    /// Where they lie at a sample's start: a `[regions]` rectangle or a map region, each item
    /// anywhere in it clear of solids, of every robot and of the items placed before it.
    pub region: String,
}

/// `[nest]`: where a carried item is delivered.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NestDecl {
    /// A `[regions]` rectangle, a map region or `room`: an item is delivered when its
    /// carrier's centre is in it.
    pub region: String,
}

/// `[[movers]]`: a moving obstacle, a disc that runs a path of waypoints at a fixed speed and
/// waits while a robot or a box is in its way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MoverDecl {
    /// Its name, for messages and replays.
    pub name: String,
    /// Its radius, metres.
    pub radius: f32,
    /// The waypoints `[[x, y], ...]`, metres, at least two.
    pub path: Vec<[f32; 2]>,
    /// Metres a second.
    pub speed: f32,
    /// `loop` (back to the first point after the last) or `back_and_forth`.
    #[serde(default = "MoverDecl::default_mode")]
    pub mode: String,
    /// Where it starts: a share of one lap, in [0, 1).
    #[serde(default)]
    pub start: f32,
}

impl MoverDecl {
    fn default_mode() -> String {
        "loop".into()
    }
}

/// `[[boxes]]`: a group of boxes (discs) that robots push.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxGroupDecl {
    /// The group's name, for messages and replays.
    pub name: String,
    /// How many boxes, at least 1.
    pub count: u32,
    /// Where they stand at a sample's start: a `[regions]` rectangle or a map region, each box
    /// clear of solids, robots, items, movers and the boxes placed before it.
    pub region: String,
    /// Each box's radius, metres.
    pub radius: f32,
}

/// `[end]`: what ends a sample besides a collision and the time limit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndDecl {
    /// When the sample is solved: a condition (`"in goal"`, `"beyond room.exit"`, `"teammate
    /// in room"`, `"near NAME and teammate met"`, ...; docs/scenario-file.md lists the atoms).
    pub solved: String,
    /// `"off path"`: entering a cell off the path to the goal is a wrong branch.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrong_branch: Option<String>,
    /// Whether a wrong branch ends the sample (true by default; the rescue lets the robot
    /// search on, and `end_on_wrong_branch = true` changes that).
    #[serde(default = "default_true")]
    pub wrong_branch_ends: bool,
    /// A condition (`"in pit"`, `"in maze and not teammate met"`): when it holds after a
    /// move, the robot has gone where it must not, and the sample ends as a wrong branch does.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forbidden: Option<String>,
    /// For the `near NAME` atom: how close counts, metres.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub near_m: f32,
}

/// `[fitness]`: a formula per way of ending (see `scenario::fitness`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitnessDecl {
    /// When solved.
    pub solved: String,
    /// After a wrong branch (when no `otherwise`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrong_branch: Option<String>,
    /// After a collision (when no `otherwise`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub collision: Option<String>,
    /// After the time limit (when no `otherwise`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timeout: Option<String>,
    /// Every ending but solved.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub otherwise: Option<String>,
}

/// `[[phase]]`: a phase of the derived fitness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PhaseDecl {
    /// Its name, in reports.
    pub name: String,
    /// The child the arbitrator should drive with in it: its name, or its index.
    pub child: ChildRef,
    /// When the phase is in force (see `scenario::condition`); phases are tried in order.
    pub when: String,
}

/// A child of the arbitrator, by name or index.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum ChildRef {
    /// By output index.
    Index(usize),
    /// By the child's node name.
    Name(String),
}

/// `[[stage]]`: a stage post-evaluation reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageDecl {
    /// Its name, in reports.
    pub name: String,
    /// Reached once this condition has held in some cycle.
    pub reached: String,
}
