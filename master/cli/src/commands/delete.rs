//! `hevo delete`: delete a finished job, its record, results and files, from the master.

use crate::args::JobArgs;
use crate::runtime::runtime;
use anyhow::Result;

/// `hevo delete`.
pub fn delete(args: JobArgs) -> Result<()> {
    let options = args.master.options()?;
    runtime()?.block_on(hevo_client::delete(&options, &args.job))?;
    crate::outln!("{}: deleted", args.job);
    Ok(())
}
