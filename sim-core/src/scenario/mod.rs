//! Scenarios: a task as a file. A scenario says what the world is (a map of cells drawn as text,
//! a generated room or corridor, or a room under a map), which lights and which other robot it
//! holds, its named regions, its variants (which lights flash, where the goal and the start
//! are), where the robot starts, what ends a sample, the fitness of each ending, and for an
//! arbitrator the phases of its derived fitness and the stages post-evaluation reports. The
//! paper's seven tasks are the shipped scenarios in `scenarios/`; a researcher's own task is
//! one more file.
//!
//! A scenario is compiled once ([`Scenario::parse`]) into what the evaluator runs: the map's
//! cells and regions, resolved light and region indices, parsed formulas and conditions. The
//! control loop interprets nothing but a handful of resolved conditions per cycle.
//!
//! The condition atoms, fitness quantities and teammate behaviours a file names are building
//! blocks, each a small type behind a trait, registered in [`blocks`].

pub mod blocks;
mod compile;
pub mod file;
pub mod formula;

use crate::geometry::bodies::MoverPath;
use crate::geometry::cells::{Cell, CellMap};
use crate::geometry::scene::Rect;
use crate::math::hash::{Fnv1a, fnv1a_hex};
use crate::network::controller::Controller;
use crate::sensors::SensedWorld;
use crate::sensors::frame::{InputGroup, SensorSet};
use crate::world::lights::Trigger;
use blocks::{TeammateBehaviour, World};
use file::{ChildRef, MapFile, ScenarioFile};
use formula::{Condition, Formula, Quantities};
use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

/// The schema tag of a scenario file.
pub const SCHEMA: &str = "hevo.scenario/1";

/// The most phases a derived fitness may have.
pub const MAX_PHASES: usize = crate::outcome::N_SUB_TASKS;

/// The most lights a scenario may hold: a cycle's lit lights are one bit each of a `u32`, in
/// traces too.
pub const MAX_LIGHTS: usize = 32;

/// The most cycles a light's schedule counts (`blink`'s `from`, `lit` and `dark`,
/// `lit_until`): far beyond any cycle limit, and small enough that a period never overflows.
pub const MAX_SCHEDULE_CYCLES: u32 = 1_000_000;

/// The most solid rectangles `world.solids` may list.
pub const MAX_SOLIDS: usize = 1024;

/// How far from the origin a solid rectangle may reach, metres: the scene's lookup table
/// covers the solids' bounding box in 0.1 m cells, which this keeps to a few megabytes.
pub const MAX_SOLID_COORDINATE: f32 = 50.0;

/// The largest scenario file, bytes: the text travels with every job and to every worker.
pub const MAX_SCENARIO_BYTES: usize = 1024 * 1024;

/// The most cells a map's grid may span (its rows times its widest row): a cell's index is a
/// `u16`, and the walls of any grid this size stay fewer than 65,536 (a scene's solid index).
pub const MAX_MAP_CELLS: usize = 16_384;

/// The largest side of a map cell, metres.
pub const MAX_CELL_SIZE: f32 = 10.0;

/// The most `[regions]` rectangles, and the most regions a map's legend may name.
pub const MAX_REGIONS: usize = 256;

/// The most quantities a `[descriptor]` may list.
pub const MAX_DESCRIPTOR: usize = 16;

/// The behaviour descriptor of a scenario without `[descriptor]` (every shipped one): where
/// the robot ends. In code rather than in the shipped files, whose text hashes are pinned.
pub const DEFAULT_DESCRIPTOR: [&str; 2] = ["final.x", "final.y"];

/// The most `[[variant]]`s: every variant's starts are built and checked when a task is made.
pub const MAX_VARIANTS: usize = 256;

/// Whether a robot with `sensors` (of scenario `name`) has a sensor for every group of
/// `groups`; else which one it lacks, as words that follow a controller's name.
fn check_sensors(sensors: SensorSet, name: &str, groups: &[InputGroup]) -> Result<(), String> {
    match groups.iter().find(|&&group| !sensors.carries(group)) {
        None => Ok(()),
        Some(group) => {
            let carried: Vec<&str> = sensors.groups().map(InputGroup::name).collect();
            Err(format!(
                "reads '{}', a sensor the robot of scenario '{}' lacks (it has {})",
                group.name(),
                name,
                carried.join(", ")
            ))
        }
    }
}

/// Whether `[x0, y0, x1, y1]` is a rectangle of some area: finite, `x0 < x1` and `y0 < y1`.
fn is_proper_rect([x0, y0, x1, y1]: [f32; 4]) -> bool {
    x0 < x1 && y0 < y1 && [x0, y0, x1, y1].iter().all(|v| v.is_finite())
}

/// The scenarios shipped with hevo: the paper's tasks.
pub const SHIPPED: [(&str, &str); 7] = [
    (
        "exit_room",
        include_str!("../../../scenarios/exit_room.toml"),
    ),
    (
        "follow_wall",
        include_str!("../../../scenarios/follow_wall.toml"),
    ),
    (
        "turn_left",
        include_str!("../../../scenarios/turn_left.toml"),
    ),
    (
        "turn_right",
        include_str!("../../../scenarios/turn_right.toml"),
    ),
    (
        "solve_maze",
        include_str!("../../../scenarios/solve_maze.toml"),
    ),
    (
        "return_room",
        include_str!("../../../scenarios/return_room.toml"),
    ),
    ("rescue", include_str!("../../../scenarios/rescue.toml")),
];

/// The names of the shipped scenarios, in the paper's order of the task tree's leaves up to
/// its root.
pub const SHIPPED_NAMES: [&str; 7] = [
    "exit_room",
    "follow_wall",
    "turn_left",
    "turn_right",
    "solve_maze",
    "return_room",
    "rescue",
];

/// The maps shipped with hevo, by name.
pub const SHIPPED_MAPS: [(&str, &str); 1] = [(
    "double_t_maze",
    include_str!("../../../scenarios/maps/double_t_maze.toml"),
)];

/// A problem with a scenario file: where (the file, the key path, the line when known) and
/// what.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{origin}:{}{} {message}", line.map(|l| format!("{l}:")).unwrap_or_default(), at_key(path))]
pub struct ScenarioError {
    /// The file (or `scenario NAME` for a shipped one).
    pub origin: String,
    /// The key path, e.g. `variant[2].goal`.
    pub path: String,
    /// The line, when known.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

fn at_key(path: &str) -> String {
    if path.is_empty() {
        String::new()
    } else {
        format!(" at `{path}`:")
    }
}

/// A map, compiled: its cells and the regions its legend names.
#[derive(Debug)]
pub struct CompiledMap {
    /// The cells.
    pub map: CellMap,
    /// Region name -> its cells.
    pub regions: BTreeMap<String, Vec<usize>>,
}

/// A light, compiled.
#[derive(Debug, Clone, PartialEq)]
pub struct LightDef {
    /// Its name.
    pub name: String,
    /// Position, metres.
    pub position: [f32; 2],
    /// When it lights.
    pub trigger: Trigger,
}

/// A variant, compiled.
#[derive(Debug, Clone, PartialEq)]
pub struct Variant {
    /// Its name.
    pub name: String,
    /// Whether each light flashes in it.
    pub flashes: Vec<bool>,
    /// The goal region's name.
    pub goal: Option<String>,
    /// The start region's name.
    pub start: Option<String>,
}

/// Where the robot starts.
#[derive(Debug, Clone, PartialEq)]
pub enum PlaceAt {
    /// The room generator's start pose.
    RoomStart,
    /// The corridor's first cell.
    CorridorStart,
    /// The variant's start region.
    VariantStart,
    /// A named region of the map: its first cell, or any of its cells.
    Region(String),
    /// A `[regions]` rectangle: its centre, or anywhere in it.
    Rect([f32; 4]),
}

/// Which way a placed robot faces.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Facing {
    /// A fixed heading, radians.
    Heading(f32),
    /// Towards the next cell of the path.
    Path,
}

/// The start rule.
#[derive(Debug, Clone, PartialEq)]
pub struct Place {
    /// Where.
    pub at: PlaceAt,
    /// Facing (not for the room's start).
    pub facing: Option<Facing>,
    /// Ahead of the cell's centre along the facing, metres.
    pub ahead_m: f32,
    /// Whether to advance the start along the corridor.
    pub advance: bool,
    /// Whether the start is drawn anywhere in its region (clear of solids), not at its centre.
    pub anywhere: bool,
    /// A uniform turn from the facing, radians `[from, to]`, drawn only when given.
    pub turn: Option<[f32; 2]>,
}

/// How the teammate is placed and behaves.
#[derive(Debug, Clone)]
pub struct TeammatePlan {
    /// At the variant's goal (true) or start (false).
    pub at_goal: bool,
    /// In the goal cell towards its dead end (true), or behind the start by `behind_m`.
    pub branch_end: bool,
    /// At the centre of the first cell of the region `at_goal` or `region` names (`placement =
    /// "centre"`).
    pub centre: bool,
    /// A region of the map named by `teammate.at` instead of the variant's goal or start.
    pub region: Option<String>,
    /// Behind the robot's start, metres.
    pub behind_m: f32,
    /// Whether it follows from the start.
    pub following: bool,
    /// How it moves, a registered behaviour ([`blocks::BEHAVIOURS`]).
    pub behaviour: &'static dyn TeammateBehaviour,
}

/// The most robots a team may hold, the focal robot included: a bound on a sample's cost
/// (each robot senses and moves every cycle) checked before any evaluation.
pub const MAX_ROBOTS: u32 = 64;

/// A group of robots besides the focal one (`[[robots]]`).
#[derive(Debug, Clone)]
pub struct RobotGroup {
    /// Its name.
    pub name: String,
    /// How many robots.
    pub count: u32,
    /// Where they start: a `[regions]` rectangle (`PlaceAt::Rect`) or a map region
    /// (`PlaceAt::Region`).
    pub region: PlaceAt,
    /// What drives them.
    pub driver: GroupDriver,
}

impl RobotGroup {
    /// The controller file its robots run, as written (`robots[i].controller.file`).
    pub fn controller_file(&self) -> Option<&str> {
        match &self.driver {
            GroupDriver::File { path, .. } => Some(path),
            _ => None,
        }
    }
}

/// The most items a scenario may hold: a bound on a cycle's cost (every robot not carrying
/// looks at every item on the floor) checked before any evaluation.
pub const MAX_ITEMS: u32 = 64;

/// A group of items (`[[objects]]`).
#[derive(Debug, Clone)]
pub struct ObjectGroup {
    /// Its name.
    pub name: String,
    /// How many items.
    pub count: u32,
    /// Where they lie at the start: a `[regions]` rectangle (`PlaceAt::Rect`) or a map region
    /// (`PlaceAt::Region`).
    pub region: PlaceAt,
}

/// The most movers a scenario may hold (`[[movers]]`): a bound on a cycle's cost (every
/// robot's sensors and moves test every mover).
pub const MAX_MOVERS: usize = 16;

/// The most waypoints a mover's path may list.
pub const MAX_MOVER_POINTS: usize = 32;

/// A mover's radius, metres: from a cable's width to a large bin (the range is closed).
pub const MOVER_RADIUS: (f32, f32) = (0.01, 0.5);

/// A mover's top speed, metres a second: twice the e-puck's. A cycle's step (at most 2 cm at
/// the default 0.1 s cycle) is shorter than the narrowest robot or box, so a mover never
/// steps over one it should wait for.
pub const MAX_MOVER_SPEED: f32 = 0.2;

/// The most boxes a scenario may hold (`[[boxes]]`): a bound on a cycle's cost.
pub const MAX_BOXES: u32 = 32;

/// A box's radius, metres (the range is closed): no wider than an e-puck can be said to push.
pub const BOX_RADIUS: (f32, f32) = (0.01, 0.1);

/// A group of boxes (`[[boxes]]`).
#[derive(Debug, Clone)]
pub struct BoxGroup {
    /// Its name.
    pub name: String,
    /// How many boxes.
    pub count: u32,
    /// Where they stand at the start: a `[regions]` rectangle (`PlaceAt::Rect`) or a map
    /// region (`PlaceAt::Region`).
    pub region: PlaceAt,
    /// Each box's radius, metres.
    pub radius: f32,
}

/// Where items are delivered (`[nest]`).
#[derive(Debug, Clone)]
pub struct Nest {
    /// The region's name.
    pub name: String,
    /// Whether a carrier's centre is in it.
    pub test: blocks::atoms::RegionTest,
}

/// What drives the robots of a group.
#[derive(Debug, Clone)]
pub enum GroupDriver {
    /// Each its own copy of the controller being evaluated.
    Evolved,
    /// Each its own copy of a controller file's complete tree (`{ file = "PATH" }`), reset at
    /// a sample's start as the evolved copies are.
    File {
        /// The path as written in the scenario file.
        path: String,
        /// The tree, every node with its genome.
        controller: Arc<Controller>,
    },
    /// A scripted behaviour ([`blocks::BEHAVIOURS`]), never "met": a wanderer keeps wandering.
    Scripted(&'static dyn TeammateBehaviour),
}

/// The largest controller file a group may run, bytes: its text travels with the scenario's.
pub const MAX_CONTROLLER_FILE_BYTES: usize = 1024 * 1024;

/// Where compiling a scenario finds the text of a controller file a group runs
/// (`robots[i].controller.file`), given the path as written: sim-core reads no file, so the
/// caller reads it (relative to the scenario file), or a task's wire form carries it. `Err`
/// says why there is none.
pub type ControllerSource<'a> = &'a dyn Fn(&str) -> Result<String, String>;

/// The [`ControllerSource`] of a scenario that comes as text alone: it has no controller files.
pub fn no_controller_files(path: &str) -> Result<String, String> {
    Err(format!(
        "'{}' was not given with the scenario's text (a controller file is read where the \
         scenario file is read, relative to it)",
        bounded(path)
    ))
}

/// One phase of the derived fitness.
#[derive(Debug)]
pub struct Phase {
    /// Its name.
    pub name: String,
    /// The child it asks for, as written.
    pub child: ChildRef,
    /// When it is in force.
    pub when: Condition,
}

/// One stage post-evaluation reports.
#[derive(Debug)]
pub struct Stage {
    /// Its name.
    pub name: String,
    /// Reached once this has held.
    pub reached: Condition,
}

/// A compiled scenario. Cheap to share (`Arc`); immutable.
#[derive(Debug)]
pub struct Scenario {
    /// The file as written (its numbers are the task's defaults).
    pub file: ScenarioFile,
    /// The text it was parsed from: what travels to workers and what its hash covers.
    pub source: String,
    /// Where the text came from (a path, or `scenarios/NAME.toml` for a shipped one), for
    /// refusals found after it compiled.
    pub origin: String,
    /// The input groups the robot's sensors give.
    pub sensors: SensorSet,
    /// How the world is made, a registered world (`blocks::WORLDS`).
    pub world: Box<dyn World>,
    /// The map, for map worlds.
    pub map: Option<Arc<CompiledMap>>,
    /// Named rectangles, metres.
    pub rect_regions: BTreeMap<String, [f32; 4]>,
    /// The lights.
    pub lights: Vec<LightDef>,
    /// The variants (one unnamed variant when the file lists none).
    pub variants: Vec<Variant>,
    /// Solid rectangles added to the world's own.
    pub solids: Vec<Rect>,
    /// The start rule.
    pub place: Place,
    /// The teammate.
    pub teammate: Option<TeammatePlan>,
    /// The other robots of a team, group by group (none: the focal robot alone).
    pub robot_groups: Vec<RobotGroup>,
    /// The texts of the controller files its groups run, by the path as written: they travel
    /// with `source` and its content hash covers them (empty for most scenarios).
    pub controller_files: BTreeMap<String, String>,
    /// The items on the floor, group by group (none: a scenario without objects).
    pub object_groups: Vec<ObjectGroup>,
    /// Where items are delivered, in a scenario with items.
    pub nest: Option<Nest>,
    /// The moving obstacles (`[[movers]]`), by mover.
    pub movers: Vec<MoverPath>,
    /// The boxes robots push, group by group (`[[boxes]]`).
    pub box_groups: Vec<BoxGroup>,
    /// When a sample is solved.
    pub solved: Condition,
    /// Whether wrong branches are judged (cells off the path).
    pub wrong_branch: bool,
    /// Whether a wrong branch ends the sample by default.
    pub wrong_branch_ends: bool,
    /// Where the robot must not go: the sample ends, as after a wrong branch, when it holds.
    pub forbidden: Option<Condition>,
    /// `near` distance, metres.
    pub near_m: f32,
    /// Fitness when solved, after a wrong branch, a collision, a timeout.
    pub fitness: [Formula; 4],
    /// The quantities the formulas and the descriptor name, each compiled once.
    pub quantities: Quantities,
    /// The behaviour descriptor: indices into `quantities`, in the descriptor's order.
    pub descriptor: Vec<usize>,
    /// The derived fitness's phases.
    pub phases: Vec<Phase>,
    /// The stages.
    pub stages: Vec<Stage>,
}

/// Fitness formula slots.
pub mod ending_slot {
    /// Solved.
    pub const SOLVED: usize = 0;
    /// Wrong branch.
    pub const WRONG_BRANCH: usize = 1;
    /// Collision.
    pub const COLLISION: usize = 2;
    /// Timeout.
    pub const TIMEOUT: usize = 3;
}

impl Scenario {
    /// Parses and compiles a scenario file; `origin` names it in errors. A file whose groups
    /// run controller files is refused: [`Scenario::parse_with`] is given their texts.
    pub fn parse(text: &str, origin: &str) -> Result<Scenario, ScenarioError> {
        Scenario::parse_with(text, origin, &no_controller_files)
    }

    /// Parses and compiles a scenario file whose groups may run controller files, whose texts
    /// `controllers` gives by the path as written; `origin` names it in errors.
    pub fn parse_with(
        text: &str,
        origin: &str,
        controllers: ControllerSource<'_>,
    ) -> Result<Scenario, ScenarioError> {
        let error = |path: &str, line: Option<usize>, message: String| ScenarioError {
            origin: origin.to_string(),
            path: path.to_string(),
            line,
            message,
        };
        if text.len() > MAX_SCENARIO_BYTES {
            return Err(error(
                "",
                None,
                format!(
                    "is {} bytes, at most {MAX_SCENARIO_BYTES} are accepted",
                    text.len()
                ),
            ));
        }
        let deserializer = toml::Deserializer::parse(text).map_err(|e| {
            error(
                "",
                e.span().map(|span| line_of(text, span.start)),
                crate::scenario::bounded(&e.to_string()),
            )
        })?;
        let file: ScenarioFile = serde_path_to_error::deserialize(deserializer).map_err(|e| {
            let line = e.inner().span().map(|span| line_of(text, span.start));
            // A key path holds the file's own keys, which may be of any length.
            error(
                &bounded_path(&e.path().to_string()),
                line,
                crate::scenario::bounded(e.inner().message()),
            )
        })?;
        compile::compile(file, text, origin, controllers)
    }

    /// A shipped scenario by name (or alias), compiled once per process.
    pub fn shipped(name: &str) -> Option<Arc<Scenario>> {
        static COMPILED: OnceLock<Vec<Arc<Scenario>>> = OnceLock::new();
        let all = COMPILED.get_or_init(|| {
            SHIPPED
                .iter()
                .map(|(name, text)| {
                    Arc::new(
                        Scenario::parse(text, &format!("scenarios/{name}.toml"))
                            .unwrap_or_else(|e| panic!("a shipped scenario is invalid: {e}")),
                    )
                })
                .collect()
        });
        all.iter()
            .find(|s| s.file.name == name || s.file.aliases.iter().any(|a| a == name))
            .cloned()
    }

    /// The names of the shipped scenarios (and their aliases).
    pub fn shipped_names() -> Vec<&'static str> {
        let mut names: Vec<&'static str> = SHIPPED.iter().map(|(name, _)| *name).collect();
        names.push("maze_single");
        names
    }

    /// Whether the robot has a sensor for every group of `groups` (those a controller's nodes
    /// read); else which one it lacks, for the message that refuses the controller.
    pub fn check_sensors(&self, groups: &[InputGroup]) -> Result<(), String> {
        check_sensors(self.sensors, self.name(), groups)
    }

    /// A refusal of this file at key path `path`, found after it compiled (when a task or a
    /// controller meets it): the file, the key's line and the problem, as a parse error gives.
    pub fn refusal(&self, path: &str, message: String) -> ScenarioError {
        ScenarioError {
            origin: self.origin.clone(),
            path: path.to_string(),
            line: line_of_path(&self.source, path),
            message,
        }
    }

    /// Its name.
    pub fn name(&self) -> &str {
        &self.file.name
    }

    /// The task name its content hash is computed under, for the shipped paper tasks.
    pub fn legacy(&self) -> Option<&str> {
        self.file.legacy.as_deref()
    }

    /// How many variants a sample can be asked for (1 when the file lists none).
    pub fn n_variants(&self) -> u32 {
        self.variants.len() as u32
    }

    /// How many values a sample's reported variant can take: the variants, or for a turning
    /// corridor its shape (bend, T end, side junction), which is drawn, never asked for.
    pub fn reported_variants(&self) -> u32 {
        match self.world.shapes().len() {
            0 => self.n_variants(),
            n_shapes => n_shapes as u32,
        }
    }

    /// The name of variant `idx` as reports show it.
    pub fn variant_label(&self, idx: u32) -> Option<String> {
        let shapes = self.world.shapes();
        match shapes.len() {
            1.. => Some(
                shapes
                    .get(idx as usize)
                    .map_or_else(|| format!("shape {idx}"), |s| s.to_string()),
            ),
            _ if self.variants.len() > 1 => self.variants.get(idx as usize).map(|v| v.name.clone()),
            _ => None,
        }
    }

    /// The last stage a sample can reach: one per stage, and solved.
    pub fn max_stage(&self) -> u8 {
        self.stages.len() as u8 + 1
    }

    /// The stages' names, then `solved`.
    pub fn stage_names(&self) -> Vec<String> {
        let mut names: Vec<String> = self.stages.iter().map(|s| s.name.clone()).collect();
        names.push("solved".into());
        names
    }

    /// The behaviour descriptor's quantities' names, in order.
    pub fn descriptor_names(&self) -> Vec<&str> {
        self.descriptor
            .iter()
            .map(|&idx| self.quantities[idx].0.as_str())
            .collect()
    }

    /// The least and most each of the behaviour descriptor's values can be, in order.
    pub fn descriptor_ranges(&self) -> Vec<(f32, f32)> {
        self.descriptor
            .iter()
            .map(|&idx| self.quantities[idx].1.range(self.phases.len()))
            .collect()
    }

    /// Whether it has a derived fitness (an arbitrator's scenario).
    pub fn has_phases(&self) -> bool {
        !self.phases.is_empty()
    }

    /// The number of robots in a sample, the focal robot included.
    pub fn n_robots(&self) -> usize {
        1 + self
            .robot_groups
            .iter()
            .map(|group| group.count as usize)
            .sum::<usize>()
    }

    /// This scenario with a team of `n_robots` robots, the focal one included: for measuring
    /// how a cycle's cost grows with the team. The first group grows or shrinks to make up the
    /// number, the other groups stay as they are. At 1 the groups go, and with them the
    /// conditions, fitness and descriptor, whose team terms need other robots: the sample then
    /// runs to its cycle limit with a fitness of 0.
    pub fn with_team_size(&self, n_robots: u32) -> Result<Scenario, ScenarioError> {
        let mut file = self.file.clone();
        let refuse = |message: String| self.refusal("robots", message);
        if file.robot_groups.is_empty() {
            return Err(refuse("has no [[robots]] to resize".into()));
        }
        if n_robots <= 1 {
            file.robot_groups.clear();
            file.end = file::EndDecl {
                solved: "not always".into(),
                wrong_branch: None,
                wrong_branch_ends: true,
                forbidden: None,
                near_m: 0.0,
            };
            file.fitness = file::FitnessDecl {
                solved: "0".into(),
                wrong_branch: None,
                collision: None,
                timeout: None,
                otherwise: Some("0".into()),
            };
            file.phases.clear();
            file.stages.clear();
            file.descriptor = None;
        } else {
            let others: u32 = file.robot_groups[1..].iter().map(|group| group.count).sum();
            let first = (n_robots - 1)
                .checked_sub(others)
                .filter(|&count| count > 0);
            let Some(first) = first else {
                return Err(refuse(format!(
                    "a team of {n_robots} cannot hold the {others} robots of its other groups \
                     and at least one of the first"
                )));
            };
            file.robot_groups[0].count = first;
        }
        let text = toml::to_string(&file)
            .map_err(|error| refuse(format!("cannot be written back: {error}")))?;
        Scenario::parse_with(
            &text,
            &format!("{} (a team of {n_robots})", self.origin),
            &|path| self.controller_file(path),
        )
    }

    /// Whether other robots run copies of the controller being evaluated: a caller that
    /// steps the focal robot itself (an `Episode`) has no controller to give them.
    pub fn has_evolved_team(&self) -> bool {
        self.robot_groups
            .iter()
            .any(|group| matches!(group.driver, GroupDriver::Evolved))
    }

    /// What its world holds that the robot's sensors may sense.
    pub fn sensed_world(&self) -> SensedWorld {
        SensedWorld {
            has_lights: !self.lights.is_empty(),
            has_teammate: self.teammate.is_some(),
            has_team: !self.robot_groups.is_empty(),
            has_items: !self.object_groups.is_empty(),
        }
    }

    /// Each box's radius, group by group, box by box (empty without boxes).
    pub fn box_radii(&self) -> Vec<f32> {
        self.box_groups
            .iter()
            .flat_map(|group| std::iter::repeat_n(group.radius, group.count as usize))
            .collect()
    }

    /// Whether a sample has movers or boxes, bodies the robots must not overlap.
    pub fn has_bodies(&self) -> bool {
        !self.movers.is_empty() || !self.box_groups.is_empty()
    }

    /// The number of items in a sample.
    pub fn n_items(&self) -> usize {
        self.object_groups
            .iter()
            .map(|group| group.count as usize)
            .sum()
    }

    /// A content hash of the scenario's text and of the controller files its groups run.
    pub fn content_hash(&self) -> String {
        if self.controller_files.is_empty() {
            return fnv1a_hex(self.source.as_bytes());
        }
        let mut hasher = Fnv1a::new();
        hasher.write_str(&self.source);
        for (path, text) in &self.controller_files {
            hasher.write_str(path);
            hasher.write_str(text);
        }
        format!("{:016x}", hasher.finish())
    }

    /// The text of the controller file a group runs, by the path as written: the
    /// [`ControllerSource`] that compiles this scenario again.
    pub fn controller_file(&self, path: &str) -> Result<String, String> {
        self.controller_files
            .get(path)
            .cloned()
            .ok_or_else(|| no_controller_files(path).unwrap_err())
    }

    /// The children the phases ask for by name, each once, in the phases' order: what an
    /// arbitrator over this scenario must have among its children.
    pub fn named_phase_children(&self) -> Vec<&str> {
        let mut names: Vec<&str> = Vec::new();
        for phase in &self.phases {
            if let ChildRef::Name(name) = &phase.child
                && !names.contains(&name.as_str())
            {
                names.push(name);
            }
        }
        names
    }

    /// Resolves each phase's child to an output index of an arbitrator with these children;
    /// a phase asking for a child the arbitrator lacks is refused at its `phase[i].child`.
    pub fn phase_children(&self, children: &[String]) -> Result<Vec<usize>, ScenarioError> {
        self.phases
            .iter()
            .enumerate()
            .map(|(phase_idx, phase)| {
                let refuse =
                    |message: String| self.refusal(&format!("phase[{phase_idx}].child"), message);
                match &phase.child {
                    ChildRef::Index(idx) if *idx < children.len() => Ok(*idx),
                    ChildRef::Index(idx) => Err(refuse(format!(
                        "phase '{}' asks for child {idx}, the arbitrator has {}",
                        phase.name,
                        children.len()
                    ))),
                    ChildRef::Name(name) => {
                        children.iter().position(|c| c == name).ok_or_else(|| {
                            refuse(format!(
                                "phase '{}' asks for the child '{name}', the arbitrator's \
                                 children are {}",
                                phase.name,
                                children.join(", ")
                            ))
                        })
                    }
                }
            })
            .collect()
    }
}

/// The line (from 1) of byte offset `at` in `text`.
fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}

/// The line a key path such as `phase[1].when` names in `text`: the key's own line, or, for a
/// key the file leaves to its default, the line of the nearest written table or key above it.
/// `None` when the text names nothing on the path (the path is then the whole file's).
fn line_of_path(text: &str, path: &str) -> Option<usize> {
    use toml::de::{DeTable, DeValue};
    let root = DeTable::parse(text).ok()?;
    let mut table = Some(root.get_ref());
    let mut line = None;
    'path: for segment in path.split('.').filter(|segment| !segment.is_empty()) {
        let mut parts = segment.split('[');
        let key = parts.next().unwrap_or_default();
        let Some((written_key, mut value)) =
            table.and_then(|t| t.iter().find(|(k, _)| k.get_ref() == key))
        else {
            break;
        };
        line = Some(line_of(text, written_key.span().start));
        for index in parts.map(|i| i.trim_end_matches(']')) {
            let item = match (value.get_ref(), index.parse::<usize>()) {
                (DeValue::Array(items), Ok(idx)) => items.get(idx),
                _ => None,
            };
            let Some(item) = item else {
                break 'path;
            };
            value = item;
            line = Some(line_of(text, item.span().start));
        }
        table = match value.get_ref() {
            DeValue::Table(inner) => Some(inner),
            _ => None,
        };
    }
    line
}

/// A parser's message cut to a bounded length: an error must not quote a huge input back.
pub fn bounded(message: &str) -> String {
    const MAX: usize = 400;
    let message = message.trim();
    if message.chars().count() <= MAX {
        message.to_string()
    } else {
        format!("{} …", message.chars().take(MAX).collect::<String>())
    }
}

/// A key path cut to a bounded length, like a parser's message.
fn bounded_path(path: &str) -> String {
    const MAX: usize = 120;
    if path.chars().count() <= MAX {
        path.to_string()
    } else {
        format!("{} …", path.chars().take(MAX).collect::<String>())
    }
}

/// A shipped map, by name.
fn shipped_map(name: &str) -> Option<&'static str> {
    SHIPPED_MAPS
        .iter()
        .find(|(map, _)| *map == name)
        .map(|(_, text)| *text)
}

/// Refuses a map whose size alone is too much, before any cell is built: its cell size, how
/// many cells its grid spans ([`MAX_MAP_CELLS`]), and how far from the origin its cells reach
/// (the scene's lookup table covers them in 0.1 m cells, as for `world.solids`).
fn check_map_size(file: &MapFile) -> Result<(), (String, String)> {
    let bad = |path: &str, message: String| Err((path.to_string(), message));
    if !(file.cell_size > 0.0 && file.cell_size <= MAX_CELL_SIZE) {
        return bad(
            "cell_size",
            format!("must be a positive number of metres, at most {MAX_CELL_SIZE}"),
        );
    }
    let rows = || {
        file.grid
            .lines()
            .map(str::trim_end)
            .filter(|row| !row.is_empty())
    };
    let n_rows = rows().count();
    let widest = rows().map(|row| row.chars().count()).max();
    let spanned = n_rows.saturating_mul(widest.unwrap_or(0));
    if spanned > MAX_MAP_CELLS {
        return bad(
            "grid",
            format!(
                "spans {n_rows} rows x {} columns = {spanned} cells, at most {MAX_MAP_CELLS} \
                 are accepted",
                widest.unwrap_or(0)
            ),
        );
    }
    // The farthest cell centre, in cells, on either axis: columns run right of the origin,
    // rows down from it.
    let reach = |origin: i32, last: f64| f64::from(origin).abs().max(last.abs());
    let last_column = f64::from(file.origin[0]) + widest.unwrap_or(0) as f64;
    let last_row = f64::from(file.origin[1]) - n_rows as f64;
    let farthest = reach(file.origin[0], last_column).max(reach(file.origin[1], last_row))
        * f64::from(file.cell_size);
    if farthest > f64::from(MAX_SOLID_COORDINATE) {
        return bad(
            "origin",
            format!(
                "the map's cells reach {farthest:.1} m from the origin, at most {MAX_SOLID_COORDINATE} m"
            ),
        );
    }
    Ok(())
}

/// Builds the cells and regions of a map drawn as text.
pub fn compile_map(file: &MapFile) -> Result<CompiledMap, (String, String)> {
    let bad = |path: &str, message: String| Err((path.to_string(), message));
    check_map_size(file)?;
    if !(file.wall_thickness > 0.0 && file.wall_thickness < file.cell_size) {
        return bad(
            "wall_thickness",
            "must be positive and thinner than a cell".into(),
        );
    }
    let mut meaning: BTreeMap<char, Option<String>> = BTreeMap::new();
    for (symbol, what) in &file.legend {
        let mut chars = symbol.chars();
        let (Some(c), None) = (chars.next(), chars.next()) else {
            return bad(
                &format!("legend.{symbol}"),
                "a legend key is one character".into(),
            );
        };
        let region = match what.as_str() {
            "solid" => None,
            "open" => Some(String::new()),
            name => Some(name.to_string()),
        };
        meaning.insert(c, region);
    }
    let rows: Vec<&str> = file
        .grid
        .lines()
        .map(str::trim_end)
        .filter(|l| !l.is_empty())
        .collect();
    if rows.is_empty() {
        return bad("grid", "is empty".into());
    }
    let mut open: Vec<([i32; 2], Option<String>)> = Vec::new();
    for (row_idx, row) in rows.iter().enumerate() {
        for (col_idx, c) in row.chars().enumerate() {
            let Some(region) = meaning.get(&c) else {
                return bad(
                    "grid",
                    format!(
                        "unknown map symbol '{c}' at row {} column {}: add it to [legend]",
                        row_idx + 1,
                        col_idx + 1
                    ),
                );
            };
            if let Some(region) = region {
                let at = [
                    file.origin[0] + col_idx as i32,
                    file.origin[1] - row_idx as i32,
                ];
                open.push((at, (!region.is_empty()).then(|| region.clone())));
            }
        }
    }
    if open.is_empty() {
        return bad("grid", "has no open cell".into());
    }
    let open_cells: std::collections::HashSet<[i32; 2]> = open.iter().map(|(at, _)| *at).collect();
    let is_open = |at: [i32; 2]| open_cells.contains(&at);
    let cells: Vec<Cell> = open
        .iter()
        .map(|(at, _)| Cell {
            at: *at,
            walls: crate::geometry::cells::Side::ALL.map(|side| {
                let [dx, dy] = side.offset();
                !is_open([at[0] + dx, at[1] + dy])
            }),
        })
        .collect();
    if meaning.values().flatten().filter(|n| !n.is_empty()).count() > MAX_REGIONS {
        return bad("legend", format!("names more than {MAX_REGIONS} regions"));
    }
    let mut regions: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (cell_idx, (_, region)) in open.iter().enumerate() {
        if let Some(region) = region {
            regions.entry(region.clone()).or_default().push(cell_idx);
        }
    }
    for name in meaning.values().flatten().filter(|n| !n.is_empty()) {
        if !regions.contains_key(name) {
            return bad(
                "legend",
                format!("the region '{name}' has no cell in the grid"),
            );
        }
    }
    Ok(CompiledMap {
        map: CellMap::new(cells, file.cell_size, file.wall_thickness),
        regions,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_path_finds_its_line() {
        let text = "name = \"x\"\n\n[end]\nsolved = \"in goal\"\n\n[[phase]]\nwhen = \"a\"\n\n\
                    [[phase]]\nchild = 1\nwhen = \"b\"\n\n[regions]\nbay = { rect = [0, 0, 1, 1] }\n";
        for (path, line) in [
            ("name", Some(1)),
            ("end.solved", Some(4)),
            ("phase[0].when", Some(7)),
            ("phase[1].when", Some(11)),
            ("regions.bay.rect", Some(14)),
            // A key left to its default: the nearest written place above it.
            ("end.wrong_branch", Some(3)),
            ("phase[1].name", Some(9)),
            ("phase[7].when", Some(6)),
            ("world.map", None),
            ("", None),
        ] {
            assert_eq!(line_of_path(text, path), line, "{path}");
        }
    }

    #[test]
    fn a_maps_reach_counts_its_rows_down_from_the_origin() {
        let map = |origin_y: i32, rows: usize| MapFile {
            cell_size: 1.0,
            wall_thickness: 0.1,
            origin: [0, origin_y],
            grid: vec!["."; rows].join("\n"),
            legend: BTreeMap::from([(".".to_string(), "open".to_string())]),
        };
        // Rows 40 down to -19: within 50 m.
        assert!(check_map_size(&map(40, 60)).is_ok());
        // Rows -40 down to -59: beyond.
        let (key, message) = check_map_size(&map(-40, 20)).unwrap_err();
        assert_eq!(key, "origin");
        assert!(message.contains("at most 50 m"), "{message}");
    }

    #[test]
    fn every_shipped_scenario_compiles() {
        for (name, _) in SHIPPED {
            let scenario = Scenario::shipped(name).unwrap();
            assert_eq!(scenario.name(), name);
            assert_eq!(scenario.legacy(), Some(name));
        }
        assert_eq!(
            Scenario::shipped("maze_single").unwrap().name(),
            "solve_maze"
        );
        assert!(Scenario::shipped("nope").is_none());
    }

    #[test]
    fn a_descriptor_is_the_final_position_unless_the_file_lists_quantities() {
        for (name, _) in SHIPPED {
            let scenario = Scenario::shipped(name).unwrap();
            assert_eq!(scenario.descriptor_names(), DEFAULT_DESCRIPTOR, "{name}");
        }
        // A user's copy of exit room: the shipped file under another name, without the keys
        // reserved for shipped scenarios.
        let exit_room: String = SHIPPED[0]
            .1
            .lines()
            .filter(|line| !line.starts_with("legacy") && !line.starts_with("aliases"))
            .map(|line| match line.starts_with("name = ") {
                true => "name = \"my_exit_room\"\n".to_string(),
                false => format!("{line}\n"),
            })
            .collect();
        let with = |quantities: &str| {
            Scenario::parse(
                &format!("{exit_room}\n[descriptor]\nquantities = [{quantities}]\n"),
                "test.toml",
            )
        };
        // The formulas' quantities keep their indices; a shared one is compiled once.
        let plain = Scenario::shipped("exit_room").unwrap();
        let scenario = with("\"approach room.exit\", \"final.y\", \"time_bonus\"").unwrap();
        assert_eq!(
            scenario.descriptor_names(),
            ["approach room.exit", "final.y", "time_bonus"]
        );
        let names = |s: &Scenario| {
            s.quantities
                .iter()
                .map(|(n, _)| n.clone())
                .collect::<Vec<_>>()
        };
        // (Exit room's formulas name neither final.x nor final.y.)
        let n_formulas = plain.quantities.len() - DEFAULT_DESCRIPTOR.len();
        assert_eq!(names(&scenario)[..n_formulas], names(&plain)[..n_formulas]);
        assert_eq!(
            scenario.quantities.len(),
            n_formulas + 1,
            "final.y alone is new"
        );
        assert_eq!(
            scenario.descriptor_ranges()[1],
            (
                -blocks::quantities::MAX_FINAL_COORDINATE,
                blocks::quantities::MAX_FINAL_COORDINATE
            )
        );
        for (quantities, wanted) in [
            ("", "lists 0 quantities"),
            ("\"speed\"", "'speed' is not a quantity"),
            ("\"final.x\", \"final.x\"", "'final.x' is listed twice"),
            ("\"approach teammate\"", "needs a [teammate]"),
        ] {
            let error = with(quantities).unwrap_err().to_string();
            assert!(
                error.contains("descriptor.quantities") && error.contains(wanted),
                "{quantities}: {error}"
            );
        }
    }

    #[test]
    fn the_double_t_maze_map_has_the_paper_layout() {
        let maze = Scenario::shipped("solve_maze").unwrap();
        let map = maze.map.as_ref().unwrap();
        assert_eq!(map.map.cells.len(), 19);
        for (region, at) in [
            ("entrance", [0, -5]),
            ("branch_a", [3, 1]),
            ("branch_b", [3, -3]),
            ("branch_c", [-3, 1]),
            ("branch_d", [-3, -3]),
        ] {
            let cells = &map.regions[region];
            assert_eq!(cells.len(), 1);
            assert_eq!(map.map.cells[cells[0]].at, at, "{region}");
        }
    }
}
