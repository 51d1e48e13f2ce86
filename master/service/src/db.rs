//! The master's durable job store: one redb database, `<state-dir>/hevo.redb`, with a record
//! per job (its experiment text, settings, state, progress) and the submission request ids
//! already served. A submission is committed with full durability before its id is returned,
//! and so is every change of state, so a master killed at any instant (even kill -9) loses no
//! submitted job; progress updates, frequent and recomputed on resume anyway, are committed
//! without waiting for the disk.
//!
//! The store is verified when it is opened, before the master says it listens: redb's own
//! integrity check (which repairs what it can), then every record read back. A damaged file
//! is a clear error naming it and what to do, never a panic: redb's panics are caught and
//! reported the same way. A store that is missing or empty while `<state-dir>/jobs/` holds
//! jobs is refused rather than silently started afresh; `--rebuild-store` rebuilds the index
//! from the copy of each record kept in `jobs/<id>/job.json`. Job ids are time-ordered and
//! random (UUID version 7), so they stay unique even when a store is lost.

use hevo_engine::runner::{Overrides, ProgressEvent};
use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};
use serde::{Deserialize, Serialize};
use std::path::Path;

const JOBS: TableDefinition<'_, &str, &str> = TableDefinition::new("jobs");
/// Submission request id -> job id: a retried submission returns the job it made.
const REQUESTS: TableDefinition<'_, &str, &str> = TableDefinition::new("requests");
/// Job id -> its latest progress, newer than the record's own: progress is written often, and
/// must not rewrite the record's submitted text (megabytes, perhaps) every time.
const PROGRESS: TableDefinition<'_, &str, &str> = TableDefinition::new("progress");

/// A job's progress, as stored apart from its record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct StoredProgress {
    generations_done: u64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    last_event: Option<ProgressEvent>,
}

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
    /// `job-<UUID v7>`: time-ordered, random.
    pub id: String,
    /// The client's id of the submission that made it, if it sent one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub request_id: Option<String>,
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

/// A store operation failed, or the store cannot be used.
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

/// Runs a store operation, turning a panic inside redb (a damaged page met later, say) into
/// an error instead of a crash.
fn guarded<T>(path: &str, body: impl FnOnce() -> Result<T, StoreError>) -> Result<T, StoreError> {
    quiet_panics_in_guarded_calls();
    IN_GUARDED_CALL.with(|flag| flag.set(flag.get() + 1));
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(body));
    IN_GUARDED_CALL.with(|flag| flag.set(flag.get() - 1));
    outcome.unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| panic.downcast_ref::<&str>().copied())
            .unwrap_or("a panic");
        Err(StoreError {
            path: path.to_string(),
            message: format!(
                "the store library failed ({what}): the file is damaged. {}",
                DAMAGED_ADVICE
            ),
        })
    })
}

thread_local! {
    /// How deep the current thread is in [`guarded`] calls.
    static IN_GUARDED_CALL: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Installs, once, a panic hook that keeps a panic inside a [`guarded`] call off stderr: it
/// becomes the clear error the call returns, and a backtrace before it would only alarm. Any
/// other panic goes to the hook that was there before.
fn quiet_panics_in_guarded_calls() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if IN_GUARDED_CALL.with(std::cell::Cell::get) > 0 {
                tracing::debug!(%info, "the store library panicked; reported as a damaged store");
            } else {
                previous(info);
            }
        }));
    });
}

const DAMAGED_ADVICE: &str = "Restore it from a backup, or move it aside and start with `--rebuild-store` (rebuilds the job index from jobs/*/job.json), or start with --state-dir elsewhere";

/// How many job directories `jobs_dir` holds.
fn job_dirs(jobs_dir: &Path) -> usize {
    std::fs::read_dir(jobs_dir).map_or(0, |entries| {
        entries
            .filter_map(Result::ok)
            .filter(|entry| entry.path().is_dir())
            .count()
    })
}

impl JobStore {
    /// Opens (or creates) the database and verifies it. Fails when another master holds it,
    /// when it is damaged, and when it is missing or empty although `jobs_dir` holds jobs.
    pub fn open(path: &Path, jobs_dir: &Path) -> Result<JobStore, StoreError> {
        let path_text = path.display().to_string();
        let fresh = std::fs::metadata(path).map_or(true, |m| m.len() == 0);
        let existing = job_dirs(jobs_dir);
        if fresh && existing > 0 {
            return Err(StoreError {
                path: path_text,
                message: format!(
                    "is missing or empty, but {} holds {existing} job(s): their index is lost. \
                     Restore the store from a backup, or start with `--rebuild-store` to rebuild it \
                     from jobs/*/job.json, or start with --state-dir elsewhere",
                    jobs_dir.display()
                ),
            });
        }
        let store = guarded(&path_text, || {
            Self::open_verified(path, &path_text, jobs_dir, existing)
        })?;
        Ok(store)
    }

    /// Opens, checks and reads back every record; `existing` is how many job directories
    /// `jobs_dir` holds, which a repaired store must still account for.
    fn open_verified(
        path: &Path,
        path_text: &str,
        jobs_dir: &Path,
        existing: usize,
    ) -> Result<JobStore, StoreError> {
        let error = |message: String| StoreError {
            path: path_text.to_string(),
            message,
        };
        let mut db = Database::create(path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => {
                error("already open: is another master using this state directory?".into())
            }
            other => error(format!("cannot be opened ({other}). {DAMAGED_ADVICE}")),
        })?;
        let repaired = match db.check_integrity() {
            Ok(true) => false,
            Ok(false) => {
                tracing::warn!(
                    store = path_text,
                    "the job store was damaged and has been repaired"
                );
                true
            }
            Err(e) => {
                return Err(error(format!(
                    "is damaged beyond repair ({e}). {DAMAGED_ADVICE}"
                )));
            }
        };
        let store = JobStore {
            db,
            path: path_text.to_string(),
        };
        // Create the tables so that readers never meet a missing one.
        store.write(Durability::Immediate, |txn| {
            txn.open_table(JOBS)?;
            txn.open_table(REQUESTS)?;
            txn.open_table(PROGRESS)?;
            Ok(())
        })?;
        // Every record must read back: a damaged value is found now, not by a client later.
        let records = store
            .list()
            .map_err(|e| error(format!("{}. {DAMAGED_ADVICE}", e.message)))?;
        // A repair rolls back to the last whole commit, which may predate the newest jobs:
        // serving then would hide jobs whose directories exist.
        if repaired && records.len() < existing {
            return Err(error(format!(
                "was damaged, and the repaired store holds {} of the {existing} job(s) in {}. \
                 {DAMAGED_ADVICE}",
                records.len(),
                jobs_dir.display()
            )));
        }
        Ok(store)
    }

    /// Builds a new store at `path` from the records kept in `jobs_dir/<id>/job.json`; the
    /// file at `path`, if any, is moved aside to `<path>.damaged-<unix seconds>` first.
    pub fn rebuild(path: &Path, jobs_dir: &Path) -> Result<Rebuilt, StoreError> {
        let path_text = path.display().to_string();
        let error = |message: String| StoreError {
            path: path_text.clone(),
            message,
        };
        if path.exists() {
            let stamp = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            let aside = path.with_extension(format!("redb.damaged-{stamp}"));
            std::fs::rename(path, &aside)
                .map_err(|e| error(format!("cannot move it aside to {}: {e}", aside.display())))?;
            tracing::warn!(from = %path_text, to = %aside.display(), "old job store moved aside");
        }
        let mut records = Vec::new();
        let mut skipped = Vec::new();
        let entries =
            std::fs::read_dir(jobs_dir).map(|e| e.filter_map(Result::ok).collect::<Vec<_>>());
        let mut entries = entries.unwrap_or_default();
        entries.sort_by_key(|entry| entry.file_name());
        for entry in entries {
            let file = entry.path().join(RECORD_FILE);
            match read_record_copy(&entry.file_name().to_string_lossy(), &file) {
                Ok(record) => records.push(record),
                Err(why) => {
                    tracing::warn!(record = %file.display(), %why, "record skipped: not rebuilt");
                    skipped.push(format!("{}: {why}", file.display()));
                }
            }
        }
        let store = guarded(&path_text, || {
            let db = Database::create(path).map_err(|e| error(e.to_string()))?;
            let store = JobStore {
                db,
                path: path_text.clone(),
            };
            store.write(Durability::Immediate, |txn| {
                txn.open_table(PROGRESS)?;
                let mut jobs = txn.open_table(JOBS)?;
                let mut requests = txn.open_table(REQUESTS)?;
                for record in &records {
                    let json = serde_json::to_string(record)
                        .map_err(|e| redb::Error::Corrupted(e.to_string()))?;
                    jobs.insert(record.id.as_str(), json.as_str())?;
                    if let Some(request_id) = &record.request_id {
                        requests.insert(request_id.as_str(), record.id.as_str())?;
                    }
                }
                Ok(())
            })?;
            Ok(store)
        })?;
        Ok(Rebuilt {
            store,
            jobs: records.len(),
            skipped,
        })
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
        guarded(&self.path, || {
            let mut txn = self.db.begin_write().map_err(|e| self.error(e))?;
            txn.set_durability(durability).map_err(|e| self.error(e))?;
            let value = body(&txn).map_err(|e| self.error(e))?;
            txn.commit().map_err(|e| self.error(e))?;
            Ok(value)
        })
    }

    /// Stores a new job under a fresh id, durably; `make` builds the record for the id. A
    /// submission whose `request_id` was served before returns that job instead, and `false`.
    pub fn insert_new(
        &self,
        request_id: Option<&str>,
        make: impl FnOnce(String) -> JobRecord,
    ) -> Result<(JobRecord, bool), StoreError> {
        self.write(Durability::Immediate, |txn| {
            let mut requests = txn.open_table(REQUESTS)?;
            let mut jobs = txn.open_table(JOBS)?;
            if let Some(request_id) = request_id
                && let Some(job_id) = requests.get(request_id)?
            {
                let job_id = job_id.value().to_string();
                if let Some(json) = jobs.get(job_id.as_str())? {
                    let record: JobRecord = serde_json::from_str(json.value())
                        .map_err(|e| redb::Error::Corrupted(e.to_string()))?;
                    return Ok((record, false));
                }
            }
            let mut record = make(new_job_id());
            record.request_id = request_id.map(str::to_string);
            let json = serde_json::to_string(&record)
                .map_err(|e| redb::Error::Corrupted(e.to_string()))?;
            jobs.insert(record.id.as_str(), json.as_str())?;
            if let Some(request_id) = request_id {
                requests.insert(request_id, record.id.as_str())?;
            }
            Ok((record, true))
        })
    }

    /// Replaces a job's record (its progress included); `durable` waits for the disk.
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
            txn.open_table(PROGRESS)?.remove(record.id.as_str())?;
            Ok(())
        })
    }

    /// Stores a job's progress alone, without waiting for the disk (it is recomputed on
    /// resume): a small write, whatever the size of the job's submitted text.
    pub fn put_progress(
        &self,
        id: &str,
        generations_done: u64,
        last_event: Option<&ProgressEvent>,
    ) -> Result<(), StoreError> {
        let json = serde_json::to_string(&StoredProgress {
            generations_done,
            last_event: last_event.cloned(),
        })
        .map_err(|e| self.error(e))?;
        self.write(Durability::None, |txn| {
            txn.open_table(PROGRESS)?.insert(id, json.as_str())?;
            Ok(())
        })
    }

    /// Removes a job's record, progress and request id, durably.
    pub fn delete(&self, record: &JobRecord) -> Result<(), StoreError> {
        self.write(Durability::Immediate, |txn| {
            txn.open_table(JOBS)?.remove(record.id.as_str())?;
            txn.open_table(PROGRESS)?.remove(record.id.as_str())?;
            if let Some(request_id) = &record.request_id {
                txn.open_table(REQUESTS)?.remove(request_id.as_str())?;
            }
            Ok(())
        })
    }

    /// Every job, in id order (which is submission order).
    pub fn list(&self) -> Result<Vec<JobRecord>, StoreError> {
        guarded(&self.path, || {
            let txn = self.db.begin_read().map_err(|e| self.error(e))?;
            let table = txn.open_table(JOBS).map_err(|e| self.error(e))?;
            // A store written before progress had a table of its own has none.
            let progress = match txn.open_table(PROGRESS) {
                Ok(progress) => Some(progress),
                Err(redb::TableError::TableDoesNotExist(_)) => None,
                Err(e) => return Err(self.error(e)),
            };
            let mut records = Vec::new();
            for entry in table.iter().map_err(|e| self.error(e))? {
                let (key, value) = entry.map_err(|e| self.error(e))?;
                let mut record: JobRecord = serde_json::from_str(value.value()).map_err(|e| {
                    self.error(format!("job {}: unreadable record: {e}", key.value()))
                })?;
                if let Some(progress) = &progress
                    && let Some(stored) = progress.get(key.value()).map_err(|e| self.error(e))?
                {
                    let stored: StoredProgress =
                        serde_json::from_str(stored.value()).map_err(|e| {
                            self.error(format!("job {}: unreadable progress: {e}", key.value()))
                        })?;
                    record.generations_done = stored.generations_done;
                    record.last_event = stored.last_event;
                }
                records.push(record);
            }
            Ok(records)
        })
    }
}

/// The copy of a job's record kept in its directory, from which a lost store is rebuilt.
pub const RECORD_FILE: &str = "job.json";

/// A fresh job id: `job-` and a UUID version 7 (milliseconds since the epoch, then random
/// bits), so ids sort by submission time and never repeat, even across lost stores.
/// What `--rebuild-store` made: the store, how many jobs it holds, and the records it left
/// out (each `path: why`).
#[derive(Debug)]
pub struct Rebuilt {
    /// The rebuilt store.
    pub store: JobStore,
    /// Jobs in it.
    pub jobs: usize,
    /// Records left out, and why.
    pub skipped: Vec<String>,
}

/// Whether `id` is a job id as [`new_job_id`] makes them: `job-` and 32 lowercase hex digits.
/// An id is a directory name under the state directory, so nothing else is trusted as one.
pub fn is_job_id(id: &str) -> bool {
    id.strip_prefix("job-").is_some_and(|hex| {
        hex.len() == 32
            && hex
                .bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
    })
}

/// Reads the copy of a record kept in `jobs/<dir_name>/job.json`, refusing one whose id is not
/// a job id or not its directory's name (a copy written elsewhere, or edited to point outside
/// the state directory).
fn read_record_copy(dir_name: &str, file: &Path) -> Result<JobRecord, String> {
    let text = std::fs::read_to_string(file).map_err(|e| format!("cannot read it ({e})"))?;
    let record: JobRecord = serde_json::from_str(&text).map_err(|e| {
        format!(
            "unreadable record: {}",
            hevo_engine::experiment::cut(&e.to_string(), 200)
        )
    })?;
    if !is_job_id(&record.id) || record.id != dir_name {
        return Err(format!(
            "its id '{}' is not a job id naming its own directory",
            hevo_engine::experiment::cut(&record.id.escape_default().to_string(), 80)
        ));
    }
    Ok(record)
}

pub fn new_job_id() -> String {
    format!("job-{}", uuid::Uuid::now_v7().simple())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A queued job's record, for tests here and in `jobs.rs`.
    pub(crate) fn record(id: String) -> JobRecord {
        JobRecord {
            id,
            request_id: None,
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
    fn jobs_survive_reopening_with_time_ordered_ids() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hevo.redb");
        let jobs_dir = dir.path().join("jobs");
        let (first, second) = {
            let store = JobStore::open(&path, &jobs_dir).unwrap();
            let (first, new) = store.insert_new(None, record).unwrap();
            assert!(new && first.id.starts_with("job-") && first.id.len() == 36);
            assert_eq!(first.generations_total(), 14);
            let (mut second, _) = store.insert_new(None, record).unwrap();
            assert!(second.id > first.id, "ids sort by time");
            second.state = JobState::Running;
            second.generations_done = 3;
            store.put(&second, false).unwrap();
            second.state = JobState::Succeeded;
            store.put(&second, true).unwrap();
            assert!(
                JobStore::open(&path, &jobs_dir)
                    .unwrap_err()
                    .to_string()
                    .contains("another master")
            );
            (first.id, second.id)
        };
        let store = JobStore::open(&path, &jobs_dir).unwrap();
        let jobs = store.list().unwrap();
        assert_eq!(
            jobs.iter()
                .map(|j| (j.id.clone(), j.state))
                .collect::<Vec<_>>(),
            [
                (first, JobState::Queued),
                (second.clone(), JobState::Succeeded)
            ]
        );
        assert!(store.insert_new(None, record).unwrap().0.id > second);
    }

    #[test]
    fn progress_is_stored_apart_and_a_deleted_job_is_gone() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hevo.redb");
        let jobs_dir = dir.path().join("jobs");
        let store = JobStore::open(&path, &jobs_dir).unwrap();
        let (job, _) = store
            .insert_new(Some("req-1"), |id| JobRecord {
                experiment_toml: "x".repeat(1 << 20),
                ..record(id)
            })
            .unwrap();
        let before = std::fs::metadata(&path).unwrap().len();
        for done in 1..=200 {
            store.put_progress(&job.id, done, None).unwrap();
        }
        let grown = std::fs::metadata(&path)
            .unwrap()
            .len()
            .saturating_sub(before);
        assert!(
            grown < 4 << 20,
            "200 progress updates grew the store by {grown} bytes (the record is 1 MiB)"
        );
        let listed = store.list().unwrap();
        assert_eq!(listed[0].generations_done, 200);
        assert_eq!(listed[0].experiment_toml.len(), 1 << 20);
        // A change of state writes the whole record, progress included, and it stays.
        let mut finished = listed[0].clone();
        finished.state = JobState::Succeeded;
        store.put(&finished, true).unwrap();
        assert_eq!(store.list().unwrap(), std::slice::from_ref(&finished));
        store.delete(&finished).unwrap();
        assert!(store.list().unwrap().is_empty());
        // Its request id is free again.
        assert!(store.insert_new(Some("req-1"), record).unwrap().1);
    }

    #[test]
    fn a_panic_inside_the_store_library_is_an_error_and_others_still_panic() {
        let error = guarded::<()>("x.redb", || panic!("page 7 is garbage"))
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("x.redb")
                && error.contains("page 7 is garbage")
                && error.contains("damaged"),
            "{error}"
        );
        IN_GUARDED_CALL.with(|depth| assert_eq!(depth.get(), 0));
        // Outside a guarded call the hook passes a panic on.
        assert!(std::panic::catch_unwind(|| panic!("elsewhere")).is_err());
    }

    #[test]
    fn a_retried_submission_returns_its_job() {
        let dir = tempfile::tempdir().unwrap();
        let store =
            JobStore::open(&dir.path().join("hevo.redb"), &dir.path().join("jobs")).unwrap();
        let (job, new) = store.insert_new(Some("req-1"), record).unwrap();
        assert!(new);
        let (again, new) = store.insert_new(Some("req-1"), record).unwrap();
        assert!(!new);
        assert_eq!(again, job);
        assert_eq!(again.request_id.as_deref(), Some("req-1"));
        let (other, new) = store.insert_new(Some("req-2"), record).unwrap();
        assert!(new && other.id != job.id);
        assert_eq!(store.list().unwrap().len(), 2);
    }

    #[test]
    fn a_lost_store_beside_jobs_is_refused_and_can_be_rebuilt() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hevo.redb");
        let jobs_dir = dir.path().join("jobs");
        let job = {
            let store = JobStore::open(&path, &jobs_dir).unwrap();
            let (job, _) = store.insert_new(Some("req-1"), record).unwrap();
            let job_dir = jobs_dir.join(&job.id);
            std::fs::create_dir_all(&job_dir).unwrap();
            std::fs::write(
                job_dir.join(RECORD_FILE),
                serde_json::to_string(&job).unwrap(),
            )
            .unwrap();
            job
        };
        for lose in [
            |p: &Path| std::fs::write(p, b"").unwrap(),
            |p: &Path| std::fs::remove_file(p).unwrap(),
        ] {
            lose(&path);
            let error = JobStore::open(&path, &jobs_dir).unwrap_err().to_string();
            assert!(
                error.contains("missing or empty")
                    && error.contains("1 job(s)")
                    && error.contains("--rebuild-store"),
                "{error}"
            );
        }
        // Damaged and hostile copies beside it are skipped and listed, not fatal.
        let outside = record("../../../outside".into());
        for (dir, text) in [
            ("job-broken", "{ not json".to_string()),
            ("job-escape", serde_json::to_string(&outside).unwrap()),
            (
                "job-0000000000000000000000000000000a",
                serde_json::to_string(&record(job.id.clone())).unwrap(),
            ),
        ] {
            std::fs::create_dir_all(jobs_dir.join(dir)).unwrap();
            std::fs::write(jobs_dir.join(dir).join(RECORD_FILE), text).unwrap();
        }
        let Rebuilt {
            store,
            jobs,
            skipped,
        } = JobStore::rebuild(&path, &jobs_dir).unwrap();
        assert_eq!(jobs, 1);
        assert_eq!(skipped.len(), 3, "{skipped:?}");
        assert!(skipped[0].contains("job-0000") && skipped[0].contains("not a job id naming"));
        assert!(skipped[1].contains("job-broken") && skipped[1].contains("unreadable"));
        assert!(skipped[2].contains("job-escape") && skipped[2].contains("../../../outside"));
        assert!(!dir.path().parent().unwrap().join("outside").exists());
        assert_eq!(store.list().unwrap(), std::slice::from_ref(&job));
        // The request index came back too.
        assert!(!store.insert_new(Some("req-1"), record).unwrap().1);
    }

    #[test]
    fn a_damaged_store_is_a_clear_error_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("hevo.redb");
        let jobs_dir = dir.path().join("jobs");
        {
            let store = JobStore::open(&path, &jobs_dir).unwrap();
            for _ in 0..20 {
                store.insert_new(None, record).unwrap();
            }
        }
        let clean = std::fs::read(&path).unwrap();
        // Garbage over the middle of the file, and a few flipped bytes all over it.
        let mut garbage = clean.clone();
        let middle = garbage.len() / 2;
        for byte in &mut garbage[middle..(middle + 4096).min(clean.len())] {
            *byte = 0xA5;
        }
        let mut flipped = clean.clone();
        for i in 0..20 {
            let at = (i * 7919 + 4096) % flipped.len();
            flipped[at] ^= 0xFF;
        }
        for damaged in [garbage, flipped] {
            std::fs::write(&path, &damaged).unwrap();
            match JobStore::open(&path, &jobs_dir) {
                // redb repaired it: every record still reads back.
                Ok(store) => assert!(store.list().is_ok()),
                Err(error) => {
                    let error = error.to_string();
                    assert!(
                        error.contains("hevo.redb") && error.contains("--rebuild-store"),
                        "{error}"
                    );
                }
            }
        }
    }
}
