//! `hevo dashboard`: the live dashboard over local run directories.

use crate::runtime::runtime;
use anyhow::{Context, Result, bail};
use clap::Args;
use std::path::PathBuf;
use std::sync::Arc;

/// `hevo dashboard`.
#[derive(Debug, Args)]
pub struct DashboardArgs {
    /// Run output directories (as given to `hevo run --out`), each shown as one job.
    #[arg(required = true, value_name = "RUNS_DIR")]
    pub runs_dirs: Vec<PathBuf>,
    /// Address to serve on (port 0: any free port); the URL is printed first on stdout as
    /// `dashboard on http://ADDR`. The default is reachable from this machine only.
    #[arg(long, default_value = "127.0.0.1:0", value_name = "ADDR")]
    pub listen: String,
    /// Ask for one of the tokens in this file (one per line) before showing anything, as a
    /// master's dashboard does; without it anyone who reaches the address sees the runs.
    #[arg(long)]
    pub token_file: Option<PathBuf>,
}

pub fn dashboard(args: DashboardArgs) -> Result<()> {
    let access = match &args.token_file {
        Some(file) => {
            let tokens = hevo_proto::auth::read_token_file(file)?;
            if tokens.is_empty() {
                bail!("{} holds no token", file.display());
            }
            hevo_dashboard::Access::tokens(tokens)
        }
        None => hevo_dashboard::Access::Open,
    };
    let source = hevo_dashboard::rundirs::RunDirSource::new(&args.runs_dirs)?;
    runtime()?.block_on(async move {
        let listener = tokio::net::TcpListener::bind(&args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        let address = listener.local_addr()?;
        crate::outln!("dashboard on http://{address}");
        let source = Arc::new(source);
        source.watch_for_changes();
        let board = hevo_dashboard::Dashboard::new(source, access);
        hevo_dashboard::serve(
            listener,
            board,
            hevo_dashboard::ConnectionLimits::DEFAULT,
            async {
                let _ = tokio::signal::ctrl_c().await;
            },
        )
        .await
        .context("the dashboard server failed")
    })
}
