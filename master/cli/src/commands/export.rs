//! `hevo export`: a controller tree as a C library for the e-puck (`hevo_export`), its test
//! vectors and, with `--check-closed-loop`, the solve rate of the exported C driven by the
//! simulator beside sim-core's own on the same samples.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use hevo_engine::post_evaluation;
use hevo_export::{ExportOptions, Target, closed_loop, vectors};

use crate::args::TaskArgs;
use crate::runtime::default_threads;

/// `hevo export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The controller file (JSON), complete (every node with its genome).
    pub controller: PathBuf,
    #[command(flatten)]
    pub task: TaskArgs,
    /// The directory to write the library into (created if missing; files are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// The arithmetic: float (e-puck2, bit-identical to the simulator) or fixed (e-puck1's
    /// dsPIC, no FPU).
    #[arg(long, value_enum, default_value_t = TargetArg::Float)]
    pub target: TargetArg,
    /// Samples per variant (light configuration, start branch) the test vectors record.
    #[arg(long, default_value_t = 2)]
    pub vector_samples: u32,
    /// Then run `make check` (the recorded cycles), build the exported C (`make hevo_loop`),
    /// drive it with the simulator in place of the Rust controller and print its solve rate
    /// beside sim-core's on the same samples.
    #[arg(long)]
    pub check_closed_loop: bool,
    /// With --check-closed-loop: samples per light configuration / start branch, as `hevo
    /// eval --samples`.
    #[arg(long, default_value_t = 100)]
    pub samples: u32,
    /// With --check-closed-loop: the samples' seed, as `hevo eval --seed`.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// With --check-closed-loop: threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// `--target`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TargetArg {
    /// IEEE single precision (e-puck2, Cortex-M4F).
    Float,
    /// Integers only (e-puck1, dsPIC30F6014A).
    Fixed,
}

/// Runs `hevo export`.
pub fn export(args: ExportArgs) -> Result<()> {
    let task = args.task.task_config()?;
    let controller = hevo_engine::inputs::read_complete_controller(&args.controller)?;
    hevo_sim_core::controller_fits(&controller, &task.scenario).map_err(|problem| {
        anyhow::anyhow!("{}: the controller {problem}", args.controller.display())
    })?;
    if args.vector_samples == 0 || args.vector_samples > 1000 {
        bail!("--vector-samples must be between 1 and 1000");
    }
    if args.check_closed_loop && args.samples == 0 {
        bail!("--samples must be at least 1");
    }
    let target = match args.target {
        TargetArg::Float => Target::Float,
        TargetArg::Fixed => Target::Fixed,
    };
    let options = ExportOptions {
        target,
        vector_samples: vectors::default_samples(&task, args.vector_samples),
        source_note: Some(format!("`{}`", args.controller.display())),
    };
    let bundle = hevo_export::export(&controller, &task, &options)?;
    bundle.write(&args.out)?;
    crate::outln!(
        "{} ({} nodes, {} parameters) for {}, {target} target -> {}",
        bundle.model.controller_name,
        bundle.model.nodes.len(),
        bundle.model.n_parameters(),
        bundle.model.task_name,
        args.out.display()
    );
    crate::outln!(
        "test vectors: {} samples, {} cycles (make -C {} check)",
        bundle.vectors.samples.len(),
        bundle.vectors.n_cycles,
        args.out.display()
    );
    if let Some(error) = bundle.sigmoid_error {
        crate::outln!("sigmoid table: largest error {error:.2e} against the exact logistic");
    }
    if args.check_closed_loop {
        // The recorded cycles first: bit identity (float) or the largest errors (fixed).
        let check = closed_loop::make(&args.out, "check")?;
        for line in check.lines().filter(|l| l.starts_with(target.name())) {
            crate::outln!("make check: {line}");
        }
        let program = closed_loop::build_program(&args.out)?;
        let samples = post_evaluation::post_evaluation_samples(&task, args.samples, args.seed);
        let threads = default_threads(args.threads);
        let report = closed_loop::run(&program, &controller, &task, &samples, threads)
            .context("closed loop")?;
        let n = samples.len();
        let percent = |solved: usize| 100.0 * solved as f64 / n as f64;
        crate::outln!(
            "closed loop, {n} samples (seed {}): exported C solved {} ({:.2} %), sim-core {} \
             ({:.2} %); {} of {n} outcomes identical",
            args.seed,
            report.exported_solved(),
            percent(report.exported_solved()),
            report.simulated_solved(),
            percent(report.simulated_solved()),
            report.identical()
        );
    }
    Ok(())
}
