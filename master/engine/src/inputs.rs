//! The inputs of a one-off evaluation, as `hevo eval`, `hevo replay` and the Python module
//! read them: a task named by a shipped scenario's name or a scenario file's path, optionally
//! with some numbers overridden, and a controller file from disk. One place, so the command
//! line and Python refuse the same inputs with the same messages (file, key, what was expected).

use crate::experiment::{controller_beside, with_task_overrides};
use hevo_sim_core::ControllerFile;
use hevo_sim_core::Scenario;
use hevo_sim_core::TaskConfig;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why a task could not be had.
#[derive(Debug, thiserror::Error)]
pub enum TaskInputError {
    /// The name is neither a shipped scenario nor a `.toml` path.
    #[error(
        "unknown task '{name}'; expected a scenario file (a path ending in .toml) or one of {known}"
    )]
    Unknown {
        /// The name given (cut short when long).
        name: String,
        /// The shipped scenarios, comma-separated.
        known: String,
    },
    /// The scenario file could not be read.
    #[error("cannot read scenario file {file}: {reason}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        reason: std::io::Error,
    },
    /// The scenario file does not compile.
    #[error("{0}")]
    Scenario(String),
    /// A setting is out of range, or an override names no setting.
    #[error("{origin}: invalid settings: {key}{separator}{message}", separator = if .key.is_empty() { "" } else { " " })]
    Settings {
        /// The task's name or file.
        origin: String,
        /// The setting's key path (`robot.v_max`); empty for the whole task.
        key: String,
        /// What is wrong.
        message: String,
    },
}

/// The task `name` stands for, at its scenario's own settings: a shipped scenario (by name or
/// alias), or a scenario file (a path ending in `.toml`).
pub fn task_by_name(name: &str) -> Result<TaskConfig, TaskInputError> {
    if name.ends_with(".toml") {
        let task = TaskConfig::from_scenario(Arc::new(read_scenario(name)?));
        task.validate().map_err(|error| TaskInputError::Settings {
            origin: name.to_string(),
            key: error.key,
            message: error.message,
        })?;
        return Ok(task);
    }
    TaskConfig::shipped(name).ok_or_else(|| TaskInputError::Unknown {
        name: crate::experiment::cut(name, 80),
        known: Scenario::shipped_names().join(", "),
    })
}

/// Reads and compiles the scenario file at `path`, and the controller files its groups run
/// (relative to it).
pub fn read_scenario(path: &str) -> Result<Scenario, TaskInputError> {
    let text = std::fs::read_to_string(path).map_err(|reason| TaskInputError::Read {
        file: path.to_string(),
        reason,
    })?;
    let read_controller = |written: &str| {
        let file = controller_beside(path, written);
        std::fs::read_to_string(&file).map_err(|reason| format!("cannot read {file}: {reason}"))
    };
    Scenario::parse_with(&text, path, &read_controller)
        .map_err(|e| TaskInputError::Scenario(e.to_string()))
}

/// `task` with the settings in `overrides` (an object shaped like an experiment node's
/// `task_config` table) replaced; `origin` names the task in messages.
pub fn task_with_overrides(
    task: TaskConfig,
    overrides: serde_json::Value,
    origin: &str,
) -> Result<TaskConfig, TaskInputError> {
    with_task_overrides(task, overrides).map_err(|(key, message)| TaskInputError::Settings {
        origin: origin.to_string(),
        key,
        message,
    })
}

/// Why a controller file could not be had.
#[derive(Debug, thiserror::Error)]
pub enum ControllerInputError {
    /// The file could not be read.
    #[error("cannot read controller file {}: {reason}", .file.display())]
    Read {
        /// The file.
        file: PathBuf,
        /// Why.
        reason: std::io::Error,
    },
    /// The file is not a valid controller file.
    #[error("{}: invalid controller file: {reason}", .file.display())]
    Invalid {
        /// The file.
        file: PathBuf,
        /// What is wrong, naming the node.
        reason: hevo_sim_core::ControllerError,
    },
    /// A node has no genome where a complete controller is needed.
    #[error("{}: node '{node}' has no genome; a controller to evaluate must be complete", .file.display())]
    Incomplete {
        /// The file.
        file: PathBuf,
        /// The path of the node without a genome.
        node: String,
    },
}

/// Reads and validates a controller file (which may have one free node).
pub fn read_controller(path: &Path) -> Result<ControllerFile, ControllerInputError> {
    let text = std::fs::read_to_string(path).map_err(|reason| ControllerInputError::Read {
        file: path.to_path_buf(),
        reason,
    })?;
    ControllerFile::from_json_str(&text).map_err(|reason| ControllerInputError::Invalid {
        file: path.to_path_buf(),
        reason,
    })
}

/// Reads a controller file that must be complete (every node with its genome), as one to
/// evaluate or replay must be.
pub fn read_complete_controller(path: &Path) -> Result<ControllerFile, ControllerInputError> {
    let file = read_controller(path)?;
    if let Some((node, _)) = file.free_node_topology() {
        return Err(ControllerInputError::Incomplete {
            file: path.to_path_buf(),
            node,
        });
    }
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tasks_by_name_and_overrides_name_what_is_wrong() {
        assert_eq!(task_by_name("solve_maze").unwrap().name(), "solve_maze");
        let unknown = task_by_name("no_such_task").unwrap_err().to_string();
        assert!(unknown.contains("unknown task 'no_such_task'"), "{unknown}");
        assert!(unknown.contains("follow_wall"), "{unknown}");
        let missing = task_by_name("/no/such/file.toml").unwrap_err().to_string();
        assert!(
            missing.starts_with("cannot read scenario file /no/such/file.toml"),
            "{missing}"
        );

        let task = task_by_name("follow_wall").unwrap();
        let shorter = task_with_overrides(
            task.clone(),
            serde_json::json!({"max_cycles": 77, "robot": {"v_max": 0.08}}),
            "follow_wall",
        )
        .unwrap();
        assert_eq!(shorter.max_cycles, Some(77));
        assert_eq!(shorter.params.robot.v_max, 0.08);
        let typo = task_with_overrides(
            task.clone(),
            serde_json::json!({"robot": {"vmax": 0.1}}),
            "follow_wall",
        )
        .unwrap_err()
        .to_string();
        assert!(
            typo.starts_with("follow_wall: invalid settings: robot"),
            "{typo}"
        );
        assert!(typo.contains("vmax"), "{typo}");
        let range = task_with_overrides(
            task,
            serde_json::json!({"robot": {"v_max": -1.0}}),
            "follow_wall",
        )
        .unwrap_err()
        .to_string();
        assert!(range.contains("robot.v_max"), "{range}");
    }

    #[test]
    fn a_scenario_file_reads_the_controller_files_its_groups_run_beside_it() {
        let dir = tempfile::tempdir().unwrap();
        let scenarios = dir.path().join("scenarios");
        std::fs::create_dir(&scenarios).unwrap();
        let scenario_path = scenarios.join("mixed.toml");
        std::fs::write(
            &scenario_path,
            include_str!("../../../scenarios/swarm/mixed_aggregation.toml")
                .replace("../../controllers/aggregation.json", "../pilots/pilot.json"),
        )
        .unwrap();
        let path = scenario_path.to_string_lossy().into_owned();
        let missing = task_by_name(&path).unwrap_err().to_string();
        assert!(missing.contains("robots[1].controller.file"), "{missing}");
        assert!(missing.contains("cannot read"), "{missing}");
        assert!(missing.contains("pilot.json"), "{missing}");

        std::fs::create_dir(dir.path().join("pilots")).unwrap();
        let pilot = include_str!("../../../controllers/aggregation.json");
        std::fs::write(dir.path().join("pilots/pilot.json"), pilot).unwrap();
        let task = task_by_name(&path).unwrap();
        assert_eq!(
            task.scenario
                .controller_files
                .get("../pilots/pilot.json")
                .map(String::as_str),
            Some(pilot)
        );
        // The text travels with the task: a worker needs no file.
        let json = serde_json::to_string(&task).unwrap();
        let back: TaskConfig = serde_json::from_str(&json).unwrap();
        assert_eq!(back, task);
    }

    #[test]
    fn controller_files_are_read_and_checked() {
        let dir = tempfile::tempdir().unwrap();
        let missing = read_controller(&dir.path().join("none.json"))
            .unwrap_err()
            .to_string();
        assert!(
            missing.starts_with("cannot read controller file"),
            "{missing}"
        );
        let broken = dir.path().join("broken.json");
        std::fs::write(&broken, "{").unwrap();
        let invalid = read_controller(&broken).unwrap_err().to_string();
        assert!(invalid.contains("invalid controller file"), "{invalid}");
        let free = dir.path().join("free.json");
        let template = ControllerFile::new(hevo_sim_core::NodeSpec::primitive(
            "p",
            vec![hevo_sim_core::InputGroup::IR],
            2,
        ));
        std::fs::write(&free, template.to_json_pretty().unwrap()).unwrap();
        assert!(read_controller(&free).is_ok());
        let incomplete = read_complete_controller(&free).unwrap_err().to_string();
        assert!(
            incomplete.contains("node 'p' has no genome"),
            "{incomplete}"
        );
    }
}
