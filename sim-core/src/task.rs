//! Tasks: a scenario (what the world is made of and how a sample is judged) with every number
//! of the robot, sensors and environment generators in force, as one serialisable
//! configuration. A scenario file's own numbers are its task's defaults; an experiment node may
//! override any of them (`[node.task_config]`). Everything the paper leaves open is a
//! documented config value here.

use crate::config::{
    ConfigError, CorridorConfig, IrConfig, LightConfig, Params, RabConfig, RobotConfig, RoomConfig,
    StartConfig, invalid,
};
use crate::scenario::Scenario;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::Arc;

/// Everything that defines a task's samples: the scenario and the numbers in force.
#[derive(Debug, Clone)]
pub struct TaskConfig {
    /// What the world is and how a sample is judged.
    pub scenario: Arc<Scenario>,
    /// Cycle limit; the scenario's when absent.
    pub max_cycles: Option<u32>,
    /// Whether touching a wall ends the sample (SPEC: most tasks do).
    pub end_on_collision: bool,
    /// Whether entering a cell off the path ends the sample in a scenario whose wrong branches
    /// do not end it by default (the rescue: the paper does not say, and a rescuer may turn
    /// round and search on; see `docs/decisions/model/0006-goals-and-wrong-branches.md`, and for the
    /// ablation with it on `docs/decisions/model/0020-rescue-wrong-branch-ablation.md`).
    pub end_on_wrong_branch: bool,
    /// For a scenario with a derived fitness: whether a solved sample also earns the time bonus
    /// (maxCycles - spentCycles) / maxCycles, as in the authors' JBotEvolver code
    /// (`RoomMazeBackBehaviorsEvaluationFunction`); the paper's text gives f3 a maximum of 3,
    /// so it is off by default.
    pub rescue_time_bonus: bool,
    /// For a map whose wrong branches end a sample: whether a wrong branch ends it only once
    /// the robot's bounding box meets the central half of another branch's end cell, as in the
    /// authors' code (`TMazeEnvironment`'s forbidden squares). Off: any cell off the path.
    pub wrong_branch_at_end_only: bool,
    /// The robot's, its sensors' and the generators' numbers.
    pub params: Params,
}

impl PartialEq for TaskConfig {
    fn eq(&self, other: &TaskConfig) -> bool {
        // The wire form holds the controller files' texts.
        self.scenario.source == other.scenario.source && self.wire() == other.wire()
    }
}

/// A task as it is serialised: the shape tasks had before scenarios, with the scenario given
/// by its legacy task name (`kind`) for the shipped paper tasks, so their content hashes and
/// run fingerprints stay what they were, and by its text (`scenario`) for any other, so a
/// worker needs no file; the controller files its groups run travel beside it (`controllers`,
/// by the path as written; absent when there are none, so every other task hashes as before).
/// The numbers follow.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TaskWire {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    kind: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    scenario: Option<String>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    controllers: BTreeMap<String, String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_cycles: Option<u32>,
    #[serde(default = "default_true")]
    end_on_collision: bool,
    #[serde(default, skip_serializing_if = "is_false")]
    end_on_wrong_branch: bool,
    #[serde(default, skip_serializing_if = "is_false")]
    rescue_time_bonus: bool,
    #[serde(default, skip_serializing_if = "is_false")]
    wrong_branch_at_end_only: bool,
    #[serde(default)]
    robot: RobotConfig,
    #[serde(default)]
    ir: IrConfig,
    #[serde(default)]
    light: LightConfig,
    // Left out at its default, so the tasks hashed before the board existed keep their hashes.
    #[serde(default, skip_serializing_if = "RabConfig::is_default")]
    rab: RabConfig,
    #[serde(default)]
    room: RoomConfig,
    #[serde(default)]
    corridor: CorridorConfig,
    #[serde(default)]
    start: StartConfig,
}

fn default_true() -> bool {
    true
}

fn is_false(value: &bool) -> bool {
    !value
}

impl Serialize for TaskConfig {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        self.wire().serialize(serializer)
    }
}

impl<'de> Deserialize<'de> for TaskConfig {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        let wire = TaskWire::deserialize(deserializer)?;
        let scenario = match (&wire.kind, &wire.scenario) {
            (Some(name), None) => Scenario::shipped(name).ok_or_else(|| {
                D::Error::custom(format!(
                    "unknown task '{}', expected one of {}",
                    crate::scenario::bounded(name),
                    Scenario::shipped_names().join(", ")
                ))
            })?,
            (None, Some(text)) => {
                let carried = |path: &str| {
                    wire.controllers.get(path).cloned().ok_or_else(|| {
                        format!(
                            "'{}' is not among the task's controllers",
                            crate::scenario::bounded(path)
                        )
                    })
                };
                let scenario = Scenario::parse_with(text, "the task's scenario", &carried)
                    .map_err(D::Error::custom)?;
                // Canonical: a task carries exactly the files its scenario runs, so that
                // equal tasks hash alike.
                if let Some(path) = wire
                    .controllers
                    .keys()
                    .find(|path| !scenario.controller_files.contains_key(*path))
                {
                    return Err(D::Error::custom(format!(
                        "controllers: '{}' is run by no group of the task's scenario",
                        crate::scenario::bounded(path)
                    )));
                }
                Arc::new(scenario)
            }
            _ => {
                return Err(D::Error::custom(
                    "a task names a shipped scenario (`kind`) or carries one (`scenario`)",
                ));
            }
        };
        Ok(TaskConfig {
            scenario,
            max_cycles: wire.max_cycles,
            end_on_collision: wire.end_on_collision,
            end_on_wrong_branch: wire.end_on_wrong_branch,
            rescue_time_bonus: wire.rescue_time_bonus,
            wrong_branch_at_end_only: wire.wrong_branch_at_end_only,
            params: Params {
                robot: wire.robot,
                ir: wire.ir,
                light: wire.light,
                rab: wire.rab,
                room: wire.room,
                corridor: wire.corridor,
                start: wire.start,
            },
        })
    }
}

impl TaskConfig {
    /// A scenario's task with the scenario's own numbers.
    pub fn from_scenario(scenario: Arc<Scenario>) -> TaskConfig {
        let file = &scenario.file;
        TaskConfig {
            max_cycles: None,
            end_on_collision: file.end_on_collision,
            end_on_wrong_branch: false,
            rescue_time_bonus: false,
            wrong_branch_at_end_only: false,
            params: file.params(),
            scenario,
        }
    }

    /// A shipped scenario's task (the paper's settings), by name or alias.
    pub fn shipped(name: &str) -> Option<TaskConfig> {
        Scenario::shipped(name).map(TaskConfig::from_scenario)
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        self.scenario.name()
    }

    fn wire(&self) -> TaskWire {
        let (kind, scenario) = match self.scenario.legacy() {
            Some(kind) => (Some(kind.to_string()), None),
            None => (None, Some(self.scenario.source.clone())),
        };
        let controllers = self.scenario.controller_files.clone();
        let Params {
            robot,
            ir,
            light,
            rab,
            room,
            corridor,
            start,
        } = self.params.clone();
        TaskWire {
            kind,
            scenario,
            controllers,
            max_cycles: self.max_cycles,
            end_on_collision: self.end_on_collision,
            end_on_wrong_branch: self.end_on_wrong_branch,
            rescue_time_bonus: self.rescue_time_bonus,
            wrong_branch_at_end_only: self.wrong_branch_at_end_only,
            robot,
            ir,
            light,
            rab,
            room,
            corridor,
            start,
        }
    }

    /// The cycle limit in force.
    pub fn max_cycles(&self) -> u32 {
        self.max_cycles.unwrap_or(self.scenario.file.max_cycles)
    }

    /// The lowest and highest fitness a sample of this task can score: every formula's range
    /// with each quantity in its own (the time bonus, progress and approach in [0, 1], the
    /// derived fitness up to one per phase), and the time bonus added to a solved derived
    /// fitness when asked for.
    pub fn fitness_range(&self) -> (f32, f32) {
        let n_phases = self.scenario.phases.len();
        let range_of = |idx: usize| self.scenario.quantities[idx].1.range(n_phases);
        let mut low = f32::INFINITY;
        let mut high = f32::NEG_INFINITY;
        for (slot, formula) in self.scenario.fitness.iter().enumerate() {
            let (a, mut b) = formula.range(&range_of);
            if slot == crate::scenario::ending_slot::SOLVED && self.rescue_time_bonus {
                b += 1.0;
            }
            low = low.min(a);
            high = high.max(b);
        }
        (low, high)
    }

    /// Checks every value; the error names the key.
    pub fn validate(&self) -> Result<(), ConfigError> {
        // In the order the keys have always been checked, so a task with several mistakes
        // gets the message it got before.
        self.params.robot.validate()?;
        self.params.room.validate()?;
        self.params
            .room
            .validate_start_clearance(self.params.robot.radius)?;
        if self.max_cycles() == 0 {
            return Err(invalid("max_cycles", "must be at least 1".into()));
        }
        let scenario = &self.scenario;
        if self.rescue_time_bonus && !scenario.has_phases() {
            return Err(invalid(
                "rescue_time_bonus",
                format!(
                    "applies to scenarios with a derived fitness only ({} has none)",
                    scenario.name()
                ),
            ));
        }
        // Only where wrong branches are judged but do not end a sample by themselves.
        let wrong_branch_may_continue = scenario.wrong_branch && !scenario.wrong_branch_ends;
        if self.end_on_wrong_branch && !wrong_branch_may_continue {
            return Err(invalid(
                "end_on_wrong_branch",
                format!(
                    "applies to scenarios whose wrong branches do not end a sample ({} always \
                     ends on a wrong branch or has none)",
                    scenario.name()
                ),
            ));
        }
        let map_wrong_branches =
            scenario.wrong_branch && scenario.wrong_branch_ends && scenario.world.is_map_alone();
        if self.wrong_branch_at_end_only && !map_wrong_branches {
            return Err(invalid(
                "wrong_branch_at_end_only",
                format!(
                    "applies to maps whose wrong branches end a sample (solve_maze, \
                     return_room), not to {}",
                    scenario.name()
                ),
            ));
        }
        self.params.ir.validate()?;
        self.params.rab.validate()?;
        self.params.corridor.validate()?;
        self.params.start.validate()
    }
}

/// A stable content hash of a task configuration (FNV-1a over its canonical JSON), so workers
/// can cache evaluators by (template hash, task hash).
pub fn task_content_hash(task: &TaskConfig) -> String {
    let json = serde_json::to_string(task).unwrap_or_default();
    crate::math::hash::fnv1a_hex(json.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> TaskConfig {
        TaskConfig::shipped(name).unwrap()
    }

    /// A boolean task option, off by default: absent from the serialised task when off (so
    /// task hashes and run fingerprints written before it existed stay valid), present and
    /// round-tripping when on, and refused, with a message naming it, where it does not apply.
    fn assert_optional_flag(
        name: &str,
        switch_on: fn(&mut TaskConfig),
        applies_to: &[&str],
        refused_on: &str,
        refusal: &str,
    ) {
        for &scenario in applies_to {
            let task = shipped(scenario);
            let json = serde_json::to_string(&task).unwrap();
            assert!(!json.contains(name), "{json}");
            let mut on = task.clone();
            switch_on(&mut on);
            assert!(on.validate().is_ok(), "{name} on {scenario}");
            let json = serde_json::to_string(&on).unwrap();
            assert!(json.contains(name), "{json}");
            assert_eq!(serde_json::from_str::<TaskConfig>(&json).unwrap(), on);
        }
        let mut refused = shipped(refused_on);
        switch_on(&mut refused);
        let error = refused.validate().unwrap_err();
        assert_eq!(error.key, name);
        assert_eq!(error.to_string(), refusal);
    }

    #[test]
    fn optional_flags_are_unseen_when_off_and_refused_where_they_do_not_apply() {
        assert_optional_flag(
            "end_on_wrong_branch",
            |task| task.end_on_wrong_branch = true,
            &["rescue"],
            "solve_maze",
            "end_on_wrong_branch applies to scenarios whose wrong branches do not end a sample \
             (solve_maze always ends on a wrong branch or has none)",
        );
        assert_optional_flag(
            "rescue_time_bonus",
            |task| task.rescue_time_bonus = true,
            &["rescue"],
            "return_room",
            "rescue_time_bonus applies to scenarios with a derived fitness only (return_room \
             has none)",
        );
        assert_optional_flag(
            "wrong_branch_at_end_only",
            |task| task.wrong_branch_at_end_only = true,
            &["solve_maze", "return_room"],
            "rescue",
            "wrong_branch_at_end_only applies to maps whose wrong branches end a sample \
             (solve_maze, return_room), not to rescue",
        );
    }

    /// The content hashes of the paper's tasks as they were before tasks became scenarios
    /// (computed by that code): the run fingerprints of every checked-in run directory
    /// depend on them, so a shipped scenario must serialise exactly as its task did.
    #[test]
    fn the_paper_tasks_keep_their_content_hashes() {
        for (name, hash) in [
            ("exit_room", "44fa0eab1aeaf484"),
            ("follow_wall", "45bf78a8932c4cb0"),
            ("turn_left", "8838b6c402312308"),
            ("turn_right", "5ff3b307f045fbd5"),
            ("solve_maze", "9a2389abb39dcc4b"),
            ("return_room", "006cd0df2df231b2"),
            ("rescue", "3bbfbfe762587df1"),
        ] {
            assert_eq!(
                task_content_hash(&shipped(name)),
                hash,
                "{name}: {}",
                serde_json::to_string(&shipped(name)).unwrap()
            );
        }
    }

    #[test]
    fn names_round_trip_and_alias_works() {
        for name in Scenario::shipped_names() {
            assert!(TaskConfig::shipped(name).is_some(), "{name}");
        }
        assert_eq!(shipped("maze_single").name(), "solve_maze");
        let parsed: TaskConfig = serde_json::from_str(r#"{"kind":"maze_single"}"#).unwrap();
        assert_eq!(parsed.name(), "solve_maze");
        let error = serde_json::from_str::<TaskConfig>(r#"{"kind":"teleport"}"#).unwrap_err();
        assert!(
            error.to_string().contains("unknown task 'teleport'"),
            "{error}"
        );
    }

    #[test]
    fn a_scenario_that_is_not_shipped_travels_as_its_text() {
        let text = crate::scenario::SHIPPED[0]
            .1
            .replace("name = \"exit_room\"", "name = \"my_room\"")
            .replace("legacy = \"exit_room\"\n", "");
        let scenario = Arc::new(Scenario::parse(&text, "my_room.toml").unwrap());
        let task = TaskConfig::from_scenario(scenario);
        let json = serde_json::to_string(&task).unwrap();
        assert!(
            json.contains("\"scenario\":") && !json.contains("\"kind\""),
            "{json}"
        );
        let back: TaskConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, task);
        assert_eq!(back.name(), "my_room");
        assert_ne!(
            task_content_hash(&task),
            task_content_hash(&shipped("exit_room"))
        );
    }

    #[test]
    fn unknown_keys_are_rejected() {
        let err = serde_json::from_str::<TaskConfig>(r#"{"kind":"rescue","robot":{"radiuss":1}}"#)
            .unwrap_err();
        assert!(err.to_string().contains("radiuss"), "{err}");
    }

    #[test]
    fn defaults_are_the_papers() {
        assert_eq!(shipped("rescue").max_cycles(), 2000);
        assert_eq!(shipped("exit_room").max_cycles(), 1000);
        assert_eq!(shipped("turn_left").max_cycles(), 400);
        for name in Scenario::shipped_names() {
            assert_eq!(shipped(name).validate(), Ok(()), "{name}");
        }
        assert_eq!(shipped("exit_room").fitness_range(), (0.0, 6.0));
        assert_eq!(shipped("solve_maze").fitness_range(), (0.0, 2.0));
        assert_eq!(shipped("follow_wall").fitness_range(), (0.0, 2.0));
        assert_eq!(shipped("rescue").fitness_range(), (0.0, 3.0));
        let mut bonus = shipped("rescue");
        bonus.rescue_time_bonus = true;
        assert_eq!(bonus.fitness_range(), (0.0, 4.0));
    }

    #[test]
    fn a_start_advance_must_stay_inside_the_corridor() {
        let mut task = shipped("turn_left");
        task.params.corridor.start_advance = 0.5;
        let error = task.validate().unwrap_err();
        assert_eq!(error.key, "corridor.start_advance", "{error}");
        task.params.corridor.start_advance = 0.2;
        task.params.corridor.cells_before_turn = [1, 3];
        let error = task.validate().unwrap_err();
        assert_eq!(error.key, "corridor.start_advance", "{error}");
        assert!(error.message.contains("cells_before_turn"), "{error}");
    }

    #[test]
    fn a_room_whose_obstacles_could_cover_the_start_is_refused() {
        let mut task = shipped("exit_room");
        task.params.room.start_clearance = 0.15;
        let error = task.validate().unwrap_err();
        assert_eq!(error.key, "room.start_clearance", "{error}");
        assert!(error.message.contains("no clearance"), "{error}");
        // A bigger robot needs more room around the same start area.
        let mut wide = shipped("exit_room");
        wide.params.robot.radius = 0.12;
        assert_eq!(wide.validate().unwrap_err().key, "room.start_clearance");
    }
}
