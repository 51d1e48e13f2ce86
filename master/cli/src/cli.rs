//! The `hevo` command line: argument parsing and the glue from each subcommand to the library.
//! Every subcommand returns an error with a clear message instead of panicking; `main` prints
//! it and exits non-zero.

use crate::service_commands as service;
use hevo_engine::bench;
use hevo_engine::dispatch::Dispatcher;
use hevo_engine::experiment::Experiment;
use hevo_engine::post_evaluation;
use hevo_engine::rundir;
use hevo_engine::runner::{self, Overrides, RunSettings};

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use hevo_sim_core::EvaluatorKind;
use hevo_sim_core::Scenario;
use hevo_sim_core::{Controller, ControllerFile};
use hevo_sim_core::{Evaluator, Sample, TaskConfig};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Evolve robot controllers by structured composition: each sub-task's controller evolved on its
/// own, then composed bottom-up under evolved arbitrators. Run experiments locally or on a
/// master, and evaluate, replay, plot and report what evolved.
#[derive(Debug, Parser)]
#[command(name = "hevo", version)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Evolve an experiment's controller tree bottom-up, locally (resumable).
    Run(RunArgs),
    /// Post-evaluate a controller file: solve rate, per light configuration, per stage.
    Eval(EvalArgs),
    /// Measure simulator throughput on this machine.
    Bench(BenchArgs),
    /// Draw one sample of a controller as an SVG picture (or animation).
    Replay(ReplayArgs),
    /// Plot the fitness curves of a node's runs as SVG.
    Plot(PlotArgs),
    /// Run the master: job and worker services (gRPC), jobs kept in a durable store.
    Serve(service::ServeArgs),
    /// Submit an experiment file to a master; prints the job id.
    Submit(service::SubmitArgs),
    /// Follow a job's progress until it ends (exit status 0 when it succeeded).
    Watch(service::JobArgs),
    /// List a master's jobs.
    Jobs(hevo_proto::client::MasterArgs),
    /// Download a job's results (controllers, fitness logs, summaries) into a directory.
    Fetch(service::FetchArgs),
    /// Cancel a job.
    Cancel(service::JobArgs),
    /// Delete a finished job from the master: its record, its results and its files.
    Delete(service::JobArgs),
    /// Write REPRODUCTION.md (paper versus hevo) from run output directories.
    Report(ReportArgs),
    /// Check a scenario file (a task as data) and draw its world.
    Scenario(crate::scenario_command::ScenarioArgs),
    /// Serve the live dashboard over local run directories (what `hevo run --out` writes):
    /// fitness curves that grow while a run is in progress, post-evaluation tables and the
    /// best controllers' replays; prints its URL.
    Dashboard(DashboardArgs),
    /// Export a controller tree as a C library for the e-puck, with test vectors.
    Export(crate::export_command::ExportArgs),
}

/// `hevo dashboard`.
#[derive(Debug, Args)]
pub struct DashboardArgs {
    /// Run output directories (as given to `hevo run --out`), each shown as one job.
    #[arg(required = true, value_name = "RUNS_DIR")]
    pub runs_dirs: Vec<PathBuf>,
    /// Address to serve on (port 0: any free port); the URL is printed first on stdout as
    /// `dashboard on http://ADDR`. The default is reachable from this machine only.
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    pub listen: String,
    /// Ask for one of the tokens in this file (one per line) before showing anything, as a
    /// master's dashboard does; without it anyone who reaches the address sees the runs.
    #[arg(long)]
    pub token_file: Option<PathBuf>,
}

/// `hevo report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Run output directories (as given to `hevo run --out`).
    #[arg(required = true)]
    pub runs_dirs: Vec<PathBuf>,
    /// A run output directory of an ablation (repeatable): its nodes evolved under another
    /// setup than the same nodes in RUNS_DIRS, or given more runs of the same setup, get a
    /// section of their own, beside them.
    #[arg(long = "ablation", value_name = "DIR")]
    pub ablation_dirs: Vec<PathBuf>,
    /// The Markdown file to write; pictures go to `reproduction/` beside it.
    #[arg(long, default_value = "REPRODUCTION.md")]
    pub out: PathBuf,
}

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
}

/// What `hevo eval --json` prints: the report, and the failed samples when asked for.
#[derive(Debug, serde::Serialize)]
struct EvalOutput<'a> {
    #[serde(flatten)]
    report: &'a post_evaluation::EvalReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    failures: Option<&'a [post_evaluation::FailedSample]>,
}

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
    fn flags(&self) -> String {
        match (&self.task, &self.experiment, &self.node) {
            (Some(task), _, _) => format!("--task {task}"),
            (None, Some(file), Some(node)) => {
                format!("--experiment {} --node {node}", file.display())
            }
            _ => String::new(),
        }
    }
}

/// `hevo replay`.
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The controller file (JSON).
    pub controller: PathBuf,
    #[command(flatten)]
    pub task: TaskArgs,
    /// The sample's seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Fix the light configuration (or start branch) instead of drawing it from the seed.
    #[arg(long)]
    pub light_config: Option<u32>,
    /// Where to write the SVG (a `.svg` file).
    #[arg(long, value_parser = svg_path, required_unless_present = "trace_out")]
    pub out: Option<PathBuf>,
    /// Also (or instead) write the trace as a table, one row per cycle: poses, sensor inputs,
    /// wheel outputs, the active node (a `.csv` or `.json` file).
    #[arg(long, value_parser = trace_path, value_name = "FILE")]
    pub trace_out: Option<PathBuf>,
    /// Draw the IR cones at these cycles (comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub rays: Vec<u32>,
    /// Write an animated SVG.
    #[arg(long)]
    pub animate: bool,
}

/// `hevo plot`.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// A run output directory (as given to `hevo run --out`), or one node's directory.
    pub runs_dir: PathBuf,
    /// The node to plot.
    #[arg(long)]
    pub node: Option<String>,
    /// Where to write the SVG (a `.svg` file).
    #[arg(long, value_parser = svg_path)]
    pub out: PathBuf,
}

/// hevo draws SVG only; a picture asked for as `trace.png` would be an SVG under a PNG name,
/// which image viewers refuse, so the name is checked before anything is simulated.
fn svg_path(value: &str) -> Result<PathBuf, String> {
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

/// A trace table is CSV or JSON, told apart by the file's extension.
fn trace_path(value: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(value);
    match trace_format(&path) {
        Some(_) => Ok(path),
        None => Err("name the trace file *.csv or *.json".into()),
    }
}

/// The format of a trace table file: CSV or JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TraceFormat {
    Csv,
    Json,
}

fn trace_format(path: &Path) -> Option<TraceFormat> {
    let extension = path.extension()?.to_str()?.to_ascii_lowercase();
    match extension.as_str() {
        "csv" => Some(TraceFormat::Csv),
        "json" => Some(TraceFormat::Json),
        _ => None,
    }
}

/// Parses the command line and runs it; the exit code of `hevo`.
pub fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    init_tracing();
    match execute(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // The reader of our output has gone (`| head`): it has what it wanted.
        Err(error) if error.is::<crate::output::StdoutClosed>() => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

/// Logs go to stderr; `RUST_LOG` filters them (default: info).
pub fn init_tracing() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    use std::io::IsTerminal;
    let ansi = std::io::stderr().is_terminal();
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(ansi)
        .with_writer(std::io::stderr)
        .try_init();
}

fn runtime() -> Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")
}

/// Runs `work` on a new runtime against a dispatcher served by `threads` in-process workers
/// (local mode), and stops the workers once it is done.
fn with_local_workers<T, E>(
    threads: usize,
    work: impl AsyncFnOnce(&Dispatcher) -> Result<T, E>,
) -> Result<T>
where
    E: std::error::Error + Send + Sync + 'static,
{
    let dispatcher = hevo_engine::local::local_dispatcher(threads);
    Ok(hevo_engine::local::run_local(dispatcher, threads, work)
        .context("cannot start the async runtime")??)
}

/// Threads to use: the flag, else every core.
pub fn default_threads(flag: Option<usize>) -> usize {
    flag.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}

/// Runs one parsed command.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run(args) => run(args),
        Command::Eval(args) => eval(args),
        Command::Bench(args) => bench_command(args),
        Command::Replay(args) => replay(args),
        Command::Plot(args) => plot(args),
        Command::Serve(args) => service::serve(args),
        Command::Submit(args) => service::submit(args),
        Command::Watch(args) => service::watch(args),
        Command::Jobs(args) => service::jobs(args),
        Command::Fetch(args) => service::fetch(args),
        Command::Cancel(args) => service::cancel(args),
        Command::Delete(args) => service::delete(args),
        Command::Scenario(args) => crate::scenario_command::scenario(args),
        Command::Dashboard(args) => dashboard(args),
        Command::Export(args) => crate::export_command::export(args),
        Command::Report(args) => {
            let n =
                hevo_viz::report::write_report(&args.runs_dirs, &args.ablation_dirs, &args.out)?;
            crate::outln!("{n} node(s) reported -> {}", args.out.display());
            Ok(())
        }
    }
}

/// Refuses a controller that reads a sensor the task's robot lacks (it would read zeros), or
/// lacks a child a phase of the task's derived fitness asks for (it would score by position).
fn check_fits(path: &Path, controller: &ControllerFile, task: &TaskConfig) -> Result<()> {
    hevo_sim_core::controller_fits(controller, &task.scenario)
        .map_err(|problem| anyhow::anyhow!("{}: the controller {problem}", path.display()))
}

/// A note when a controller looks evolved for another task than the one it is judged on:
/// its root node is named after a task (as `hevo run` names nodes), and not this one.
fn other_task_warning(
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
fn parse_task(name: &str) -> Result<TaskConfig> {
    Ok(hevo_engine::inputs::task_by_name(name)?)
}

fn load_controller(path: &Path) -> Result<ControllerFile> {
    Ok(hevo_engine::inputs::read_complete_controller(path)?)
}

/// The paper's rescue experiment, built in so `hevo run` works without any file.
pub const EMBEDDED_EXPERIMENT: &str = include_str!("../../../experiments/rescue.toml");

fn run(args: RunArgs) -> Result<()> {
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
        runner::run_experiment(&experiment, &settings, dispatcher, progress.as_ref()).await
    })?;
    crate::outln!("results in {}", args.out.display());
    for summary in &summaries {
        crate::outln!(
            "  {:<14} {:<12} runs {:>2}  best run {:>2}: {:>5.1}% solved   mean over runs {:>5.1}%   -> {}",
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
    let mut text = format!(
        "{:<14} {:<12} {:>5} {:>6} {:>10} {:>9} {:<24} {:>14} {:>10}\n",
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
            "{:<14} {:<12} {:>5} {:>6} {:>10} {:>9} {:<24} {:>14.3e} {:>10}",
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

fn eval(args: EvalArgs) -> Result<()> {
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

fn bench_command(args: BenchArgs) -> Result<()> {
    let task = parse_task(&args.task)?;
    let threads = default_threads(args.threads);
    if !(args.seconds > 0.0 && args.seconds.is_finite()) {
        bail!("--seconds must be a positive number");
    }
    if let Some(workers) = args.dispatch_load {
        return service::dispatch_load(workers, args.seconds, args.batch_cost_ms, args.json);
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

fn replay(args: ReplayArgs) -> Result<()> {
    let task = args.task.task_config()?;
    let task_name = task.name().to_string();
    let n_variants = task.scenario.n_variants();
    let file = load_controller(&args.controller)?;
    check_fits(&args.controller, &file, &task)?;
    if let Some(warning) = other_task_warning(&args.controller, &file, &task) {
        eprintln!("{warning}");
    }
    let mut controller = Controller::new(&file, None)?;
    let evaluator = Evaluator::new(task)?;
    if let Some(k) = args.light_config {
        let n = n_variants;
        if k >= n {
            bail!(
                "--light-config {k} is out of range: task {task_name} has {n} configuration(s) (0..{})",
                n - 1
            );
        }
    }
    let trace = evaluator.evaluate_traced(
        &mut controller,
        Sample {
            seed: args.seed,
            variant: args.light_config,
        },
    );
    let node_names: Vec<String> = (0..controller.n_nodes())
        .map(|i| controller.node_path(i).unwrap_or("?").to_string())
        .collect();
    let mut written = Vec::new();
    if let Some(out) = &args.out {
        let options = hevo_viz::ReplayOptions {
            node_names: node_names.clone(),
            rays_at_cycles: args.rays.clone(),
            animate: args.animate,
            title: None,
            robot_radius: evaluator.task().params.robot.radius,
            caption: None,
        };
        let svg = hevo_viz::replay_svg(&trace, &options, &|pose| evaluator.ir_cones(pose));
        hevo_engine::store::write_atomic(out, svg.as_bytes())
            .with_context(|| format!("cannot write {}", out.display()))?;
        written.push(out.display().to_string());
    }
    if let Some(trace_out) = &args.trace_out {
        let text = match trace_format(trace_out) {
            Some(TraceFormat::Json) => hevo_viz::trace_table::trace_json(&trace, &node_names)?,
            // The flag's parser admits only .csv and .json.
            _ => hevo_viz::trace_table::trace_csv(&trace, &node_names),
        };
        hevo_engine::store::write_atomic(trace_out, text.as_bytes())
            .with_context(|| format!("cannot write {}", trace_out.display()))?;
        written.push(trace_out.display().to_string());
    }
    crate::outln!(
        "{}: {:?} after {} cycles, fitness {:.3} -> {}",
        task_name,
        trace.outcome.ending,
        trace.outcome.cycles,
        trace.outcome.fitness,
        written.join(", ")
    );
    Ok(())
}

fn dashboard(args: DashboardArgs) -> Result<()> {
    let access = match &args.token_file {
        Some(file) => {
            let tokens = hevo_proto::auth::read_token_file(file)?;
            if tokens.is_empty() {
                bail!("{} holds no token", file.display());
            }
            hevo_dashboard::Access::tokens(tokens)
        }
        None => hevo_dashboard::Access::Open,
    };
    let source = hevo_dashboard::rundirs::RunDirSource::new(&args.runs_dirs)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    runtime.block_on(async move {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        let address = listener.local_addr()?;
        crate::outln!("dashboard on http://{address}");
        let source = Arc::new(source);
        source.watch_for_changes();
        let board = hevo_dashboard::Dashboard::new(source, access);
        hevo_dashboard::serve(
            listener,
            board,
            hevo_dashboard::ConnectionLimits::DEFAULT,
            async {
                let _ = tokio::signal::ctrl_c().await;
            },
        )
        .await
        .context("the dashboard server failed")
    })
}

fn plot(args: PlotArgs) -> Result<()> {
    let node_dir = match &args.node {
        Some(node) => args.runs_dir.join(node),
        None => args.runs_dir.clone(),
    };
    let runs = hevo_viz::read_run_logs(&node_dir)?;
    if runs.is_empty() {
        let hint = if args.node.is_none() {
            " (pass --node NAME to plot a node of a run directory)"
        } else {
            ""
        };
        bail!("no run-*/fitness.csv under {}{hint}", node_dir.display());
    }
    let title = format!(
        "{}: fitness per generation",
        node_dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    );
    let svg = hevo_viz::fitness_plot_svg(&title, &runs);
    hevo_engine::store::write_atomic(&args.out, svg.as_bytes())
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    crate::outln!("{} runs plotted -> {}", runs.len(), args.out.display());
    Ok(())
}
