//! `hevo report`: REPRODUCTION.md, the paper's figures beside hevo's, from run directories; or,
//! with `--study`, the algorithm study's page from its study file.

use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// `hevo report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Run output directories (as given to `hevo run --out`).
    #[arg(required_unless_present = "study")]
    pub runs_dirs: Vec<PathBuf>,
    /// A run output directory of an ablation (repeatable): its nodes evolved under another
    /// setup than the same nodes in RUNS_DIRS, or given more runs of the same setup, get a
    /// section of their own, beside them.
    #[arg(long = "ablation", value_name = "DIR")]
    pub ablation_dirs: Vec<PathBuf>,
    /// An evaluation record (`hevo eval --record`, repeatable): a controller's rate on a task
    /// it was not evolved for, in a section of its own.
    #[arg(long = "evaluation", value_name = "FILE")]
    pub evaluations: Vec<PathBuf>,
    /// Instead of the paper's report, the study page of this study file (a TOML list of
    /// questions, each with the run directories of the algorithms that searched it; see
    /// `experiments/study/study.toml`).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["runs_dirs", "ablation_dirs", "evaluations"])]
    pub study: Option<PathBuf>,
    /// The Markdown file to write (default `REPRODUCTION.md`, or `docs/study-algorithms.md`
    /// with `--study`); pictures go to a folder named after it beside it (`reproduction/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `hevo report`.
pub fn report(args: ReportArgs) -> Result<()> {
    if let Some(study) = &args.study {
        let out = args
            .out
            .unwrap_or_else(|| PathBuf::from("docs/study-algorithms.md"));
        let n = hevo_report::write_study_report(study, &out)?;
        crate::outln!(
            "{n} search(es) with finished runs reported -> {}",
            out.display()
        );
        return Ok(());
    }
    let out = args.out.unwrap_or_else(|| PathBuf::from("REPRODUCTION.md"));
    let n = hevo_report::write_report(
        &args.runs_dirs,
        &args.ablation_dirs,
        &args.evaluations,
        &out,
    )?;
    crate::outln!("{n} node(s) reported -> {}", out.display());
    Ok(())
}
