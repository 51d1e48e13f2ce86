//! Flags several subcommands share: the task a controller is judged on ([`TaskArgs`], for
//! `eval`, `replay` and `export`), what a run changes of an experiment file ([`OverrideArgs`],
//! for `run` and `submit`), the job a client command is about ([`JobArgs`]), and the check that
//! a picture is named `*.svg`.

use crate::inputs::parse_task;
use anyhow::{Result, bail};
use clap::Args;
use hevo_engine::experiment::Experiment;
use hevo_engine::runner::Overrides;
use hevo_proto::client::MasterArgs;
use hevo_sim_core::TaskConfig;
use std::path::PathBuf;

/// What a run changes of an experiment file: the flags `hevo run` and `hevo submit` share.
#[derive(Debug, Clone, Args)]
pub struct OverrideArgs {
    /// Evolve only this node (after its children, which are reused when already finished,
    /// whatever their number of runs).
    #[arg(long)]
    pub node: Option<String>,
    /// Override every node's number of runs. A node that already has more finished runs keeps
    /// them all; with --node, raising it adds runs to that node alone.
    #[arg(long)]
    pub runs: Option<u32>,
    /// Override every node's number of generations (with --node, the nodes below it that
    /// are already finished are reused as they are).
    #[arg(long)]
    pub generations: Option<u32>,
    /// Override the experiment's seed.
    #[arg(long)]
    pub seed: Option<u64>,
}

impl OverrideArgs {
    /// The engine's overrides.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            node: self.node.clone(),
            runs: self.runs,
            generations: self.generations,
            seed: self.seed,
        }
    }
}

/// The task `hevo eval` and `hevo replay` run a controller on: a task at the paper's settings,
/// or the task a node of an experiment file trains on, with its `task_config` overrides and
/// cycle limit (so a controller evolved under an ablation's rules is judged by them).
#[derive(Debug, Args)]
pub struct TaskArgs {
    /// The task at its scenario's own settings: a shipped scenario (exit_room, follow_wall,
    /// turn_left, turn_right, solve_maze, maze_single, return_room, rescue) or a scenario file
    /// (a path ending in .toml).
    #[arg(
        long,
        required_unless_present = "experiment",
        conflicts_with = "experiment"
    )]
    pub task: Option<String>,
    /// Instead of --task: the task of a node of this experiment file (with --node).
    #[arg(long, requires = "node")]
    pub experiment: Option<PathBuf>,
    /// With --experiment: the node whose task to use.
    #[arg(long, requires = "experiment")]
    pub node: Option<String>,
}

impl TaskArgs {
    /// The task configuration these flags name.
    pub fn task_config(&self) -> Result<TaskConfig> {
        match (&self.task, &self.experiment, &self.node) {
            (Some(task), _, _) => parse_task(task),
            (None, Some(file), Some(node)) => {
                let experiment = Experiment::load(file)?;
                let plan = experiment.named_node(node)?;
                Ok(plan.task.clone())
            }
            // clap requires --task or both of --experiment and --node.
            _ => bail!("give --task, or --experiment FILE with --node NAME"),
        }
    }

    /// These flags as they are typed, for a command line printed for the user.
    pub fn flags(&self) -> String {
        match (&self.task, &self.experiment, &self.node) {
            (Some(task), _, _) => format!("--task {task}"),
            (None, Some(file), Some(node)) => {
                format!("--experiment {} --node {node}", file.display())
            }
            _ => String::new(),
        }
    }
}

/// A command about one job (`watch`, `cancel`, `delete`).
#[derive(Debug, Args)]
pub struct JobArgs {
    #[command(flatten)]
    pub master: MasterArgs,
    /// The job id (as printed by `hevo submit`).
    pub job: String,
}

/// hevo draws SVG only; a picture asked for as `trace.png` would be an SVG under a PNG name,
/// which image viewers refuse, so the name is checked before anything is simulated.
pub fn svg_path(value: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(value);
    let is_svg = path
        .extension()
        .is_some_and(|extension| extension.eq_ignore_ascii_case("svg"));
    if is_svg {
        Ok(path)
    } else {
        Err("hevo draws SVG only: name the file *.svg (any SVG viewer or converter turns it into PNG)".into())
    }
}
