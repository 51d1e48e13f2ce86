//! Run directories as the dashboard reads them, through the engine's run-directory format:
//! [`read_nodes`] (a node's runs, fitness logs and summaries, shared with the master's source,
//! whose jobs write the same layout), [`read_best`], and [`RunDirSource`], the [`Source`] of
//! `hevo dashboard RUNS_DIR...`: each directory is one job, named after it, and one task
//! watches the directories' logs and summaries for changes while a local run writes them.

use crate::{BestController, BoxFuture, JobOverview, NodeView, RunView, Source, SourceError};
use hevo_rundir::archive::{ArchiveFile, parse_qd_csv};
use hevo_rundir::store::read_json;
use hevo_rundir::{self as rundir, NodeSummary, RunSummary};
use hevo_sim_core::ControllerFile;
use hevo_sim_core::TaskConfig;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::watch;

/// How often [`RunDirSource::watch_for_changes`] looks at the files.
pub const WATCH_INTERVAL: Duration = Duration::from_millis(500);

/// The nodes `names` of the run directory `out_dir`; a node without files yet has no runs.
/// `planned` gives (runs, generations) per name, when known. A log that does not parse is left
/// out (a run that is writing it renames a whole file, so this is damage, not a race).
pub fn read_nodes(
    out_dir: &Path,
    names: &[String],
    planned: &dyn Fn(&str) -> Option<(u32, u32)>,
) -> Vec<NodeView> {
    names
        .iter()
        .map(|name| {
            let node_dir = rundir::node_dir(out_dir, name);
            let runs = rundir::run_dirs(&node_dir)
                .unwrap_or_default()
                .into_iter()
                .map(|(run, dir)| RunView {
                    run,
                    rows: std::fs::read_to_string(dir.join(rundir::FITNESS_CSV))
                        .ok()
                        .and_then(|text| rundir::parse_fitness_csv(&text).ok())
                        .unwrap_or_default(),
                    summary: read_json::<RunSummary>(&dir.join(rundir::SUMMARY))
                        .ok()
                        .flatten(),
                    archive: ArchiveFile::read(&dir.join(rundir::ARCHIVE_JSON)).ok(),
                    qd: std::fs::read_to_string(dir.join(rundir::QD_CSV))
                        .ok()
                        .and_then(|text| parse_qd_csv(&text).ok())
                        .unwrap_or_default(),
                })
                .collect();
            NodeView {
                name: name.clone(),
                runs,
                summary: read_json::<NodeSummary>(&node_dir.join(rundir::SUMMARY))
                    .ok()
                    .flatten(),
                planned: planned(name),
            }
        })
        .collect()
}

/// The nodes found in a run directory: sub-directories holding a node summary or run
/// directories, by name.
pub fn node_names(out_dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(out_dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter(|entry| entry.path().is_dir())
        .filter(|entry| {
            let dir = entry.path();
            dir.join(rundir::SUMMARY).is_file()
                || rundir::run_dirs(&dir).is_ok_and(|runs| !runs.is_empty())
        })
        .filter_map(|entry| entry.file_name().to_str().map(str::to_string))
        .collect();
    names.sort();
    names
}

/// A finished node's best controller, replayed on `task`; without one, on the task the node
/// recorded (`<node>/task.json`), else, for a run directory written before nodes recorded
/// their task, on the paper's settings of the shipped task its summary names. `None` while
/// the node runs.
pub fn read_best(
    out_dir: &Path,
    node: &str,
    task: Option<TaskConfig>,
) -> Result<Option<BestController>, SourceError> {
    let node_dir = rundir::node_dir(out_dir, node);
    let summary = match read_json::<NodeSummary>(&node_dir.join(rundir::SUMMARY)) {
        Ok(Some(summary)) => summary,
        Ok(None) => return Ok(None),
        Err(error) => return Err(SourceError::Failed(error.to_string())),
    };
    let best_path = node_dir.join(rundir::BEST);
    let text = std::fs::read_to_string(&best_path)
        .map_err(|e| SourceError::Failed(format!("{}: {e}", best_path.display())))?;
    let file = ControllerFile::from_json_str(&text)
        .map_err(|e| SourceError::Failed(format!("{}: {e}", best_path.display())))?;
    let task = match task {
        Some(task) => task,
        None => recorded_task(&node_dir, node, &summary.task)?,
    };
    Ok(Some(BestController { file, task }))
}

/// The task a node recorded, or the shipped task its summary names; else an error naming the
/// missing file.
fn recorded_task(node_dir: &Path, node: &str, task_name: &str) -> Result<TaskConfig, SourceError> {
    let task_path = node_dir.join(rundir::TASK);
    match read_json::<TaskConfig>(&task_path) {
        Ok(Some(task)) => Ok(task),
        Ok(None) => TaskConfig::shipped(task_name).ok_or_else(|| {
            SourceError::Failed(format!(
                "node {node}: task {task_name} is not a shipped scenario, and {} is missing \
                 (run directories written before nodes recorded their task lack it; \
                 `hevo run` of the experiment with this --out writes it without evolving again)",
                task_path.display()
            ))
        }),
        Err(error) => Err(SourceError::Failed(error.to_string())),
    }
}

/// A fingerprint of what the pages show of a run directory: the size and modification time of
/// every log and summary.
fn signature(out_dir: &Path) -> u64 {
    let mut hash = hevo_sim_core::Fnv1a::new();
    for name in node_names(out_dir) {
        let node_dir = rundir::node_dir(out_dir, &name);
        let mut files = vec![node_dir.join(rundir::SUMMARY)];
        for (_, run_dir) in rundir::run_dirs(&node_dir).unwrap_or_default() {
            files.push(run_dir.join(rundir::FITNESS_CSV));
            files.push(run_dir.join(rundir::SUMMARY));
        }
        for file in files {
            hash.write_str(&file.to_string_lossy());
            if let Ok(metadata) = std::fs::metadata(&file) {
                hash.write_u64(metadata.len());
                let modified = metadata
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_nanos() as u64);
                hash.write_u64(modified);
            }
        }
    }
    hash.finish()
}

/// Local run directories as jobs.
#[derive(Debug)]
pub struct RunDirSource {
    dirs: Vec<(String, PathBuf)>,
    changes: watch::Sender<u64>,
}

impl RunDirSource {
    /// The directories, each one job whose id is the directory's name (made unique with
    /// `-2`, `-3`, ... when two share a name). A path that is no directory is an error naming
    /// it.
    pub fn new(dirs: &[PathBuf]) -> Result<RunDirSource, SourceError> {
        let mut named: Vec<(String, PathBuf)> = Vec::new();
        for dir in dirs {
            if !dir.is_dir() {
                return Err(SourceError::Invalid(format!(
                    "{} is not a directory",
                    dir.display()
                )));
            }
            let canonical = dir.canonicalize().unwrap_or_else(|_| dir.clone());
            let base: String = canonical
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "runs".to_string())
                .chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || "-_.".contains(c) {
                        c
                    } else {
                        '_'
                    }
                })
                .collect();
            let mut id = base.clone();
            let mut k = 2;
            while named.iter().any(|(other, _)| *other == id) {
                id = format!("{base}-{k}");
                k += 1;
            }
            named.push((id, dir.clone()));
        }
        Ok(RunDirSource {
            dirs: named,
            changes: watch::channel(0).0,
        })
    }

    fn dir(&self, id: &str) -> Result<&Path, SourceError> {
        self.dirs
            .iter()
            .find(|(name, _)| name == id)
            .map(|(_, dir)| dir.as_path())
            .ok_or_else(|| SourceError::NotFound(id.to_string()))
    }

    fn overview(&self, id: &str, dir: &Path) -> JobOverview {
        let names = node_names(dir);
        let nodes = read_nodes(dir, &names, &|_| None);
        let finished = !nodes.is_empty() && nodes.iter().all(NodeView::finished);
        JobOverview {
            id: id.to_string(),
            name: id.to_string(),
            state: if finished { "finished" } else { "in progress" }.to_string(),
            finished,
            generations_done: nodes.iter().map(|n| n.generations_done() as u64).sum(),
            generations_total: None,
            // What the directory knows: when it was made, and when its last node summary
            // was written.
            created_unix_ms: std::fs::metadata(dir)
                .and_then(|m| m.created())
                .ok()
                .and_then(unix_ms),
            finished_unix_ms: finished
                .then(|| {
                    names
                        .iter()
                        .filter_map(|name| {
                            let summary = rundir::node_dir(dir, name).join(rundir::SUMMARY);
                            std::fs::metadata(summary).and_then(|m| m.modified()).ok()
                        })
                        .max()
                        .and_then(unix_ms)
                })
                .flatten(),
            error: None,
            nodes: names,
            cancellable: false,
            location: dir.display().to_string(),
        }
    }

    /// Looks at the directories every [`WATCH_INTERVAL`] and moves [`Source::changes`] when a
    /// log or summary changed. Must run inside a tokio runtime; ends with the source.
    pub fn watch_for_changes(self: &Arc<Self>) {
        let weak = Arc::downgrade(self);
        tokio::spawn(async move {
            let mut last = Vec::new();
            loop {
                let Some(source) = weak.upgrade() else { return };
                let dirs: Vec<PathBuf> = source.dirs.iter().map(|(_, d)| d.clone()).collect();
                drop(source);
                let now = tokio::task::spawn_blocking(move || {
                    dirs.iter().map(|d| signature(d)).collect::<Vec<u64>>()
                })
                .await
                .unwrap_or_default();
                if now != last {
                    last = now;
                    let Some(source) = weak.upgrade() else { return };
                    source.changes.send_modify(|n| *n += 1);
                }
                tokio::time::sleep(WATCH_INTERVAL).await;
            }
        });
    }
}

/// A file time as ms since the Unix epoch; `None` before it.
fn unix_ms(time: std::time::SystemTime) -> Option<i64> {
    let since = time.duration_since(std::time::UNIX_EPOCH).ok()?;
    i64::try_from(since.as_millis()).ok()
}

impl Source for RunDirSource {
    fn title(&self) -> String {
        "run directories".to_string()
    }

    fn jobs(&self) -> Vec<JobOverview> {
        self.dirs
            .iter()
            .map(|(id, dir)| self.overview(id, dir))
            .collect()
    }

    fn job(&self, id: &str) -> Result<JobOverview, SourceError> {
        Ok(self.overview(id, self.dir(id)?))
    }

    fn nodes(&self, id: &str) -> Result<Vec<NodeView>, SourceError> {
        let dir = self.dir(id)?;
        Ok(read_nodes(dir, &node_names(dir), &|_| None))
    }

    fn best_controller(&self, id: &str, node: &str) -> Result<Option<BestController>, SourceError> {
        read_best(self.dir(id)?, node, None)
    }

    fn cancel<'a>(&'a self, id: &'a str) -> BoxFuture<'a, Result<(), SourceError>> {
        Box::pin(async move {
            self.dir(id)?;
            Err(SourceError::Unsupported(format!(
                "{id} is a local run directory: stop its `hevo run` where it runs (Ctrl-C); it resumes from its checkpoints"
            )))
        })
    }

    fn changes(&self) -> watch::Receiver<u64> {
        self.changes.subscribe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_rundir::{FitnessRow, fitness_csv};

    fn write_log(out: &Path, node: &str, run: u32, generations: u32) {
        let dir = rundir::run_dir(&rundir::node_dir(out, node), run);
        std::fs::create_dir_all(&dir).unwrap();
        let rows: Vec<FitnessRow> = (0..generations)
            .map(|generation| FitnessRow {
                generation,
                best: 0.5,
                mean: 0.25,
                min: 0.0,
                max: 0.5,
                std: 0.1,
            })
            .collect();
        std::fs::write(dir.join(rundir::FITNESS_CSV), fitness_csv(&rows)).unwrap();
    }

    #[test]
    fn a_run_directory_in_progress_shows_its_logs() {
        let out = tempfile::tempdir().unwrap();
        write_log(out.path(), "follow_wall", 0, 3);
        write_log(out.path(), "follow_wall", 1, 2);
        std::fs::create_dir_all(out.path().join("not-a-node")).unwrap();
        let source = RunDirSource::new(&[out.path().to_path_buf()]).unwrap();
        let jobs = source.jobs();
        assert_eq!(jobs.len(), 1);
        assert_eq!(jobs[0].nodes, ["follow_wall"]);
        assert_eq!(jobs[0].generations_done, 5);
        assert!(!jobs[0].finished);
        assert_eq!(jobs[0].finished_unix_ms, None);
        let nodes = source.nodes(&jobs[0].id).unwrap();
        assert_eq!(nodes[0].runs.len(), 2);
        assert!(!nodes[0].finished());
        assert!(
            source
                .best_controller(&jobs[0].id, "follow_wall")
                .unwrap()
                .is_none()
        );
    }

    #[test]
    fn unknown_ids_and_missing_directories_are_named() {
        let out = tempfile::tempdir().unwrap();
        let source = RunDirSource::new(&[out.path().to_path_buf()]).unwrap();
        assert_eq!(
            source.job("nope").unwrap_err(),
            SourceError::NotFound("nope".into())
        );
        let missing = out.path().join("missing");
        let error = RunDirSource::new(std::slice::from_ref(&missing)).unwrap_err();
        assert!(error.to_string().contains(&missing.display().to_string()));
    }

    #[test]
    fn two_directories_of_one_name_get_two_ids() {
        let a = tempfile::tempdir().unwrap();
        let b = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(a.path().join("runs")).unwrap();
        std::fs::create_dir_all(b.path().join("runs")).unwrap();
        let source = RunDirSource::new(&[a.path().join("runs"), b.path().join("runs")]).unwrap();
        let ids: Vec<String> = source.jobs().into_iter().map(|j| j.id).collect();
        assert_eq!(ids, ["runs", "runs-2"]);
    }

    #[test]
    fn the_checked_in_runs_have_best_controllers() {
        let runs =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/runs-wide-turn-starts");
        let source = RunDirSource::new(&[runs]).unwrap();
        let job = &source.jobs()[0];
        assert!(job.finished, "{job:?}");
        assert!(job.finished_unix_ms.is_some(), "{job:?}");
        let best = source
            .best_controller(&job.id, "turn_left")
            .unwrap()
            .unwrap();
        assert_eq!(best.task.name(), "turn_left");
    }

    /// Runs a one-generation experiment on a copy of the phototaxis scenario file, which is no
    /// shipped scenario, through local mode as `hevo run` does; returns the output directory.
    fn run_scenario_file(dir: &Path) -> PathBuf {
        use hevo_engine::local::{local_dispatcher, run_local};
        use hevo_engine::runner::{Overrides, Progress, ProgressEvent, RunSettings};
        struct Quiet;
        impl Progress for Quiet {
            fn event(&self, _: &ProgressEvent) {}
        }
        std::fs::write(
            dir.join("beacon.toml"),
            include_str!("../../../scenarios/examples/phototaxis.toml"),
        )
        .unwrap();
        let experiment_path = dir.join("beacon-run.toml");
        let text = r#"
[experiment]
name = "beacon"
seed = 5

[evolution]
population = 4
elites = 1
post_evaluation_samples = 1

[[node]]
name = "beacon"
kind = "primitive"
inputs = ["ir", "light"]
hidden = 1
scenario = "beacon.toml"
samples = 1
cycles = 30
generations = 1
runs = 1
"#;
        let experiment = hevo_engine::Experiment::parse(text, &experiment_path).unwrap();
        let settings = RunSettings {
            out_dir: dir.join("out"),
            overrides: Overrides::default(),
            job: "beacon".into(),
        };
        run_local(local_dispatcher(1), 1, async |dispatcher| {
            hevo_engine::run_experiment(&experiment, &settings, dispatcher, &Quiet).await
        })
        .unwrap()
        .unwrap();
        settings.out_dir
    }

    #[test]
    fn a_local_run_of_a_scenario_file_replays_on_its_recorded_task() {
        let dir = tempfile::tempdir().unwrap();
        let out = run_scenario_file(dir.path());
        let source = RunDirSource::new(std::slice::from_ref(&out)).unwrap();
        let job = &source.jobs()[0];
        let best = source.best_controller(&job.id, "beacon").unwrap().unwrap();
        assert_eq!(best.task.name(), "phototaxis");
        assert!(TaskConfig::shipped(best.task.name()).is_none());
        let figures = crate::replay::replays("beacon", &best, 1).unwrap();
        assert!(!figures.is_empty());

        // Without the file, as run directories written before it were: the error names it.
        std::fs::remove_file(out.join("beacon").join(rundir::TASK)).unwrap();
        let error = source
            .best_controller(&job.id, "beacon")
            .unwrap_err()
            .to_string();
        assert!(error.contains("task.json"), "{error}");
    }

    #[test]
    fn a_node_with_an_unfinished_runs_extension_is_not_finished() {
        let runs =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/runs-wide-turn-starts");
        let source = RunDirSource::new(&[runs]).unwrap();
        let job = &source.jobs()[0];
        let node = source.nodes(&job.id).unwrap().remove(0);
        assert!(node.finished(), "{}", node.name);
        let n_runs = node.runs.len() as u32;
        let mut extended = node.clone();
        extended.runs.push(crate::RunView {
            run: n_runs,
            rows: Vec::new(),
            summary: None,
            archive: None,
            qd: Vec::new(),
        });
        assert!(!extended.finished());
        let mut planned_more = node.clone();
        planned_more.planned = Some((n_runs + 1, 10));
        assert!(!planned_more.finished());
    }
}
