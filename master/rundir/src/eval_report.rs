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

/// The format tag of an [`EvalRecord`].
pub const EVAL_RECORD_FORMAT: &str = "hevo.evaluation/1";

/// `hevo eval --record FILE`: one post-evaluation, with the controller file and the command
/// that repeats it, kept beside the run directories so that `hevo report --evaluation FILE`
/// can put a controller's rate on a task it was not evolved for into REPRODUCTION.md.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalRecord {
    /// [`EVAL_RECORD_FORMAT`].
    pub format: String,
    /// The controller file, as given.
    pub controller: String,
    /// The `hevo eval` command that wrote this record, which writes it again.
    pub command: String,
    /// The evaluation.
    pub report: EvalReport,
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

impl EvalReport {
    /// Per phase of the derived fitness, how often the arbitrator chose the right child: the
    /// rescue's [`RightChoice`], or another scenario's `per_phase`; empty without phases.
    pub fn phase_shares(&self) -> &[PhaseShare] {
        match self.stages.as_ref().and_then(|s| s.right_choice.as_ref()) {
            Some(right_choice) => &right_choice.phases,
            None => &self.per_phase,
        }
    }
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
    /// The phase: its name (`per_phase`), or the child it asks for (the rescue's
    /// [`RightChoice`]).
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

/// Per phase of the derived fitness, the share of its cycles in which the arbitrator chose the
/// child the phase asks for, averaged over the samples that reached the phase (as f3 scores one
/// sample); `None` when no sample reached it. The phases are the scenario's, in its order, each
/// keyed by the child it asks for (the rescue's: `exit_room`, `solve_maze`, `return_room`).
///
/// Its JSON is an object from key to share, in the phases' order, which is what reports have
/// always held (`{"exit_room": 0.97, "solve_maze": 0.84, "return_room": null}`), so every
/// summary written before reads as it is and writes back byte for byte.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RightChoice {
    /// Each phase's key (the child it asks for) and share, in the scenario's order.
    pub phases: Vec<PhaseShare>,
}

impl RightChoice {
    /// The share of the phase keyed `key`; `None` when the phase is missing or was not reached.
    pub fn share(&self, key: &str) -> Option<f64> {
        self.phases
            .iter()
            .find(|phase| phase.phase == key)
            .and_then(|phase| phase.right_choice)
    }
}

impl Serialize for RightChoice {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = serializer.serialize_map(Some(self.phases.len()))?;
        for phase in &self.phases {
            map.serialize_entry(&phase.phase, &phase.right_choice)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for RightChoice {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        /// Reads the object's entries in the order the file has them.
        struct InOrder;
        impl<'de> serde::de::Visitor<'de> for InOrder {
            type Value = RightChoice;
            fn expecting(&self, formatter: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                formatter
                    .write_str("an object from each phase's child to its share of right choices")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut entries: A,
            ) -> Result<RightChoice, A::Error> {
                let mut phases: Vec<PhaseShare> = Vec::new();
                while let Some((phase, right_choice)) =
                    entries.next_entry::<String, Option<f64>>()?
                {
                    if phases.iter().any(|known| known.phase == phase) {
                        return Err(serde::de::Error::custom(format!(
                            "phase `{phase}` appears twice"
                        )));
                    }
                    phases.push(PhaseShare {
                        phase,
                        right_choice,
                    });
                }
                Ok(RightChoice { phases })
            }
        }
        deserializer.deserialize_map(InOrder)
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

/// Where the robot is in each of the rescue's phases, as the report's text says it.
const RESCUE_PHASE_PLACES: [(&str, &str); 3] = [
    ("exit_room", "in the room"),
    ("solve_maze", "in the maze"),
    ("return_room", "on the way back"),
];

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
            let parts: Vec<String> = right_choice
                .phases
                .iter()
                .map(|phase| {
                    let place = RESCUE_PHASE_PLACES
                        .iter()
                        .find(|(key, _)| *key == phase.phase)
                        .map_or(phase.phase.as_str(), |(_, place)| place);
                    format!("{place} {}", percent_or_dash(phase.right_choice))
                })
                .collect();
            text.push_str(&format!(
                "\n  right child chosen (the terms of f3): {}",
                parts.join(", ")
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{NodeSummary, RunSummary, SUMMARY};
    use std::path::{Path, PathBuf};

    /// `hevo eval controllers/rescue.json --task rescue --samples 12 --json`, as hevo printed it
    /// when the rescue's right choices were three named fields.
    const RESCUE_EVAL: &str = r#"{"task":"rescue","samples":48,"solve_rate":0.8958333333333334,"mean_fitness":2.696935761719942,"collision_rate":0.020833333333333332,"mean_cycles":1197.2083333333333,"per_variant":[{"variant":0,"samples":12,"solve_rate":0.9166666666666666},{"variant":1,"samples":12,"solve_rate":0.9166666666666666},{"variant":2,"samples":12,"solve_rate":0.9166666666666666},{"variant":3,"samples":12,"solve_rate":0.8333333333333334}],"stages":{"exited_room":0.9583333333333334,"reached_teammate":0.9375,"returned":0.8958333333333334,"right_choice":{"exit_room":0.9664559823771318,"solve_maze":0.8378530556093091,"return_room":0.9893730984793769}},"node_use":[{"node":"rescue/exit_room","active_share":0.4022726481745728,"activations_per_sample":1.9166666666666667,"cycles_per_activation":251.27173913043478}]}"#;

    #[test]
    fn the_rescue_s_right_choices_read_by_phase_and_write_back_byte_for_byte() {
        let report: EvalReport = serde_json::from_str(RESCUE_EVAL).unwrap();
        let phases: Vec<(&str, Option<f64>)> = report
            .phase_shares()
            .iter()
            .map(|p| (p.phase.as_str(), p.right_choice))
            .collect();
        assert_eq!(
            phases,
            [
                ("exit_room", Some(0.9664559823771318)),
                ("solve_maze", Some(0.8378530556093091)),
                ("return_room", Some(0.9893730984793769)),
            ]
        );
        assert_eq!(serde_json::to_string(&report).unwrap(), RESCUE_EVAL);
        let text = describe(&report);
        assert!(
            text.contains(
                "right child chosen (the terms of f3): in the room 96.6%, in the maze 83.8%, \
                 on the way back 98.9%"
            ),
            "{text}"
        );
    }

    #[test]
    fn right_choices_keep_the_file_s_order_and_refuse_a_phase_twice() {
        let choice: RightChoice =
            serde_json::from_str(r#"{"return_room": null, "exit_room": 0.5}"#).unwrap();
        assert_eq!(choice.phases[0].phase, "return_room");
        assert_eq!(choice.share("exit_room"), Some(0.5));
        assert_eq!(choice.share("return_room"), None);
        assert_eq!(choice.share("solve_maze"), None);
        assert_eq!(
            serde_json::to_string(&choice).unwrap(),
            r#"{"return_room":null,"exit_room":0.5}"#
        );
        let error = serde_json::from_str::<RightChoice>(r#"{"a": 0.5, "a": 0.25}"#)
            .unwrap_err()
            .to_string();
        assert!(error.contains("phase `a` appears twice"), "{error}");
        assert!(serde_json::from_str::<RightChoice>("[0.5]").is_err());
    }

    /// Every `summary.json` under `dir`, recursively.
    fn summaries_under(dir: &Path, found: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                summaries_under(&path, found);
            } else if path.file_name().is_some_and(|name| name == SUMMARY) {
                found.push(path);
            }
        }
    }

    /// The run directories kept under `experiments/` hold every report shape hevo has written;
    /// each must still read, and write back as it was.
    #[test]
    fn every_summary_under_experiments_reads_and_writes_back_unchanged() {
        let experiments = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments");
        let mut paths = Vec::new();
        summaries_under(&experiments, &mut paths);
        assert!(paths.len() >= 100, "{} summaries", paths.len());
        let mut n_right_choices = 0;
        for path in &paths {
            let text = std::fs::read_to_string(path).unwrap();
            // A node's summary holds its runs' (`runs`); a run's is one.
            let written = if text.contains("\"best_run\"") {
                let summary: NodeSummary = serde_json::from_str(&text)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                serde_json::to_string_pretty(&summary).unwrap()
            } else {
                let summary: RunSummary = serde_json::from_str(&text)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                n_right_choices += usize::from(
                    summary
                        .post_evaluation
                        .stages
                        .as_ref()
                        .is_some_and(|s| s.right_choice.is_some()),
                );
                serde_json::to_string_pretty(&summary).unwrap()
            };
            assert_eq!(
                written,
                text.trim_end_matches('\n'),
                "{} does not write back as it was",
                path.display()
            );
        }
        assert!(
            n_right_choices > 0,
            "no rescue right choices among {paths:?}"
        );
    }
}
