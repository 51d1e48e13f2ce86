//! What an episode reports, as plain data: the sample it ran ([`Sample`]), how it ended
//! ([`Ending`], [`Outcome`]), how the controller's nodes took turns ([`NodeUse`],
//! [`SubTaskChoices`]) and, for replays, every cycle ([`Trace`]). Nothing here runs anything;
//! the engine, the service and the pictures read these types without knowing how they were
//! made.

use crate::body::Pose;
use crate::geometry::scene::Rect;
use crate::sensors::frame::SensorFrame;
use serde::{Deserialize, Serialize};

/// One sample: its seed, and optionally a fixed variant (light configuration or start branch)
/// instead of one drawn from the seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sample {
    /// The sample's seed: every random choice of the sample derives from it.
    pub seed: u64,
    /// Light configuration (maze, rescue) or branch (return to room); drawn when `None`.
    pub variant: Option<u32>,
}

impl Sample {
    /// A sample whose variant is drawn from its seed.
    pub fn seeded(seed: u64) -> Sample {
        Sample {
            seed,
            variant: None,
        }
    }
}

/// Why a sample ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ending {
    /// The task's goal was reached.
    Solved,
    /// The robot touched a wall or obstacle and the task ends on collisions.
    Collision,
    /// The robot entered a branch off the correct path, or a region the scenario forbids.
    WrongBranch,
    /// The cycle limit ran out. The default: a summary made without an outcome (a test's)
    /// claims nothing happened.
    #[default]
    Timeout,
}

impl Ending {
    /// Every ending, in the order of their codes (`Ending::ALL[code]`), as Python arrays and
    /// other tables number them.
    pub const ALL: [Ending; 4] = [
        Ending::Solved,
        Ending::Collision,
        Ending::WrongBranch,
        Ending::Timeout,
    ];

    /// The name a trace's outcome writes (`"wrong_branch"`).
    pub fn name(self) -> &'static str {
        match self {
            Ending::Solved => "solved",
            Ending::Collision => "collision",
            Ending::WrongBranch => "wrong_branch",
            Ending::Timeout => "timeout",
        }
    }

    /// Its index in [`Ending::ALL`].
    pub fn code(self) -> u8 {
        self as u8
    }
}

/// The result of one sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    /// The task's fitness.
    pub fitness: f32,
    /// Whether the goal was reached (for rescue: the teammate brought back into the room).
    pub solved: bool,
    /// Whether the robot touched a wall or obstacle at any time.
    pub collided: bool,
    /// Why the sample ended.
    pub ending: Ending,
    /// Cycles run.
    pub cycles: u32,
    /// Furthest stage reached: rescue 0 none, 1 left the room, 2 found the teammate, 3 brought
    /// it back; other tasks 1 when solved, else 0.
    pub stage: u8,
    /// The variant the sample ran (light configuration or start branch; 0 for other tasks,
    /// except corridors: the turn's shape, 0 for an L-bend (and every straight corridor), 1
    /// for a T-end, 2 for a side junction).
    pub variant: u32,
    /// How long and how often each controller node drove, indexed like the policy's nodes.
    pub node_use: NodeUse,
    /// Rescue only: how the root chose in each sub-task (all zero for other tasks).
    pub sub_task_choices: SubTaskChoices,
    /// The behaviour descriptor: the value of each of the scenario's descriptor quantities
    /// (the final position unless the scenario says otherwise).
    pub descriptor: Vec<f32>,
}

/// How a controller's nodes took turns in one sample, per node in pre-order (the root first):
/// the cycles each was active and how often it was switched on (active in a cycle but not in
/// the one before). An arbitrator that keeps a child on for hundreds of cycles and one that
/// flicks between two children every few cycles can score alike; these counts tell them apart.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NodeUse {
    /// Cycles each node was active.
    pub active_cycles: Vec<u32>,
    /// How often each node became active; never more than its active cycles.
    pub activations: Vec<u32>,
}

/// Rescue's sub-tasks, in the order of the rescue arbitrator's children: exit the room, solve
/// the maze, return to the room.
pub const N_SUB_TASKS: usize = 6;

/// How often the rescue arbitrator chose the sub-controller that the environment's ground truth
/// asks for, per sub-task: the raw counts behind the derived fitness f3.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SubTaskChoices {
    /// Cycles spent in each sub-task.
    pub cycles: [u32; N_SUB_TASKS],
    /// Of those, cycles in which the root chose that sub-task's child.
    pub correct: [u32; N_SUB_TASKS],
}

impl SubTaskChoices {
    /// Each sub-task's share of correct choices; `None` for a sub-task the sample never
    /// reached (the teammate never found, say), which f3 leaves out of its sum.
    pub fn shares(&self) -> [Option<f32>; N_SUB_TASKS] {
        std::array::from_fn(|s| {
            (self.cycles[s] > 0).then(|| self.correct[s] as f32 / self.cycles[s] as f32)
        })
    }

    /// f3, the derived fitness: the sum of the shares of the sub-tasks reached (at most 3).
    pub fn derived_fitness(&self) -> f32 {
        self.shares().into_iter().flatten().sum()
    }
}

/// One cycle of a trace.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TraceCycle {
    /// Robot pose at the start of the cycle (when the sensors were read).
    pub robot: Pose,
    /// Teammate pose, if the task has one.
    pub teammate: Option<Pose>,
    /// The inputs the controller read.
    pub frame: SensorFrame,
    /// The controller's wheel outputs, in [0, 1].
    pub wheels: [f32; 2],
    /// Active node indices, root first.
    pub active_path: Vec<u16>,
    /// Whether the move of this cycle was undone by a collision.
    pub collided: bool,
    /// Bit i set when light i was lit this cycle.
    pub lit_lights: u32,
    /// The rescue sub-task in force (0 exit room, 1 solve maze, 2 return), else 0.
    pub sub_task: u8,
    /// A team's other robots' poses at the start of the cycle, group by group (`[[robots]]`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub team: Vec<Pose>,
    /// The movers' then the boxes' centres at the start of the cycle (`[[movers]]`,
    /// `[[boxes]]`), in the order of the trace's `movers` and `boxes`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub bodies: Vec<[f32; 2]>,
    /// Each item at the start of the cycle (`[[objects]]`), in the order of the trace's
    /// `items`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub items: Vec<CycleItem>,
}

/// Where one item is in one cycle of a trace. An item on the floor is where it lies; a carried
/// one is at its carrier's centre; a delivered one stays where its carrier delivered it (the
/// carrier's centre on entering the nest), flagged so a replay can draw it as done.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CycleItem {
    /// Where it is.
    pub at: [f32; 2],
    /// Whether a robot carries it.
    pub carried: bool,
    /// Whether it has been delivered in the nest.
    pub delivered: bool,
}

/// One item of a trace: where it lay at the start and where it ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TracedItem {
    /// Where it lay at the sample's start.
    pub start: [f32; 2],
    /// Where it lies, or its carrier stands, or it was delivered, at the end.
    pub end: [f32; 2],
    /// Whether it was delivered in the nest.
    pub delivered: bool,
    /// Whether a robot carries it at the end.
    pub carried: bool,
}

/// One mover of a trace: its path and where it ended.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TracedMover {
    /// Its name.
    pub name: String,
    /// Its radius, metres.
    pub radius: f32,
    /// Its waypoints.
    pub path: Vec<[f32; 2]>,
    /// Whether it runs the path as a loop (else back and forth).
    pub looped: bool,
    /// Where it stands at the end.
    pub end: [f32; 2],
}

/// One box of a trace: where it stood at the start and where it ended.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TracedBox {
    /// Its radius, metres.
    pub radius: f32,
    /// Where it stood at the sample's start.
    pub start: [f32; 2],
    /// Where it stands at the end.
    pub end: [f32; 2],
}

/// What a replay needs to draw a sample: the world and every cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Trace {
    /// The scenario's name.
    pub scenario: String,
    /// The variant's name as reports show it, if the scenario has several.
    pub variant_label: Option<String>,
    /// Whether the scenario has a derived fitness whose last phase is the way back (the path
    /// is drawn twice: out, and back over it).
    pub has_phases: bool,
    /// The sample.
    pub sample: Sample,
    /// Walls and obstacles.
    pub rects: Vec<Rect>,
    /// Stem lights: position and whether they flash in this sample.
    pub lights: Vec<([f32; 2], bool)>,
    /// Centre of the goal cell, for cell tasks and rescue (the teammate's branch end).
    pub goal: Option<[f32; 2]>,
    /// Exit of the room: centre on the inner face, outward unit vector.
    pub exit: Option<([f32; 2], [f32; 2])>,
    /// The cycles, in order.
    pub cycles: Vec<TraceCycle>,
    /// A team's groups of other robots (`[[robots]]`), in the order of each cycle's `team`:
    /// name and count, so a replay can tell the groups apart (empty without a team).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub team_groups: Vec<(String, u32)>,
    /// The items of a scenario with `[[objects]]`, by item (empty without).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub items: Vec<TracedItem>,
    /// The movers of a scenario with `[[movers]]`, by mover (empty without).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub movers: Vec<TracedMover>,
    /// The boxes of a scenario with `[[boxes]]`, by box (empty without).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boxes: Vec<TracedBox>,
    /// The final pose of the robot.
    pub final_robot: Pose,
    /// The final poses of a team's other robots, in the order of each cycle's `team` (empty
    /// without a team).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub final_team: Vec<Pose>,
    /// The outcome.
    pub outcome: Outcome,
}

impl Trace {
    /// A name for each of the team's other robots, in the order of each cycle's `team`: the
    /// group's name and the robot's index in its group, `swarm_0`, `swarm_1`, ... (empty
    /// without a team). Trace tables and Python's poses name their columns with it.
    pub fn team_member_names(&self) -> Vec<String> {
        self.team_groups
            .iter()
            .flat_map(|(name, count)| (0..*count).map(move |idx| format!("{name}_{idx}")))
            .collect()
    }
}
