//! `hevo submit`: send an experiment file to a master; prints the job id alone.

use crate::args::OverrideArgs;
use crate::runtime::runtime;
use anyhow::Result;
use clap::Args;
use hevo_proto::client::MasterArgs;
use std::path::PathBuf;

/// `hevo submit`.
#[derive(Debug, Args)]
pub struct SubmitArgs {
    #[command(flatten)]
    pub master: MasterArgs,
    /// The experiment file (TOML).
    pub file: PathBuf,
    #[command(flatten)]
    pub overrides: OverrideArgs,
}

/// `hevo submit`: prints the job id alone.
pub fn submit(args: SubmitArgs) -> Result<()> {
    let options = args.master.options()?;
    let settings = args.overrides.overrides();
    let job = runtime()?.block_on(hevo_client::submit(&options, &args.file, settings))?;
    crate::outln!("{job}");
    Ok(())
}
