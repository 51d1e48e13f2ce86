//! The master's jobs as the dashboard's [`Source`]: the job records of the [`JobManager`], the
//! files their runs write under the state directory (read as any run directory is, by
//! hevo-dashboard), the job's own task settings for replays, cancellation through the manager,
//! and the dispatcher's worker counts. The dashboard's streams wait on the manager's change
//! counter, which moves with every progress event.

use crate::db::JobRecord;
use crate::jobs::{JobError, JobManager};
use hevo_dashboard::rundirs::{read_best, read_nodes};
use hevo_dashboard::{
    BestController, BoxFuture, JobOverview, NodeView, Source, SourceError, SpotChecksView,
    WorkersView,
};
use hevo_engine::experiment::Experiment;
use std::path::Path;

/// The master's jobs, for the dashboard.
#[derive(Debug, Clone)]
pub struct JobsSource {
    manager: JobManager,
}

impl JobsSource {
    /// The jobs of `manager`.
    pub fn new(manager: JobManager) -> JobsSource {
        JobsSource { manager }
    }

    fn record(&self, id: &str) -> Result<JobRecord, SourceError> {
        self.manager.get(id).map_err(to_source_error)
    }

    fn overview(&self, record: &JobRecord) -> JobOverview {
        JobOverview {
            id: record.id.clone(),
            name: record.experiment_name.clone(),
            state: record.state.name().to_string(),
            finished: record.state.is_final(),
            generations_done: record.generations_done,
            generations_total: Some(record.generations_total()),
            created_unix_ms: Some(record.created_unix_ms),
            finished_unix_ms: record.finished_unix_ms,
            error: record.error.clone(),
            nodes: record
                .plan
                .iter()
                .map(|(node, _, _)| node.clone())
                .collect(),
            cancellable: true,
            location: self.manager.out_dir(&record.id).display().to_string(),
        }
    }
}

fn to_source_error(error: JobError) -> SourceError {
    match error {
        JobError::NotFound(id) => SourceError::NotFound(id),
        JobError::Invalid { .. } => SourceError::Invalid(error.to_string()),
        other => SourceError::Failed(other.to_string()),
    }
}

impl Source for JobsSource {
    fn title(&self) -> String {
        "hevo master".to_string()
    }

    fn jobs(&self) -> Vec<JobOverview> {
        self.manager
            .list()
            .iter()
            .map(|record| self.overview(record))
            .collect()
    }

    fn job(&self, id: &str) -> Result<JobOverview, SourceError> {
        Ok(self.overview(&self.record(id)?))
    }

    fn nodes(&self, id: &str) -> Result<Vec<NodeView>, SourceError> {
        let record = self.record(id)?;
        let names: Vec<String> = record
            .plan
            .iter()
            .map(|(node, _, _)| node.clone())
            .collect();
        let planned = |name: &str| {
            record
                .plan
                .iter()
                .find(|(node, _, _)| node == name)
                .map(|(_, runs, generations)| (*runs, *generations))
        };
        Ok(read_nodes(&self.manager.out_dir(id), &names, &planned))
    }

    fn best_controller(&self, id: &str, node: &str) -> Result<Option<BestController>, SourceError> {
        let record = self.record(id)?;
        // The node's own task settings, as the job evolved it.
        let task = Experiment::parse_with(
            &record.experiment_toml,
            Path::new(&record.file_name),
            &record.files,
        )
        .ok()
        .and_then(|experiment| experiment.node(node).map(|plan| plan.task.clone()));
        read_best(&self.manager.out_dir(id), node, task)
    }

    fn cancel<'a>(&'a self, id: &'a str) -> BoxFuture<'a, Result<(), SourceError>> {
        Box::pin(async move {
            self.manager
                .cancel(id)
                .await
                .map(|_| ())
                .map_err(to_source_error)
        })
    }

    fn workers(&self) -> Option<WorkersView> {
        let dispatcher = self.manager.dispatcher();
        let stats = dispatcher.stats(std::time::Instant::now());
        let spot_checks = (dispatcher.verify_share() > 0.0).then(|| SpotChecksView {
            share: dispatcher.verify_share(),
            checked: stats.spot_checks,
            refused_workers: dispatcher.refused_workers(),
        });
        Some(WorkersView {
            active_workers: stats.active_workers,
            active_threads: stats.active_threads,
            leased_batches: stats.leased_batches,
            queued_batches: stats.queued_batches,
            evaluations: stats.evaluations,
            batches_completed: stats.batches_completed,
            spot_checks,
        })
    }

    fn changes(&self) -> tokio::sync::watch::Receiver<u64> {
        self.manager.changes()
    }
}
