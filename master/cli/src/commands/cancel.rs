//! `hevo cancel`: cancel a job.

use crate::args::JobArgs;
use crate::runtime::runtime;
use anyhow::Result;

/// `hevo cancel`.
pub fn cancel(args: JobArgs) -> Result<()> {
    let options = args.master.options()?;
    let info = runtime()?.block_on(hevo_client::cancel(&options, &args.job))?;
    crate::outln!("{}: {}", args.job, hevo_client::state_name(info.state));
    Ok(())
}
