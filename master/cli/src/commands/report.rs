//! `hevo report`: REPRODUCTION.md, the paper's figures beside hevo's, from run directories.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

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

/// `hevo report`.
pub fn report(args: ReportArgs) -> Result<()> {
    let n = hevo_report::write_report(&args.runs_dirs, &args.ablation_dirs, &args.out)?;
    crate::outln!("{n} node(s) reported -> {}", args.out.display());
    Ok(())
}
