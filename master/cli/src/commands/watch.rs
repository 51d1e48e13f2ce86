//! `hevo watch`: follow a job until it ends; the exit status says whether it succeeded.

use crate::args::JobArgs;
use crate::client;
use crate::runtime::runtime;
use anyhow::{Result, bail};

/// `hevo watch`: an error unless the job succeeded.
pub fn watch(args: JobArgs) -> Result<()> {
    let options = args.master.options()?;
    let info = runtime()?.block_on(client::watch(&options, &args.job))?;
    match hevo_proto::v1::JobState::try_from(info.state) {
        Ok(hevo_proto::v1::JobState::Succeeded) => Ok(()),
        Ok(hevo_proto::v1::JobState::Cancelled) => bail!("job {} was cancelled", args.job),
        _ => bail!("job {} failed: {}", args.job, info.error),
    }
}
