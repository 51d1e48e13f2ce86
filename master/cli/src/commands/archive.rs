//! `hevo archive export`: every elite of a MAP-Elites run's archive as a controller file, so
//! `hevo eval` and `hevo replay` work on any of them, with an index of what each one did.

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use hevo_engine::rundir::archive::{ARCHIVE_JSON, ArchiveFile};
use hevo_engine::rundir::{self, BEST, SUMMARY};
use hevo_engine::store;
use hevo_sim_core::ControllerFile;
use std::path::{Path, PathBuf};

/// `hevo archive`.
#[derive(Debug, Args)]
pub struct ArchiveArgs {
    /// What to do with the archive.
    #[command(subcommand)]
    pub command: ArchiveCommand,
}

/// `hevo archive` subcommands.
#[derive(Debug, Subcommand)]
pub enum ArchiveCommand {
    /// Write every elite of a MAP-Elites run as a controller file (`cell-<c>.json`), with
    /// `elites.csv` listing each one's cell, bins, descriptor and fitness.
    Export(ExportArgs),
}

/// `hevo archive export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// A finished MAP-Elites run's directory (`<out>/<node>/run-<k>`), or a node's directory
    /// (its best run's archive).
    pub run_dir: PathBuf,
    /// The directory to write the controllers into (created if missing).
    #[arg(long)]
    pub out: PathBuf,
}

/// The index written beside the controllers.
pub const INDEX_CSV: &str = "elites.csv";

pub fn archive(args: ArchiveArgs) -> Result<()> {
    match args.command {
        ArchiveCommand::Export(args) => export(args),
    }
}

/// The run directory of `dir`: itself when it holds an archive, else a node directory's best
/// run, by its summary.
fn run_dir_of(dir: &Path) -> Result<PathBuf> {
    if dir.join(ARCHIVE_JSON).is_file() {
        return Ok(dir.to_path_buf());
    }
    let summary_path = dir.join(SUMMARY);
    if let Ok(Some(summary)) = store::read_json::<rundir::NodeSummary>(&summary_path) {
        let best = rundir::run_dir(dir, summary.best_run);
        if best.join(ARCHIVE_JSON).is_file() {
            return Ok(best);
        }
    }
    bail!(
        "no {ARCHIVE_JSON} in {}: pass a MAP-Elites run's directory (<out>/<node>/run-<k>) or its node's",
        dir.display()
    )
}

fn export(args: ExportArgs) -> Result<()> {
    let run_dir = run_dir_of(&args.run_dir)?;
    let archive = ArchiveFile::read(&run_dir.join(ARCHIVE_JSON)).map_err(anyhow::Error::msg)?;
    // The run's controller is its node over its fixed children: each elite is that tree with
    // the node's genome replaced.
    let best_path = run_dir.join(BEST);
    let text = std::fs::read_to_string(&best_path).with_context(|| {
        format!(
            "cannot read {}: the run's controller is the template of its elites (is the run finished?)",
            best_path.display()
        )
    })?;
    let mut template = ControllerFile::from_json_str(&text)
        .with_context(|| format!("{} is not a controller file", best_path.display()))?;
    template.root.genome = None;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut index = String::from("file,cell");
    for (value, name) in archive.descriptor.iter().enumerate() {
        index.push_str(&format!(",bin_{value},{name}"));
    }
    index.push_str(",fitness\n");
    for elite in &archive.elites {
        let controller = template.with_free_genome(&elite.genes).with_context(|| {
            format!(
                "the elite of cell {} does not fit {}'s network",
                elite.cell,
                best_path.display()
            )
        })?;
        let name = format!("cell-{}.json", elite.cell);
        let path = args.out.join(&name);
        store::write_atomic(&path, controller.to_json_pretty()?.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        index.push_str(&format!("{name},{}", elite.cell));
        for (bin, value) in elite.bins.iter().zip(&elite.descriptor) {
            index.push_str(&format!(",{bin},{value}"));
        }
        index.push_str(&format!(",{}\n", elite.fitness));
    }
    let index_path = args.out.join(INDEX_CSV);
    store::write_atomic(&index_path, index.as_bytes())
        .with_context(|| format!("cannot write {}", index_path.display()))?;
    crate::outln!(
        "{} elites of {} ({} of {} cells, generation {}) -> {}",
        archive.elites.len(),
        run_dir.display(),
        archive.elites.len(),
        archive.n_cells(),
        archive.generation,
        args.out.display()
    );
    Ok(())
}
