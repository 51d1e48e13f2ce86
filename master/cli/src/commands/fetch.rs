//! `hevo fetch`: download a job's results into a directory laid out as `hevo run --out`'s.

use crate::runtime::runtime;
use anyhow::Result;
use clap::Args;
use hevo_proto::client::MasterArgs;
use std::path::PathBuf;

/// `hevo fetch`.
#[derive(Debug, Args)]
pub struct FetchArgs {
    #[command(flatten)]
    pub master: MasterArgs,
    /// The job id.
    pub job: String,
    /// Where to write the results (the layout of `hevo run --out`).
    #[arg(long)]
    pub out: PathBuf,
}

/// `hevo fetch`.
pub fn fetch(args: FetchArgs) -> Result<()> {
    let options = args.master.options()?;
    let (info, files) = runtime()?.block_on(hevo_client::fetch(&options, &args.job, &args.out))?;
    let state = hevo_client::state_name(info.state);
    if state != "succeeded" {
        eprintln!(
            "warning: job {} is {state}: its results are incomplete",
            args.job
        );
    }
    crate::outln!(
        "{files} files of job {} ({state}) -> {}",
        args.job,
        args.out.display()
    );
    Ok(())
}
