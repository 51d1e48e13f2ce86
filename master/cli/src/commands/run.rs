//! `hevo run`: evolve an experiment's controller tree locally, or with `--dry-run` print the
//! plan (the nodes, what is done, how long the rest takes on this machine).

use crate::args::OverrideArgs;
use crate::runtime::{default_threads, with_local_workers};
use anyhow::Result;
use clap::Args;
use hevo_engine::bench;
use hevo_engine::experiment::Experiment;
use hevo_engine::rundir;
use hevo_engine::runner::{self, RunSettings};
use hevo_sim_core::EvaluatorKind;
use std::path::{Path, PathBuf};

/// `hevo run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The experiment file (TOML). Without one, the paper's whole rescue experiment built into
    /// hevo (a copy of experiments/rescue.toml) is used.
    pub file: Option<PathBuf>,
    #[command(flatten)]
    pub overrides: OverrideArgs,
    /// Output directory (checkpoints, controllers, logs).
    #[arg(long, default_value = "runs")]
    pub out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print the nodes it would evolve, what is already done in --out, and an estimate of how
    /// long the rest takes on this machine; evolve nothing.
    #[arg(long)]
    pub dry_run: bool,
}

/// The paper's rescue experiment, built in so `hevo run` works without any file.
pub const EMBEDDED_EXPERIMENT: &str = include_str!("../../../../experiments/rescue.toml");

pub fn run(args: RunArgs) -> Result<()> {
    let experiment = match &args.file {
        Some(file) => Experiment::load(file)?,
        None => Experiment::parse(
            EMBEDDED_EXPERIMENT,
            Path::new("<built-in experiments/rescue.toml>"),
        )?,
    };
    let threads = default_threads(args.threads);
    let settings = RunSettings {
        out_dir: args.out.clone(),
        overrides: args.overrides.overrides(),
        job: "local".into(),
    };
    if args.dry_run || args.file.is_none() {
        let statuses = runner::node_statuses(&experiment, &settings)?;
        let plan = describe_plan(&experiment, &statuses, threads)?;
        if args.dry_run {
            crate::outln!("{plan}");
            return Ok(());
        }
        // Without a file, hevo runs the paper's whole tree: hours of work nobody should
        // start without knowing.
        eprintln!(
            "no experiment file given: running the built-in paper experiment (experiments/rescue.toml) into {}\n{plan}\n\
             Ctrl-C stops it at any time; the same command resumes it. `hevo run --node follow_wall` runs one primitive.",
            args.out.display()
        );
    }
    let progress = crate::progress::for_stderr();
    let summaries = with_local_workers(threads, async |dispatcher| {
        tokio::select! {
            summaries = runner::run_experiment(&experiment, &settings, dispatcher, progress.as_ref()) => summaries,
            _ = tokio::signal::ctrl_c() => {
                // Every finished generation is checkpointed and the runner writes only between
                // its awaits, so stopping here loses at most the generation in flight; exiting
                // at once spares the wait for the workers' current batches.
                eprintln!("{}", progress.interrupted());
                std::process::exit(130);
            }
        }
    })?;
    crate::outln!("results in {}", args.out.display());
    let node_width = column_width(summaries.iter().map(|summary| summary.node.as_str()), 14);
    let task_width = column_width(summaries.iter().map(|summary| summary.task.as_str()), 12);
    for summary in &summaries {
        crate::outln!(
            "  {:<node_width$} {:<task_width$} runs {:>2}  best run {:>2}: {:>5.1}% solved   mean over runs {:>5.1}%   -> {}",
            summary.node,
            summary.task,
            summary.runs.len(),
            summary.best_run,
            100.0 * summary.best_solve_rate,
            100.0 * summary.mean_solve_rate,
            rundir::node_dir(&args.out, &summary.node)
                .join(rundir::BEST)
                .display()
        );
    }
    Ok(())
}

/// How long one task's control cycles take on this machine, measured briefly with the paper's
/// controller for it (a random genome, so a rough figure).
const PLAN_BENCH_SECONDS: f64 = 0.3;

/// The nodes a run evolves, what is done, and at most how long the rest takes on this machine.
fn describe_plan(
    experiment: &Experiment,
    statuses: &[runner::NodeStatus],
    threads: usize,
) -> Result<String> {
    use std::fmt::Write as _;
    let mut speeds: std::collections::BTreeMap<String, f64> = Default::default();
    let node_width = column_width(statuses.iter().map(|status| status.node.as_str()), 14);
    let task_width = column_width(statuses.iter().map(|status| status.task.as_str()), 12);
    let mut text = format!(
        "{:<node_width$} {:<task_width$} {:>5} {:>6} {:>10} {:>9} {:<24} {:>14} {:>10}\n",
        "node",
        "task",
        "runs",
        "gens",
        "evals/gen",
        "mem/gen",
        "done",
        "cycles (max)",
        "time (max)"
    );
    let mut total_seconds = 0.0;
    for status in statuses {
        let done = if status.finished {
            "finished".to_string()
        } else {
            match status.in_progress {
                Some((run, generation)) => format!(
                    "{} run(s), run {run} at gen {generation}",
                    status.finished_runs
                ),
                None => format!("{} run(s)", status.finished_runs),
            }
        };
        let cycles = status.remaining_cycles_bound();
        let seconds = if cycles == 0 {
            0.0
        } else {
            // Measured with the node's own network over its children's, so a large network
            // or a robot without some sensor is timed as it will run.
            let task = experiment.named_node(&status.node)?.task.clone();
            let speed = match speeds.get(&status.node) {
                Some(&speed) => speed,
                None => {
                    let report = bench::simulator_with(
                        bench::node_controller(experiment, &status.node, 1),
                        task,
                        threads,
                        PLAN_BENCH_SECONDS,
                        EvaluatorKind::default(),
                    )?;
                    speeds.insert(status.node.clone(), report.cycles_per_second);
                    report.cycles_per_second
                }
            };
            cycles as f64 / speed.max(1.0)
        };
        total_seconds += seconds;
        let plan = experiment.named_node(&status.node)?;
        let memory = hevo_engine::experiment::generation_bytes(
            plan.evolution.population,
            hevo_engine::experiment::declared_genes(&plan.decl),
            plan.decl.samples,
        );
        let _ = writeln!(
            text,
            "{:<node_width$} {:<task_width$} {:>5} {:>6} {:>10} {:>9} {:<24} {:>14.3e} {:>10}",
            status.node,
            status.task,
            status.runs,
            status.generations,
            status.evaluations_per_generation,
            format!("{:.1} MiB", memory as f64 / (1024.0 * 1024.0)),
            done,
            cycles as f64,
            human_duration(seconds)
        );
    }
    let _ = write!(
        text,
        "at most {} on this machine with {threads} thread(s) (every sample to its cycle limit; evolved controllers often finish sooner)",
        human_duration(total_seconds)
    );
    Ok(text)
}

/// The width of a text column: its longest entry, at least `minimum`, so long node names keep
/// the columns after them aligned.
fn column_width<'a>(entries: impl Iterator<Item = &'a str>, minimum: usize) -> usize {
    entries
        .map(|entry| entry.chars().count())
        .fold(minimum, usize::max)
}

/// `42 s`, `12 min`, `3.4 h`, `2.1 days`.
fn human_duration(seconds: f64) -> String {
    if seconds < 90.0 {
        format!("{seconds:.0} s")
    } else if seconds < 90.0 * 60.0 {
        format!("{:.0} min", seconds / 60.0)
    } else if seconds < 48.0 * 3600.0 {
        format!("{:.1} h", seconds / 3600.0)
    } else {
        format!("{:.1} days", seconds / 86400.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_column_is_as_wide_as_its_longest_entry_and_never_narrower_than_its_minimum() {
        let names = ["exit_room", "rescue_over_primitives_cmaes"];
        assert_eq!(column_width(names.into_iter(), 14), 28);
        assert_eq!(column_width(["a", "bb"].into_iter(), 14), 14);
        assert_eq!(column_width(std::iter::empty(), 12), 12);
    }

    #[test]
    fn durations_read_in_the_unit_that_fits() {
        assert_eq!(human_duration(42.0), "42 s");
        assert_eq!(human_duration(720.0), "12 min");
        assert_eq!(human_duration(3.4 * 3600.0), "3.4 h");
        assert_eq!(human_duration(2.1 * 86400.0), "2.1 days");
    }
}
