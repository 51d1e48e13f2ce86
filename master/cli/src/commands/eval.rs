//! `hevo eval`: post-evaluate a controller file on fresh samples, as text or JSON, with the
//! unsolved samples and the command that replays each when asked.

use crate::args::TaskArgs;
use crate::inputs::{check_fits, load_controller, other_task_warning};
use crate::runtime::{default_threads, with_local_workers};
use anyhow::{Context, Result, bail};
use clap::Args;
use hevo_engine::post_evaluation;
use hevo_engine::post_evaluation::{EVAL_RECORD_FORMAT, EvalRecord};
use hevo_engine::store::write_json_atomic;
use hevo_sim_core::{Evaluator, TaskConfig};
use std::path::PathBuf;

/// `hevo eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The controller file (JSON).
    pub controller: PathBuf,
    #[command(flatten)]
    pub task: TaskArgs,
    /// Samples (per light configuration / start branch for tasks that have them).
    #[arg(long, default_value_t = 100)]
    pub samples: u32,
    /// Seed of the samples.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Also list the unsolved samples, each with the `hevo replay` command that draws it.
    #[arg(long)]
    pub failures: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Also write the report, the controller file and this command as JSON to FILE, for
    /// `hevo report --evaluation FILE`.
    #[arg(long, value_name = "FILE")]
    pub record: Option<PathBuf>,
}

/// What `hevo eval --json` prints: the report, and the failed samples when asked for.
#[derive(Debug, serde::Serialize)]
struct EvalOutput<'a> {
    #[serde(flatten)]
    report: &'a post_evaluation::EvalReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    failures: Option<&'a [post_evaluation::FailedSample]>,
}

pub fn eval(args: EvalArgs) -> Result<()> {
    let task = args.task.task_config()?;
    let controller = load_controller(&args.controller)?;
    check_fits(&args.controller, &controller, &task)?;
    if let Some(warning) = other_task_warning(&args.controller, &controller, &task) {
        eprintln!("{warning}");
    }
    if args.samples == 0 {
        bail!("--samples must be at least 1");
    }
    let threads = default_threads(args.threads);
    Evaluator::new(task.clone())?;
    let samples = post_evaluation::post_evaluation_samples(&task, args.samples, args.seed);
    let node_paths = controller.node_paths();
    let summaries = with_local_workers(threads, async |dispatcher| {
        post_evaluation::evaluate_samples(
            dispatcher,
            "eval",
            controller,
            task.clone(),
            samples.clone(),
        )
        .await
    })?;
    let report = post_evaluation::report(&task, &summaries, &node_paths);
    let failures = post_evaluation::failed_samples(&samples, &summaries);
    if let Some(path) = &args.record {
        let record = EvalRecord {
            format: EVAL_RECORD_FORMAT.into(),
            controller: args.controller.display().to_string(),
            command: this_command(),
            report: report.clone(),
        };
        write_json_atomic(path, &record)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if args.json {
        let output = EvalOutput {
            report: &report,
            failures: args.failures.then_some(failures.as_slice()),
        };
        crate::outln!("{}", serde_json::to_string(&output)?);
        return Ok(());
    }
    crate::outln!("{}", post_evaluation::describe(&report));
    if args.failures {
        crate::outln!("{}", post_evaluation::describe_failures(&task, &failures));
        for failure in &failures {
            crate::outln!("  {}", describe_failure(failure, &task, &args));
        }
    }
    Ok(())
}

/// One failed sample as a line: how far it got, and the command that replays it.
fn describe_failure(
    failure: &post_evaluation::FailedSample,
    task: &TaskConfig,
    args: &EvalArgs,
) -> String {
    let wall = if failure.collided {
        ", touched a wall"
    } else {
        ""
    };
    // Stages mean something only where the scenario names some (the rescue: left the room,
    // reached the teammate).
    let stage = if !task.scenario.stages.is_empty() {
        format!(", stage {}", failure.stage)
    } else {
        String::new()
    };
    let variant = failure
        .variant
        .map(|v| format!(" --light-config {v}"))
        .unwrap_or_default();
    format!(
        "{} cycles{stage}{wall}: hevo replay {} {} --seed {}{variant} --out failure-{}.svg",
        failure.cycles,
        args.controller.display(),
        args.task.flags(),
        failure.seed,
        failure.seed
    )
}

/// The command line this process was started with, as `hevo ...` (whatever the binary's path),
/// quoted for a POSIX shell where an argument needs it (an argument that is not UTF-8 is
/// written lossily: the record is text).
fn this_command() -> String {
    let args: Vec<String> = std::env::args_os()
        .skip(1)
        .map(|arg| arg.to_string_lossy().into_owned())
        .collect();
    let words = std::iter::once("hevo").chain(args.iter().map(String::as_str));
    // A quoting error means a NUL byte, which no argument of a process can hold.
    shlex::try_join(words).unwrap_or_else(|_| format!("hevo {}", args.join(" ")))
}
