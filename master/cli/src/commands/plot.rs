//! `hevo plot`: the fitness curves of a node's runs as an SVG picture.

use crate::args::svg_path;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;

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

pub fn plot(args: PlotArgs) -> Result<()> {
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
    let svg = hevo_viz::fitness_plot_svg(&title, &runs, None);
    hevo_engine::store::write_atomic(&args.out, svg.as_bytes())
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    crate::outln!("{} runs plotted -> {}", runs.len(), args.out.display());
    Ok(())
}
