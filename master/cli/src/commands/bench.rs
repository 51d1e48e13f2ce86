//! `hevo bench`: simulator throughput on this machine (scalar and lockstep evaluators), the
//! `hevo run` pipeline's, a team task's per robot at several team sizes (`--robots`), or with
//! `--dispatch-load` the master's dispatch capacity against fake workers.

use crate::inputs::parse_task;
use crate::runtime::{default_threads, runtime};
use anyhow::{Result, bail};
use clap::Args;
use hevo_engine::bench;
use hevo_sim_core::{EvaluatorKind, TaskConfig};
use std::time::Duration;

/// `hevo bench`.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// The task: a shipped scenario's name or a scenario file.
    #[arg(long, default_value = "solve_maze")]
    pub task: String,
    /// Seconds to measure.
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Measure the `hevo run` path (dispatcher and worker pool, evaluations per second)
    /// instead of the raw simulator.
    #[arg(long)]
    pub pipeline: bool,
    /// The simulator's evaluator: scalar (the reference, one sample at a time), lockstep
    /// (several samples together, what `hevo run` and the workers use), or both, one after the
    /// other, with the ratio.
    #[arg(long, value_enum, default_value_t = BenchEvaluator::Both)]
    pub evaluator: BenchEvaluator,
    /// Print one JSON object per measurement.
    #[arg(long)]
    pub json: bool,
    /// Measure the master's dispatch capacity instead: this many fake workers (fixed-cost
    /// evaluations) against a real worker service on 127.0.0.1, for --seconds.
    #[arg(long, value_name = "WORKERS")]
    pub dispatch_load: Option<usize>,
    /// With --dispatch-load: what one batch costs a fake worker, milliseconds.
    #[arg(long, default_value_t = 20.0)]
    pub batch_cost_ms: f64,
    /// For a task with a team (`[[robots]]`): measure it at each of these team sizes (the
    /// focal robot included; its first group resized), robot-cycles per second per thread and
    /// each size's ratio to the first. With the lockstep evaluator unless --evaluator says
    /// scalar.
    #[arg(long, value_delimiter = ',', value_name = "N,N,...")]
    pub robots: Vec<u32>,
}

/// Which evaluators `hevo bench` measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchEvaluator {
    /// The scalar reference.
    Scalar,
    /// The lockstep evaluator.
    Lockstep,
    /// Scalar, then lockstep, and their ratio.
    Both,
}

pub fn bench(args: BenchArgs) -> Result<()> {
    let task = parse_task(&args.task)?;
    let threads = default_threads(args.threads);
    if !(args.seconds > 0.0 && args.seconds.is_finite()) {
        bail!("--seconds must be a positive number");
    }
    if let Some(workers) = args.dispatch_load {
        return dispatch_load(workers, args.seconds, args.batch_cost_ms, args.json);
    }
    if !args.robots.is_empty() {
        return team_sizes(&task, &args, threads);
    }
    let reports = if args.pipeline {
        vec![
            runtime()?
                .block_on(bench::pipeline(task, threads, args.seconds, 10))
                .map_err(anyhow::Error::msg)?,
        ]
    } else {
        let kinds: &[EvaluatorKind] = match args.evaluator {
            BenchEvaluator::Scalar => &[EvaluatorKind::Scalar],
            BenchEvaluator::Lockstep => &[EvaluatorKind::Lockstep],
            BenchEvaluator::Both => &[EvaluatorKind::Scalar, EvaluatorKind::Lockstep],
        };
        kinds
            .iter()
            .map(|&kind| bench::simulator(task.clone(), threads, args.seconds, kind))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)?
    };
    for report in &reports {
        if args.json {
            crate::outln!("{}", serde_json::to_string(report)?);
        } else {
            crate::outln!(
                "{} ({}, {:?}), {} thread(s): {:.0} cycles/s ({:.0} per thread), {:.1} evaluations/s",
                report.task,
                report.mode,
                report.evaluator,
                report.threads,
                report.cycles_per_second,
                report.cycles_per_second_per_thread,
                report.evaluations_per_second
            );
        }
    }
    if let [scalar, lockstep] = &reports[..]
        && !args.json
    {
        crate::outln!(
            "lockstep / scalar: {:.2}x",
            lockstep.cycles_per_second / scalar.cycles_per_second.max(1.0)
        );
    }
    Ok(())
}

/// `hevo bench --robots N,N,...`: the task at each team size, one after the other.
fn team_sizes(task: &TaskConfig, args: &BenchArgs, threads: usize) -> Result<()> {
    let kind = match args.evaluator {
        BenchEvaluator::Scalar => EvaluatorKind::Scalar,
        BenchEvaluator::Lockstep | BenchEvaluator::Both => EvaluatorKind::Lockstep,
    };
    if let Some(&n_robots) = args
        .robots
        .iter()
        .find(|&&n| n == 0 || n > hevo_sim_core::MAX_ROBOTS)
    {
        bail!(
            "--robots {n_robots}: a team holds 1 to {} robots",
            hevo_sim_core::MAX_ROBOTS
        );
    }
    let mut first_rate = None;
    for &n_robots in &args.robots {
        let scenario = task.scenario.with_team_size(n_robots)?;
        let sized = TaskConfig {
            scenario: std::sync::Arc::new(scenario),
            ..task.clone()
        };
        let report =
            bench::simulator(sized, threads, args.seconds, kind).map_err(anyhow::Error::msg)?;
        let rate = report.robot_cycles_per_second_per_thread;
        let ratio = rate / *first_rate.get_or_insert(rate);
        if args.json {
            crate::outln!("{}", serde_json::to_string(&report)?);
        } else {
            crate::outln!(
                "{} ({:?}), {n_robots:>2} robot(s), {} thread(s): {:.0} robot-cycles/s per \
                 thread, {:.2} of the first size's",
                report.task,
                report.evaluator,
                report.threads,
                rate,
                ratio
            );
        }
    }
    Ok(())
}

/// `hevo bench --dispatch-load WORKERS`.
fn dispatch_load(workers: usize, seconds: f64, batch_cost_ms: f64, json: bool) -> Result<()> {
    if !((1..=5_000).contains(&workers) && seconds > 0.0 && seconds <= 600.0) {
        bail!("--dispatch-load takes 1 to 5000 workers, for at most 600 seconds");
    }
    if !(batch_cost_ms.is_finite() && batch_cost_ms >= 0.0) {
        bail!("--batch-cost-ms must be a non-negative number");
    }
    let config = hevo_service::load::LoadConfig {
        workers,
        seconds,
        batch_cost: Duration::from_secs_f64(batch_cost_ms / 1e3),
        jobs: 4,
        genomes: 1_000,
        samples: 1,
    };
    let report = runtime()?.block_on(hevo_service::load::run(config))?;
    if json {
        crate::outln!("{}", serde_json::to_string(&report)?);
    } else {
        let [p50, p90, p99, max] = report.lease_latency_ms;
        crate::outln!(
            "dispatch load: {} fake workers, {:.0} ms per batch, {:.1} s: {:.0} batches/s (ideal {:.0}), {:.0} evaluations/s; \
             lease latency p50 {p50:.2} ms, p90 {p90:.2} ms, p99 {p99:.2} ms, max {max:.2} ms over {} leases; {} reconnects",
            report.workers,
            report.batch_cost_ms,
            report.seconds,
            report.batches_per_second,
            report.ideal_batches_per_second,
            report.evaluations_per_second,
            report.leases,
            report.reconnects
        );
    }
    Ok(())
}
