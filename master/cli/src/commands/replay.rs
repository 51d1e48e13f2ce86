//! `hevo replay`: simulate one sample of a controller and draw it as an SVG picture (or
//! animation), and/or write its trace as a CSV or JSON table.

use crate::args::{TaskArgs, svg_path};
use crate::inputs::{check_fits, load_controller, other_task_warning};
use anyhow::{Context, Result, bail};
use clap::Args;
use hevo_sim_core::{Controller, Evaluator, Sample};
use std::path::{Path, PathBuf};

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

pub fn replay(args: ReplayArgs) -> Result<()> {
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
