//! The building blocks a scenario file names, and the one place they are registered. A block
//! is a small type implementing one trait: a world ([`World`]: a map, a generated room or
//! corridor, their joins), a condition's atom ([`Atom`]: `in goal`, `near LIGHT`, `LIGHT lit`, ...; the
//! phases, the stages and `end.solved` are conditions), a fitness quantity ([`Quantity`]:
//! `time_bonus`, `approach NAME`, ...), or how the teammate moves ([`TeammateBehaviour`]:
//! `follow`, `fixed`, `wander`). Each kind of block has a registry below ([`WORLDS`], [`ATOMS`],
//! [`QUANTITIES`], [`BEHAVIOURS`]; the robot's sensors, a floor below, have theirs in
//! [`crate::sensors::registry`]): the scenario compiler asks the registered
//! blocks in order which one a piece of the file names, and the evaluator only ever calls the
//! compiled blocks' traits. A new block is one file in this folder and one line in its
//! registry; docs/dev/extending.md walks through one.
//!
//! Blocks compile once per scenario (names resolved to indices, regions to tests, requirements
//! checked against [`Facts`]), so in the control loop a block does arithmetic on what it sees
//! ([`CycleView`]), never a lookup by name.

pub mod atoms;
pub mod boxes;
pub mod items;
pub mod quantities;
pub mod team;
pub mod teammates;
pub mod worlds;

use crate::body::Pose;
use crate::config::Params;
use crate::geometry::bodies::Disc;
use crate::geometry::cells::CellMap;
use crate::geometry::items::Items;
use crate::geometry::scene::Scene;
use crate::math::rng::SimRng;
use crate::outcome::SubTaskChoices;
use crate::scenario::file::WorldDecl;
use crate::scenario::{CompiledMap, LightDef, Scenario};
use crate::world::Ground;
use crate::world::room::Room;
use atoms::RegionTest;
use std::fmt::Debug;
use std::sync::Arc;

/// The worlds (the combinations of `map`, `room` and `corridor` they recognise are disjoint; a
/// random maze, first, takes every table with a `maze`).
pub static WORLDS: &[WorldKind] = &[
    worlds::RANDOM_MAZE,
    worlds::MAP,
    worlds::ROOM,
    worlds::CORRIDOR,
    worlds::CORRIDOR_BEYOND_MAP,
    worlds::ROOM_BELOW_MAP,
    worlds::ROOM_BELOW_CORRIDOR,
    worlds::SOLIDS,
];

/// The condition atoms, in the order the compiler tries them (the first that recognises the
/// text wins, so `in REGION` comes after the `in` atoms with fixed names).
pub static ATOMS: &[AtomKind] = &[
    atoms::IN_MAZE,
    atoms::IN_GOAL,
    atoms::IN_REGION,
    atoms::TEAMMATE_FOLLOWING,
    atoms::TEAMMATE_IN_ROOM,
    atoms::BEYOND_EXIT,
    atoms::NEAR,
    team::TEAM_GATHERED,
    team::TEAM_DISPERSED,
    team::TEAM_IN_REGION,
    atoms::LIGHT_LIT,
    items::ALL_DELIVERED,
    items::CARRYING,
    boxes::BOXES_IN_REGION,
    atoms::ALWAYS,
];

/// The fitness quantities, in the order the compiler tries them.
pub static QUANTITIES: &[QuantityKind] = &[
    quantities::TIME_BONUS,
    quantities::PROGRESS,
    quantities::DERIVED,
    quantities::APPROACH,
    quantities::FINAL_POSITION,
    quantities::DISTANCE,
    quantities::ENERGY,
    team::TEAM_SPREAD,
    team::TEAM_NEAREST,
    team::TEAM_IN,
    items::ITEMS_DELIVERED,
    items::ITEMS_PICKED,
    boxes::BOXES_IN,
];

/// The teammate's behaviours, by the name `teammate.behaviour` gives (the first is the
/// default).
pub static BEHAVIOURS: &[&dyn TeammateBehaviour] =
    &[&teammates::Follow, &teammates::Fixed, &teammates::Wander];

/// What a scenario holds, as far as a block's requirements go: a block that needs a room, a
/// teammate or a goal in cells says so when it compiles, naming what is missing.
pub struct Facts<'a> {
    /// The lights, by index.
    pub lights: &'a [LightDef],
    /// Resolves a region's name to its test, or says why a condition may not name it.
    pub region: &'a dyn Fn(&str) -> Result<RegionTest, String>,
    /// Whether the world holds a generated room.
    pub has_room: bool,
    /// Whether every sample has a goal in cells (a corridor, or a map and a goal in every
    /// variant): the corridor distance to it is known.
    pub goals_in_cells: bool,
    /// Whether the scenario has a teammate.
    pub has_teammate: bool,
    /// Whether the scenario has a team (`[[robots]]`).
    pub has_team: bool,
    /// Whether the scenario has items (`[[objects]]`) and a nest.
    pub has_items: bool,
    /// Whether the scenario has boxes (`[[boxes]]`).
    pub has_boxes: bool,
    /// Whether the scenario has phases (a derived fitness).
    pub has_phases: bool,
    /// `end.near_m`.
    pub near_m: f32,
}

impl std::fmt::Debug for Facts<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Facts")
            .field("lights", &self.lights)
            .field("has_room", &self.has_room)
            .field("goals_in_cells", &self.goals_in_cells)
            .field("has_teammate", &self.has_teammate)
            .field("has_team", &self.has_team)
            .field("has_items", &self.has_items)
            .field("has_boxes", &self.has_boxes)
            .field("has_phases", &self.has_phases)
            .field("near_m", &self.near_m)
            .finish_non_exhaustive()
    }
}

impl Facts<'_> {
    /// A light's index by name.
    pub fn light(&self, name: &str) -> Option<usize> {
        self.lights.iter().position(|light| light.name == name)
    }
}

/// The other robot as a block sees it.
#[derive(Debug, Clone, Copy)]
pub struct TeammateView {
    /// Where it is.
    pub pose: Pose,
    /// Whether it has been met (it follows from then on, unless fixed).
    pub following: bool,
}

/// What a block sees of a sample in one cycle.
#[derive(Debug, Clone, Copy)]
pub struct CycleView<'a> {
    /// The robot.
    pub robot: &'a Pose,
    /// The teammate, in scenarios with one.
    pub teammate: Option<TeammateView>,
    /// The sample's ground truth (room, goal, cells).
    pub ground: &'a Ground,
    /// The scenario.
    pub scenario: &'a Scenario,
    /// The numbers in force.
    pub params: &'a Params,
    /// The cycle limit in force.
    pub max_cycles: u32,
    /// The wheel speeds driven in the cycle just judged (noise included), m/s; 0 before the
    /// first cycle and where no cycle is judged.
    pub wheel_speeds: [f32; 2],
    /// Every robot's position in a team, the focal robot first; empty for a robot alone.
    pub team: &'a [[f32; 2]],
    /// The lights lit in the cycle, one bit per light by index (0 where no cycle is judged).
    pub lit_mask: u32,
    /// The items, in a scenario with `[[objects]]`.
    pub items: Option<&'a Items>,
    /// The boxes where they stand, by box (empty without `[[boxes]]`).
    pub boxes: &'a [Disc],
    /// The world's cell map (the ground's cells, else its goal's) and the robot's cell in it,
    /// found once per view: several blocks of a cycle ask for it, and each finding costs two
    /// divisions.
    world_cell: Option<(&'a CellMap, Option<usize>)>,
}

impl<'a> CycleView<'a> {
    /// What the blocks see of a cycle with the robot at `robot`.
    pub fn new(
        robot: &'a Pose,
        teammate: Option<TeammateView>,
        ground: &'a Ground,
        scenario: &'a Scenario,
        params: &'a Params,
        max_cycles: u32,
    ) -> CycleView<'a> {
        let world_map = ground
            .cells
            .as_deref()
            .or(ground.goal.as_ref().map(|goal| &*goal.map));
        CycleView {
            robot,
            teammate,
            ground,
            scenario,
            params,
            max_cycles,
            wheel_speeds: [0.0; 2],
            team: &[],
            lit_mask: 0,
            items: None,
            boxes: &[],
            world_cell: world_map.map(|map| (map, map.cell_at(robot.position()))),
        }
    }

    /// The view of a cycle whose wheels drove at `wheel_speeds` (m/s).
    #[inline]
    pub fn with_wheel_speeds(self, wheel_speeds: [f32; 2]) -> CycleView<'a> {
        CycleView {
            wheel_speeds,
            ..self
        }
    }

    /// The view of a cycle whose team (the focal robot first) stands at `team`.
    #[inline]
    pub fn with_team(self, team: &'a [[f32; 2]]) -> CycleView<'a> {
        CycleView { team, ..self }
    }

    /// The view of a cycle whose lit lights are `lit_mask` (one bit per light).
    #[inline]
    pub fn with_lit(self, lit_mask: u32) -> CycleView<'a> {
        CycleView { lit_mask, ..self }
    }

    /// The view of a cycle whose items are `items`.
    #[inline]
    pub fn with_items(self, items: Option<&'a Items>) -> CycleView<'a> {
        CycleView { items, ..self }
    }

    /// The view of a cycle whose boxes stand at `boxes`.
    #[inline]
    pub fn with_boxes(self, boxes: &'a [Disc]) -> CycleView<'a> {
        CycleView { boxes, ..self }
    }

    /// The cell of `map` the robot's centre is in, if any: `map.cell_at` of the robot's
    /// position, found once per view for the world's own map.
    #[inline]
    pub fn robot_cell(&self, map: &CellMap) -> Option<usize> {
        match self.world_cell {
            Some((world_map, cell)) if std::ptr::eq(world_map, map) => cell,
            _ => map.cell_at(self.robot.position()),
        }
    }
}

/// What a quantity sees when the sample ends.
#[derive(Debug, Clone, Copy)]
pub struct EndView<'a> {
    /// The last cycle.
    pub cycle: CycleView<'a>,
    /// Cycles run.
    pub cycles: u32,
    /// Which child the arbitrator chose in each phase.
    pub sub_task_choices: &'a SubTaskChoices,
}

/// What a kind of block makes of a piece of a file: `None` when the piece is not its kind's,
/// else the compiled block or what is wrong with the piece.
pub type Recognised<Block, Problem = String> = Option<Result<Box<Block>, Problem>>;

/// A world's refusal: the key and what is wrong.
pub type Refusal = (&'static str, String);

/// One kind of world: how it is written and how it compiles.
#[derive(Debug)]
pub struct WorldKind {
    /// How it is written, for the message that lists what a world may be.
    pub syntax: &'static str,
    /// The compiled world, if the `[world]` table is this kind's; a refusal names its key.
    /// `map` is the table's map, compiled.
    pub compile: fn(decl: &WorldDecl, map: Option<&CompiledMap>) -> Recognised<dyn World, Refusal>,
}

/// What a world makes for one sample.
#[derive(Debug)]
pub struct Built {
    /// The solids.
    pub scene: Arc<Scene>,
    /// The cells, in worlds made of cells.
    pub cells: Option<Arc<CellMap>>,
    /// The generated room.
    pub room: Option<Room>,
    /// A generated corridor's path, its first cell first.
    pub corridor_path: Option<Vec<usize>>,
    /// The shape drawn, reported in place of the variant (a turning corridor's).
    pub shape: Option<u32>,
}

/// What a world keeps between samples: a fixed layout's solids and, if it is made of cells,
/// its cells.
pub type FixedLayout = (Arc<Scene>, Option<Arc<CellMap>>);

/// A compiled world: what it provides, and one sample's layout.
pub trait World: Debug + Send + Sync {
    /// Whether it holds a generated room (regions `room` and `room.exit`, start `room.start`).
    fn has_room(&self) -> bool {
        false
    }
    /// Whether it holds a generated corridor (regions and start `corridor.start`,
    /// `corridor.end`; a goal in cells).
    fn has_corridor(&self) -> bool {
        false
    }
    /// Whether `place.advance` fits it.
    fn advances(&self) -> bool {
        false
    }
    /// Whether it is a fixed map and nothing else.
    fn is_map_alone(&self) -> bool {
        false
    }
    /// The shapes it draws and reports in place of the variant, by index.
    fn shapes(&self) -> &'static [&'static str] {
        &[]
    }
    /// What never changes between samples, built once per evaluator. A world with statics
    /// builds every sample on them: its samples' scene is the statics' scene.
    fn statics(&self, _scenario: &Scenario, _params: &Params) -> Option<FixedLayout> {
        None
    }
    /// One sample's layout, drawn from its environment stream. By default, a fixed world's:
    /// its statics as they are, drawing nothing.
    fn build(
        &self,
        _scenario: &Scenario,
        _params: &Params,
        statics: Option<&FixedLayout>,
        _rng: &mut SimRng,
    ) -> Built {
        let (scene, cells) = statics
            .cloned()
            .expect("a world without statics draws its own layout");
        Built {
            scene,
            cells,
            room: None,
            corridor_path: None,
            shape: None,
        }
    }
}

/// One kind of condition atom: how it is written and how it compiles.
#[derive(Debug)]
pub struct AtomKind {
    /// How it is written, for the message that lists what a condition may say.
    pub syntax: &'static [&'static str],
    /// The compiled atom, if the text is this kind's (`None`: not this kind); an error says
    /// what is wrong with text that is.
    pub compile: fn(text: &str, facts: &Facts<'_>) -> Recognised<dyn Atom>,
}

/// A compiled condition atom: whether it holds in a cycle.
pub trait Atom: Debug + Send + Sync {
    /// Whether it holds.
    fn holds(&self, view: &CycleView<'_>) -> bool;
}

/// One kind of fitness quantity: how it is written and how it compiles.
#[derive(Debug)]
pub struct QuantityKind {
    /// How it is written, for the message that lists what a formula may say.
    pub syntax: &'static [&'static str],
    /// The compiled quantity, if the text is this kind's.
    pub compile: fn(text: &str, facts: &Facts<'_>) -> Recognised<dyn Quantity>,
}

/// What a quantity keeps during a sample: its value at the start and the best so far (a
/// closest approach, say), or a running sum and the last position (a distance travelled).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tracked {
    /// At the start.
    pub start: f32,
    /// The best so far.
    pub best: f32,
    /// A running sum.
    pub sum: f32,
    /// The robot's position when last seen.
    pub last: [f32; 2],
    /// Cycles observed.
    pub cycles: u32,
}

/// A compiled fitness quantity: its value when the sample ends, from what it kept.
pub trait Quantity: Debug + Send + Sync {
    /// Whether it keeps anything during the sample (only those are asked to `observe`).
    fn tracks(&self) -> bool {
        false
    }
    /// What it keeps, seen at the start (before the first cycle).
    fn start(&self, _view: &CycleView<'_>) -> Tracked {
        Tracked::default()
    }
    /// Updates what it keeps, after each cycle's move.
    fn observe(&self, _tracked: &mut Tracked, _view: &CycleView<'_>) {}
    /// Its value.
    fn value(&self, tracked: &Tracked, end: &EndView<'_>) -> f32;
    /// The least and most it can be, for a scenario of `n_phases` phases.
    fn range(&self, _n_phases: usize) -> (f32, f32) {
        (0.0, 1.0)
    }
}

/// How the teammate moves: a name, a check of the file's other teammate keys, and a fresh
/// motion per sample.
pub trait TeammateBehaviour: Debug + Send + Sync {
    /// The name `teammate.behaviour` gives.
    fn name(&self) -> &'static str;
    /// Refuses settings that do not fit (`following`: whether it follows from the start).
    fn check(&self, _following: bool) -> Result<(), String> {
        Ok(())
    }
    /// A sample's motion; may set the starting pose's heading and draw from the sample's own
    /// teammate stream (`sample_seed`). `max_cycles` bounds the trail it may keep.
    fn start(&self, pose: &mut Pose, sample_seed: u64, max_cycles: u32) -> Box<dyn Motion>;
}

/// A teammate's motion during one sample.
pub trait Motion: Debug + Send {
    /// A cycle before it is met.
    fn before_met(&mut self, pose: &mut Pose, step: f32, scene: &Scene, radius: f32);
    /// A cycle once met (from the first on, for one that follows from the start).
    fn after_met(&mut self, pose: &mut Pose, robot: &Pose, step: f32);
}

/// What a block written as a fixed word (one of `words`) makes of `text`: nothing when the text
/// is another word, else the block, or the refusal `missing` when the scenario lacks what the
/// block needs.
pub(crate) fn fixed_word<Block: ?Sized>(
    text: &str,
    words: &[&str],
    missing: Option<&str>,
    make: impl FnOnce() -> Box<Block>,
) -> Recognised<Block> {
    if !words.contains(&text) {
        return None;
    }
    Some(match missing {
        None => Ok(make()),
        Some(why) => Err(why.to_string()),
    })
}

/// `a, b, c or d`.
pub(crate) fn listed(items: impl Iterator<Item = &'static str>) -> String {
    let items: Vec<&str> = items.collect();
    match items.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        Some((last, _)) => last.to_string(),
        None => String::new(),
    }
}

/// The two blocks docs/dev/extending.md shows whole, compiled here as written there
/// and tried, so that the guide a new block starts from never rots.
#[cfg(test)]
mod doc_examples {
    #[path = "compass.rs"]
    mod compass;
    #[path = "east_of.rs"]
    mod east_of;

    // What the examples import from `super`: the blocks module the atom would live in, and
    // the sensors floor the compass would.
    use super::{Atom, AtomKind, CycleView, Facts};
    use crate::body::Pose;
    use crate::episode::evaluator::Evaluator;
    use crate::math::rng::{Stream, stream_rng};
    use crate::outcome::Sample;
    use crate::sensors::registry::SensorKind;
    use crate::sensors::{SenseView, Sensor, SensorRun};
    use crate::task::TaskConfig;

    #[test]
    fn the_extending_guide_shows_each_example_block_as_compiled_here() {
        let guide = include_str!("../../../../docs/dev/extending.md");
        for (name, code) in [
            ("east_of.rs", include_str!("doc_examples/east_of.rs")),
            ("compass.rs", include_str!("doc_examples/compass.rs")),
        ] {
            // As the guide shows it: a code block indented under a list item.
            let shown: String = code
                .lines()
                .map(|line| match line {
                    "" => "\n".to_string(),
                    _ => format!("  {line}\n"),
                })
                .collect();
            assert!(
                guide.contains(&format!("  ```rust\n{shown}  ```\n")),
                "docs/dev/extending.md no longer shows doc_examples/{name} as it is"
            );
        }
    }

    #[test]
    fn the_east_of_example_compiles_its_text_and_judges_the_robots_x() {
        let no_region = |name: &str| Err(format!("no region '{name}'"));
        let facts = Facts {
            lights: &[],
            region: &no_region,
            has_room: false,
            goals_in_cells: false,
            has_teammate: false,
            has_team: false,
            has_items: false,
            has_boxes: false,
            has_phases: false,
            near_m: 0.0,
        };
        let compile = east_of::EAST_OF.compile;
        assert!(compile("in goal", &facts).is_none(), "another atom's text");
        assert!(compile("east of west", &facts).unwrap().is_err());
        let atom = compile("east of 0.3", &facts).unwrap().unwrap();
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let env = Evaluator::new(task.clone())
            .unwrap()
            .environment(Sample::seeded(0));
        for (x, holds) in [(0.29, false), (0.31, true)] {
            let robot = Pose {
                x,
                y: 0.0,
                heading: 0.0,
            };
            let view = CycleView::new(
                &robot,
                None,
                &env.ground,
                &task.scenario,
                &task.params,
                task.max_cycles(),
            );
            assert_eq!(atom.holds(&view), holds, "x = {x}");
        }
    }

    #[test]
    fn the_compass_example_reads_the_heading() {
        let task = TaskConfig::shipped("exit_room").unwrap();
        let sensor = (compass::COMPASS.compile)(&task.params, &task.scenario.sensed_world())
            .expect("always built");
        let env = Evaluator::new(task.clone())
            .unwrap()
            .environment(Sample::seeded(0));
        let mut run = sensor.start(&mut stream_rng(0, Stream::SensorSetup));
        for (heading, expected) in [
            (0.0f32, [1.0, 0.5]),
            (std::f32::consts::FRAC_PI_2, [0.5, 1.0]),
        ] {
            let robot = Pose {
                x: 0.0,
                y: 0.0,
                heading,
            };
            let mut out = [0.0f32; 2];
            run.read(
                &SenseView::unlit(&robot, &env.scene),
                &mut stream_rng(0, Stream::Noise),
                &mut out,
            );
            assert!(
                (out[0] - expected[0]).abs() < 1e-6 && (out[1] - expected[1]).abs() < 1e-6,
                "heading {heading}: {out:?}"
            );
        }
    }
}
