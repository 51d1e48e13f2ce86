//! The master's durable job store: one redb database, `<state-dir>/hevo.redb`, with a record
//! per job (its experiment text, settings, state, progress) and a job counter. A submission is
//! committed with full durability before its id is returned, and so is every change of state,
//! so a master killed at any instant (even kill -9) loses no submitted job; progress updates,
//! frequent and recomputed on resume anyway, are committed without waiting for the disk.

use hevo_engine::runner::{Overrides, ProgressEvent};
use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};
use serde::{Deserialize, Serialize};
use std::path::Path;

const JOBS: TableDefinition<'_, &str, &str> = TableDefinition::new("jobs");
const META: TableDefinition<'_, &str, u64> = TableDefinition::new("meta");
const NEXT_JOB: &str = "next_job";

/// Where a job is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    /// Stored, not started yet.
    Queued,
    /// Being evolved (or to be resumed when the master restarts).
    Running,
    /// Finished; results are complete.
    Succeeded,
    /// Stopped by an error.
    Failed,
    /// Stopped by a user.
    Cancelled,
}

impl JobState {
    /// Every state, for metrics.
    pub const ALL: [JobState; 5] = [
        JobState::Queued,
        JobState::Running,
        JobState::Succeeded,
        JobState::Failed,
        JobState::Cancelled,
    ];

    /// Whether the job will not change any more.
    pub fn is_final(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Cancelled
        )
    }

    /// The lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Succeeded => "succeeded",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }
}

/// One job, as stored.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JobRecord {
    /// `job-000001`, ...
    pub id: String,
    /// The experiment's name.
    pub experiment_name: String,
    /// The submitted file's name (for messages).
    pub file_name: String,
    /// The experiment file's text.
    pub experiment_toml: String,
    /// The files it reads from elsewhere, by relative path (see `SubmitJobRequest.files`).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub files: std::collections::BTreeMap<String, String>,
    /// Overrides.
    pub settings: Overrides,
    /// The nodes the job evolves, in order, with (runs, generations) each.
    pub plan: Vec<(String, u32, u32)>,
    /// State.
    pub state: JobState,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// Submission time, ms since the Unix epoch.
    pub created_unix_ms: i64,
    /// When it reached a final state.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finished_unix_ms: Option<i64>,
    /// Generations evaluated so far.
    #[serde(default)]
    pub generations_done: u64,
    /// The latest progress event.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_event: Option<ProgressEvent>,
}

impl JobRecord {
    /// Generations the whole job evaluates.
    pub fn generations_total(&self) -> u64 {
        self.plan
            .iter()
            .map(|(_, runs, generations)| u64::from(*runs) * u64::from(*generations))
            .sum()
    }
}

/// A store operation failed.
#[derive(Debug, thiserror::Error)]
#[error("job store {path}: {message}")]
pub struct StoreError {
    path: String,
    message: String,
}

/// The job database.
#[derive(Debug)]
pub struct JobStore {
    db: Database,
    path: String,
}

impl JobStore {
    /// Opens (or creates) the database. Fails when another master holds it.
    pub fn open(path: &Path) -> Result<JobStore, StoreError> {
        let display = path.display().to_string();
        let db = Database::create(path).map_err(|e| {
            let message = match e {
                redb::DatabaseError::DatabaseAlreadyOpen => {
                    "already open: is another master using this state directory?".to_string()
                }
                other => other.to_string(),
            };
            StoreError {
                path: display.clone(),
                message,
            }
        })?;
        let store = JobStore { db, path: display };
        // Create the tables so that readers never meet a missing one.
        store.write(Durability::Immediate, |txn| {
            txn.open_table(JOBS)?;
            txn.open_table(META)?;
            Ok(())
        })?;
        Ok(store)
    }

    fn error(&self, error: impl std::fmt::Display) -> StoreError {
        StoreError {
            path: self.path.clone(),
            message: error.to_string(),
        }
    }

    fn write<T>(
        &self,
        durability: Durability,
        body: impl FnOnce(&redb::WriteTransaction) -> Result<T, redb::Error>,
    ) -> Result<T, StoreError> {
        let mut txn = self.db.begin_write().map_err(|e| self.error(e))?;
        txn.set_durability(durability).map_err(|e| self.error(e))?;
        let value = body(&txn).map_err(|e| self.error(e))?;
        txn.commit().map_err(|e| self.error(e))?;
        Ok(value)
    }

    /// Stores a new job under the next id, durably; `make` builds the record for the id.
    pub fn insert_new(
        &self,
        make: impl FnOnce(String) -> JobRecord,
    ) -> Result<JobRecord, StoreError> {
        self.write(Durability::Immediate, |txn| {
            let mut meta = txn.open_table(META)?;
            let number = meta.get(NEXT_JOB)?.map_or(1, |v| v.value());
            meta.insert(NEXT_JOB, number + 1)?;
            let record = make(format!("job-{number:06}"));
            let json = serde_json::to_string(&record)
                .map_err(|e| redb::Error::Corrupted(e.to_string()))?;
            txn.open_table(JOBS)?
                .insert(record.id.as_str(), json.as_str())?;
            Ok(record)
        })
    }

    /// Replaces a job's record; `durable` waits for the disk.
    pub fn put(&self, record: &JobRecord, durable: bool) -> Result<(), StoreError> {
        let json = serde_json::to_string(record).map_err(|e| self.error(e))?;
        let durability = if durable {
            Durability::Immediate
        } else {
            Durability::None
        };
        self.write(durability, |txn| {
            txn.open_table(JOBS)?
                .insert(record.id.as_str(), json.as_str())?;
            Ok(())
        })
    }

    /// Every job, in id order.
    pub fn list(&self) -> Result<Vec<JobRecord>, StoreError> {
        let txn = self.db.begin_read().map_err(|e| self.error(e))?;
        let table = txn.open_table(JOBS).map_err(|e| self.error(e))?;
        let mut records = Vec::new();
        for entry in table.iter().map_err(|e| self.error(e))? {
            let (key, value) = entry.map_err(|e| self.error(e))?;
            let record: JobRecord = serde_json::from_str(value.value())
                .map_err(|e| self.error(format!("job {}: unreadable record: {e}", key.value())))?;
            records.push(record);
        }
        Ok(records)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(id: String) -> JobRecord {
        JobRecord {
            id,
            experiment_name: "e".into(),
            file_name: "e.toml".into(),
            experiment_toml: "[experiment]".into(),
            files: Default::default(),
            settings: Overrides {
                seed: Some(3),
                ..Overrides::default()
            },
            plan: vec![("a".into(), 2, 5), ("b".into(), 1, 4)],
            state: JobState::Queued,
            error: None,
            created_unix_ms: 1,
            finished_unix_ms: None,
            generations_done: 0,
            last_event: None,
        }
    }

    #[test]
    fn jobs_survive_reopening_and_ids_keep_counting() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hevo.redb");
        {
            let store = JobStore::open(&path).unwrap();
            let first = store.insert_new(record).unwrap();
            assert_eq!(first.id, "job-000001");
            assert_eq!(first.generations_total(), 14);
            let mut second = store.insert_new(record).unwrap();
            second.state = JobState::Running;
            second.generations_done = 3;
            store.put(&second, false).unwrap();
            second.state = JobState::Succeeded;
            store.put(&second, true).unwrap();
            assert!(
                JobStore::open(&path)
                    .unwrap_err()
                    .to_string()
                    .contains("another master")
            );
        }
        let store = JobStore::open(&path).unwrap();
        let jobs = store.list().unwrap();
        assert_eq!(
            jobs.iter()
                .map(|j| (j.id.as_str(), j.state))
                .collect::<Vec<_>>(),
            [
                ("job-000001", JobState::Queued),
                ("job-000002", JobState::Succeeded)
            ]
        );
        assert_eq!(store.insert_new(record).unwrap().id, "job-000003");
    }
}
