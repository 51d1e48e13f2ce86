//! What a post-evaluation reports (a run summary's `post_evaluation`, `hevo eval --json`): a
//! controller's solve rate over many fresh samples, per variant (light configuration, start
//! branch), per stage and per phase of the derived fitness where the scenario has those, with
//! mean fitness, collisions and how the controller's nodes took turns; and the report as text.
//! The engine computes it from the samples' outcomes; this is its format alone.

use serde::{Deserialize, Serialize};

/// Solve rate of one variant.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantReport {
    /// Light configuration or start branch.
    pub variant: u32,
    /// Its name in the scenario file (scenarios other than the paper's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Samples run.
    pub samples: u32,
    /// Share solved.
    pub solve_rate: f64,
}

/// The result of evaluating one controller on many samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// The task.
    pub task: String,
    /// Samples run.
    pub samples: u32,
    /// Share solved.
    pub solve_rate: f64,
    /// Mean fitness.
    pub mean_fitness: f64,
    /// Share of samples with a collision.
    pub collision_rate: f64,
    /// Mean cycles per sample.
    pub mean_cycles: f64,
    /// Per light configuration / start branch, when the task has several.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_variant: Vec<VariantReport>,
    /// Rescue only: shares that left the room, reached the teammate, brought it back.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stages: Option<StageReport>,
    /// Scenarios other than the paper's, with stages: the share of samples that reached each
    /// stage, in the file's order, then `solved`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_stage: Vec<StageShare>,
    /// Scenarios other than the paper's, with a derived fitness: per phase, how often the
    /// arbitrator chose the child the phase asks for.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub per_phase: Vec<PhaseShare>,
    /// How the controller's nodes below the root took turns, in pre-order; empty for a lone
    /// primitive (and in reports written before hevo counted it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub node_use: Vec<NodeUseReport>,
}

/// How one controller node was used over a post-evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeUseReport {
    /// The node's path in the tree, e.g. `rescue/solve_maze/turn_left`.
    pub node: String,
    /// Share of all cycles in which it was active.
    pub active_share: f64,
    /// How often it was switched on, per sample.
    pub activations_per_sample: f64,
    /// How long it stayed on once switched on, in cycles on average; `None` when never.
    pub cycles_per_activation: Option<f64>,
}

/// The share of samples that reached one stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageShare {
    /// The stage's name.
    pub stage: String,
    /// Share of samples that reached it.
    pub share: f64,
}

/// How often the arbitrator chose the right child in one phase of the derived fitness.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhaseShare {
    /// The phase's name.
    pub phase: String,
    /// The share of the phase's cycles in which the arbitrator chose its child, averaged over
    /// the samples that reached the phase; `None` when none did.
    pub right_choice: Option<f64>,
}

/// The rescue's stage rates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StageReport {
    /// Left the room (entered the maze).
    pub exited_room: f64,
    /// Reached the teammate.
    pub reached_teammate: f64,
    /// Brought it back into the room.
    pub returned: f64,
    /// How often the arbitrator chose the right child in each sub-task: the terms of the
    /// derived fitness f3, which a run's evolution maximised. Absent in reports written before
    /// hevo counted them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub right_choice: Option<RightChoice>,
}

/// Per rescue sub-task, the share of its cycles in which the arbitrator chose that sub-task's
/// child, averaged over the samples that reached the sub-task (as f3 scores one sample);
/// `None` when no sample reached it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RightChoice {
    /// In the room: exit room.
    pub exit_room: Option<f64>,
    /// In the maze before the teammate is found: solve maze.
    pub solve_maze: Option<f64>,
    /// Once the teammate follows: return to room.
    pub return_room: Option<f64>,
}

impl RightChoice {
    /// The three shares in sub-task order, for tables.
    pub fn shares(&self) -> [Option<f64>; 3] {
        [self.exit_room, self.solve_maze, self.return_room]
    }
}

/// A sample the controller did not solve, with what it takes to replay it
/// (`hevo replay --seed SEED --light-config VARIANT`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FailedSample {
    /// The sample's seed.
    pub seed: u64,
    /// The light configuration or start branch, when the post-evaluation fixed it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub variant: Option<u32>,
    /// Whether the robot touched a wall.
    pub collided: bool,
    /// Furthest stage reached (rescue 0..3).
    pub stage: u8,
    /// Cycles run before the sample ended.
    pub cycles: u32,
}

/// A one-line human summary of a report.
pub fn describe(report: &EvalReport) -> String {
    let mut text = format!(
        "{}: solved {:.1}% of {} samples, mean fitness {:.3}, collisions {:.1}%, mean cycles {:.0}",
        report.task,
        100.0 * report.solve_rate,
        report.samples,
        report.mean_fitness,
        100.0 * report.collision_rate,
        report.mean_cycles
    );
    if !report.per_variant.is_empty() {
        let parts: Vec<String> = report
            .per_variant
            .iter()
            .map(|v| {
                let name = v
                    .name
                    .as_ref()
                    .map_or_else(|| v.variant.to_string(), |n| format!("{} ({n})", v.variant));
                format!("{name}: {:.1}%", 100.0 * v.solve_rate)
            })
            .collect();
        text.push_str(&format!(
            "\n  per light configuration / branch: {}",
            parts.join(", ")
        ));
    }
    if let Some(stages) = &report.stages {
        text.push_str(&format!(
            "\n  stages: exited room {:.1}%, reached teammate {:.1}%, brought back {:.1}%",
            100.0 * stages.exited_room,
            100.0 * stages.reached_teammate,
            100.0 * stages.returned
        ));
        if let Some(right_choice) = &stages.right_choice {
            let [room, maze, back] = right_choice.shares().map(percent_or_dash);
            text.push_str(&format!(
                "\n  right child chosen (the terms of f3): in the room {room}, in the maze {maze}, \
                 on the way back {back}"
            ));
        }
    }
    if !report.per_stage.is_empty() {
        let parts: Vec<String> = report
            .per_stage
            .iter()
            .map(|s| format!("{} {}", s.stage, percent(s.share)))
            .collect();
        text.push_str(&format!("\n  stages: {}", parts.join(", ")));
    }
    if !report.per_phase.is_empty() {
        let parts: Vec<String> = report
            .per_phase
            .iter()
            .map(|p| format!("{} {}", p.phase, percent_or_dash(p.right_choice)))
            .collect();
        text.push_str(&format!(
            "\n  right child chosen (the terms of the derived fitness): {}",
            parts.join(", ")
        ));
    }
    if !report.node_use.is_empty() {
        text.push_str(&describe_node_use(&report.node_use));
    }
    text
}

/// The node-use table: per node below the root, its share of the cycles, how often it was
/// switched on per sample and for how long on average.
fn describe_node_use(node_use: &[NodeUseReport]) -> String {
    let width = node_use.iter().map(|n| n.node.len()).max().unwrap_or(0);
    let mut text =
        "\n  node use (share of cycles, switched on per sample, cycles per switch-on):".to_string();
    for node in node_use {
        let dwell = node
            .cycles_per_activation
            .map_or_else(|| "-".to_string(), |c| format!("{c:.1}"));
        text.push_str(&format!(
            "\n    {:<width$}  {:>6}  {:>6.1}  {:>6}",
            node.node,
            percent(node.active_share),
            node.activations_per_sample,
            dwell
        ));
    }
    text
}

/// A share as a percentage with one decimal.
pub fn percent(share: f64) -> String {
    format!("{:.1}%", 100.0 * share)
}

/// A share as a percentage with one decimal, or a dash when there is none.
pub fn percent_or_dash(share: Option<f64>) -> String {
    share.map_or_else(|| "-".to_string(), percent)
}
