//! The task and the controller a one-off command (`eval`, `replay`, `export`) reads, and the
//! checks that the one fits the other before anything is simulated.

use anyhow::Result;
use hevo_sim_core::Scenario;
use hevo_sim_core::{ControllerFile, TaskConfig};
use std::path::Path;

/// Refuses a controller that reads a sensor the task's robot lacks (it would read zeros), or
/// lacks a child a phase of the task's derived fitness asks for (it would score by position).
pub fn check_fits(path: &Path, controller: &ControllerFile, task: &TaskConfig) -> Result<()> {
    hevo_sim_core::controller_fits(controller, &task.scenario)
        .map_err(|problem| anyhow::anyhow!("{}: the controller {problem}", path.display()))
}

/// A note when a controller looks evolved for another task than the one it is judged on:
/// its root node is named after a task (as `hevo run` names nodes), and not this one.
pub fn other_task_warning(
    path: &Path,
    controller: &ControllerFile,
    task: &TaskConfig,
) -> Option<String> {
    let evolved_for = Scenario::shipped(&controller.root.name)?;
    (evolved_for.name() != task.name()).then(|| {
        format!(
            "note: {} looks evolved for {} (its root node is named '{}'); judging it on {}",
            path.display(),
            evolved_for.name(),
            controller.root.name,
            task.name()
        )
    })
}

/// A task by `--task`'s value: a shipped scenario's name, or a scenario file.
pub fn parse_task(name: &str) -> Result<TaskConfig> {
    Ok(hevo_engine::inputs::task_by_name(name)?)
}

/// A complete controller file (every node with its genome).
pub fn load_controller(path: &Path) -> Result<ControllerFile> {
    Ok(hevo_engine::inputs::read_complete_controller(path)?)
}
