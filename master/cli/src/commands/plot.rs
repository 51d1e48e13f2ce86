//! `hevo plot`: the fitness curves of a node's runs as an SVG picture; for MAP-Elites runs also
//! their QD-score and coverage curves (`--qd`) or a run's archive as a heatmap (`--archive`).

use crate::args::svg_path;
use anyhow::{Context, Result, bail};
use clap::Args;
use hevo_engine::rundir::archive::{ARCHIVE_JSON, ArchiveFile, QD_CSV};
use hevo_engine::rundir::{self, SUMMARY};
use std::path::{Path, PathBuf};

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
    /// MAP-Elites runs: draw every run's QD-score and coverage per generation.
    #[arg(long, conflicts_with = "archive")]
    pub qd: bool,
    /// MAP-Elites runs: draw a run's archive as a heatmap of its elites' fitness.
    #[arg(long)]
    pub archive: bool,
    /// With --archive: the run to draw (default: the node's best run once it is finished,
    /// else the lowest run with an archive).
    #[arg(long, requires = "archive")]
    pub run: Option<u32>,
}

pub fn plot(args: PlotArgs) -> Result<()> {
    let node_dir = match &args.node {
        Some(node) => args.runs_dir.join(node),
        None => args.runs_dir.clone(),
    };
    let node_name = node_dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if args.archive {
        return plot_archive(&args, &node_dir, &node_name);
    }
    if args.qd {
        let runs = hevo_viz::read_qd_logs(&node_dir).map_err(anyhow::Error::msg)?;
        if runs.is_empty() {
            bail!(
                "no run-*/{QD_CSV} under {} (written by MAP-Elites runs)",
                node_dir.display()
            );
        }
        let svg = hevo_viz::qd_plot_svg(&format!("{node_name}: QD-score and coverage"), &runs);
        write_svg(&args.out, &svg)?;
        crate::outln!("{} runs plotted -> {}", runs.len(), args.out.display());
        return Ok(());
    }
    let runs = hevo_viz::read_run_logs(&node_dir)?;
    if runs.is_empty() {
        let hint = if args.node.is_none() {
            " (pass --node NAME to plot a node of a run directory)"
        } else {
            ""
        };
        bail!("no run-*/fitness.csv under {}{hint}", node_dir.display());
    }
    let title = format!("{node_name}: fitness per generation");
    let svg = hevo_viz::fitness_plot_svg(&title, &runs, None);
    write_svg(&args.out, &svg)?;
    crate::outln!("{} runs plotted -> {}", runs.len(), args.out.display());
    Ok(())
}

fn write_svg(out: &Path, svg: &str) -> Result<()> {
    hevo_engine::store::write_atomic(out, svg.as_bytes())
        .with_context(|| format!("cannot write {}", out.display()))
}

/// `hevo plot --archive`: the chosen run's archive as a heatmap.
fn plot_archive(args: &PlotArgs, node_dir: &Path, node_name: &str) -> Result<()> {
    let run = match args.run {
        Some(run) => run,
        None => {
            let summary =
                hevo_engine::store::read_json::<rundir::NodeSummary>(&node_dir.join(SUMMARY))
                    .ok()
                    .flatten();
            let with_archive = rundir::run_dirs(node_dir)
                .unwrap_or_default()
                .into_iter()
                .find(|(_, dir)| dir.join(ARCHIVE_JSON).is_file())
                .map(|(run, _)| run);
            match summary.map(|s| s.best_run).or(with_archive) {
                Some(run) => run,
                None => bail!(
                    "no run-*/{ARCHIVE_JSON} under {} (written by MAP-Elites runs)",
                    node_dir.display()
                ),
            }
        }
    };
    let path = rundir::run_dir(node_dir, run).join(ARCHIVE_JSON);
    let archive = ArchiveFile::read(&path).map_err(anyhow::Error::msg)?;
    let title = format!(
        "{node_name} run {run}: archive after {} generations ({} of {} cells)",
        archive.generation,
        archive.elites.len(),
        archive.n_cells()
    );
    let svg = hevo_viz::archive_heatmap_svg(&title, &archive)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    write_svg(&args.out, &svg)?;
    crate::outln!(
        "{} elites of run {run} drawn -> {}",
        archive.elites.len(),
        args.out.display()
    );
    Ok(())
}
