//! The `hevo` command line: the subcommands' clap definitions and the dispatch from each to its
//! module under [`commands`](crate::commands), one file per subcommand. Every subcommand returns
//! an error with a clear message instead of panicking; `main` prints it and exits non-zero.

use crate::args::JobArgs;
use crate::commands::{
    archive, bench, cancel, dashboard, delete, eval, export, fetch, jobs, plot, replay, report,
    run, scenario, serve, submit, watch,
};
use anyhow::Result;
use clap::{Parser, Subcommand};

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
    Run(run::RunArgs),
    /// Post-evaluate a controller file: solve rate, per light configuration, per stage.
    Eval(eval::EvalArgs),
    /// Measure simulator throughput on this machine.
    Bench(bench::BenchArgs),
    /// Draw one sample of a controller as an SVG picture (or animation).
    Replay(replay::ReplayArgs),
    /// Plot the fitness curves of a node's runs as SVG.
    Plot(plot::PlotArgs),
    /// Run the master: job and worker services (gRPC), jobs kept in a durable store.
    Serve(serve::ServeArgs),
    /// Submit an experiment file to a master; prints the job id.
    Submit(submit::SubmitArgs),
    /// Follow a job's progress until it ends (exit status 0 when it succeeded).
    Watch(JobArgs),
    /// List a master's jobs.
    Jobs(hevo_proto::client::MasterArgs),
    /// Download a job's results (controllers, fitness logs, summaries) into a directory.
    Fetch(fetch::FetchArgs),
    /// Cancel a job.
    Cancel(JobArgs),
    /// Delete a finished job from the master: its record, its results and its files.
    Delete(JobArgs),
    /// Write REPRODUCTION.md (paper versus hevo) from run output directories.
    Report(report::ReportArgs),
    /// Check a scenario file (a task as data) and draw its world.
    Scenario(scenario::ScenarioArgs),
    /// Serve the live dashboard over local run directories (what `hevo run --out` writes):
    /// fitness curves that grow while a run is in progress, post-evaluation tables and the
    /// best controllers' replays; prints its URL.
    Dashboard(dashboard::DashboardArgs),
    /// Export a controller tree as a C library for the e-puck, with test vectors.
    Export(export::ExportArgs),
    /// A MAP-Elites run's archive: export every elite as a controller file.
    Archive(archive::ArchiveArgs),
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
/// Runs one parsed command.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Run(args) => run::run(args),
        Command::Eval(args) => eval::eval(args),
        Command::Bench(args) => bench::bench(args),
        Command::Replay(args) => replay::replay(args),
        Command::Plot(args) => plot::plot(args),
        Command::Serve(args) => serve::serve(args),
        Command::Submit(args) => submit::submit(args),
        Command::Watch(args) => watch::watch(args),
        Command::Jobs(args) => jobs::jobs(args),
        Command::Fetch(args) => fetch::fetch(args),
        Command::Cancel(args) => cancel::cancel(args),
        Command::Delete(args) => delete::delete(args),
        Command::Scenario(args) => scenario::scenario(args),
        Command::Dashboard(args) => dashboard::dashboard(args),
        Command::Export(args) => export::export(args),
        Command::Archive(args) => archive::archive(args),
        Command::Report(args) => report::report(args),
    }
}
