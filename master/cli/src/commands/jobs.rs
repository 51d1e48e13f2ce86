//! `hevo jobs`: a master's jobs as a table.

use crate::client;
use crate::runtime::runtime;
use anyhow::Result;
use hevo_proto::client::MasterArgs;

/// `hevo jobs`.
pub fn jobs(args: MasterArgs) -> Result<()> {
    let options = args.options()?;
    let table = runtime()?.block_on(client::jobs(&options))?;
    crate::outln!("{}", table.trim_end_matches('\n'));
    Ok(())
}
