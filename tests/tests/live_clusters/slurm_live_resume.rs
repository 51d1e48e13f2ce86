//! A SLURM job of deploy/slurm/hevo.sbatch cancelled in the middle (`scancel`, what a user or a
//! preemption does: SIGTERM to every process of the job, SIGKILL after KillWait) and submitted
//! again with the same `--state-dir` continues from the checkpoints it left: the second
//! allocation's workers do less than the whole experiment, and the results are byte for byte
//! those of an uninterrupted local `hevo run`. The cluster is real (one node on loopback,
//! deploy/slurm/local-cluster.sh).
//!
//! Needs root and Debian's slurm-wlm and munge (`scripts/install-test-tools.sh slurm`);
//! without them the test fails under CI and is skipped, loudly, elsewhere.

use hevo_tests::slurm::{Cluster, ONE_NODE};
use hevo_tests::{
    Scratch, assert_same_results, binaries, cluster_turn, kill_processes_mentioning,
    processes_mentioning, repo_root, run_locally, work_done,
};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const TEST: &str = "live_clusters::slurm_live_resume";

/// The tiny experiment's generations, raised from 3 so that the job runs for long enough (tens
/// of seconds; a generation takes some 50 ms) to be cancelled in the middle, after its first
/// checkpoints. The evaluations: 2 runs x GENERATIONS x 10 genomes x 3 samples, plus each
/// run's 10 post-evaluation samples.
const GENERATIONS: u64 = 300;
const EVALUATIONS: u64 = 2 * GENERATIONS * 10 * 3 + 2 * 10;

/// Every checkpoint.json below `dir`.
fn checkpoints(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.file_name().is_some_and(|n| n == "checkpoint.json") {
                found.push(path);
            }
        }
    }
    found
}

/// The generations done, summed over the checkpoints below `dir`.
fn checkpointed_generations(dir: &Path) -> u64 {
    checkpoints(dir)
        .iter()
        .filter_map(|path| {
            let text = std::fs::read_to_string(path).ok()?;
            let value: serde_json::Value = serde_json::from_str(&text).ok()?;
            value.get("generation")?.as_u64()
        })
        .sum()
}

/// The evaluations the workers of the last allocation did, from their logs (srun truncates
/// each task's `--output` file when a job starts).
fn evaluations_in(state: &Path) -> u64 {
    (0..2)
        .map(|task| {
            let log = std::fs::read_to_string(state.join(format!("worker-{task}.log")))
                .unwrap_or_else(|e| panic!("worker-{task}.log: {e}"));
            work_done(&log)
                .unwrap_or_else(|| panic!("worker task {task} did not stop cleanly:\n{log}"))
                .1
        })
        .sum()
}

#[test]
fn a_cancelled_job_resubmitted_resumes_to_the_local_results() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("slurm-live-resume");
    let Some(cluster) = Cluster::start(TEST, &scratch, 2) else {
        return;
    };
    let experiment = repo_root().join("deploy/local/tiny.toml");
    let experiment = experiment.to_str().unwrap();
    let bin_dir = binaries().hevo.parent().unwrap().to_str().unwrap();
    let generations = GENERATIONS.to_string();

    let reference = scratch.join("local");
    run_locally(
        Path::new(experiment),
        &reference,
        &["--generations", &generations],
    );

    let work = scratch.join("job");
    let state = work.join("state");
    std::fs::create_dir_all(&work).unwrap();
    let script = repo_root().join("deploy/slurm/hevo.sbatch");
    let mut args: Vec<&str> = ONE_NODE.to_vec();
    args.extend([
        script.to_str().unwrap(),
        "--bin-dir",
        bin_dir,
        "--state-dir",
        "state",
        "--out",
        "results",
        "--generations",
        &generations,
        experiment,
    ]);

    // First allocation: cancelled once a checkpoint holds a finished generation.
    let first = cluster.sbatch(&work, &args);
    cluster.wait_until_running(&first, Duration::from_secs(60));
    let deadline = Instant::now() + Duration::from_secs(300);
    while checkpointed_generations(&state) == 0 {
        assert!(
            cluster.in_queue(&first),
            "job {first} ended before any checkpoint: {}",
            std::fs::read_to_string(work.join(format!("hevo-{first}.out"))).unwrap_or_default()
        );
        assert!(Instant::now() < deadline, "no checkpoint within 300 s");
        std::thread::sleep(Duration::from_millis(50));
    }
    cluster.run("scancel", &[&first]);
    let (status, _) = cluster.wait_until_done(&first, Duration::from_secs(120));
    let first_log =
        std::fs::read_to_string(work.join(format!("hevo-{first}.out"))).unwrap_or_default();
    let leftovers = processes_mentioning(work.to_str().unwrap());
    kill_processes_mentioning(work.to_str().unwrap());
    assert_eq!(status, "CANCELLED", "job {first}:\n{first_log}");
    assert!(
        leftovers.is_empty(),
        "processes outlived the cancelled job {first}:\n{}",
        leftovers.join("\n")
    );
    assert!(
        !work.join("results").exists(),
        "the cancelled job fetched results: it was not cancelled in the middle"
    );
    let kept = checkpointed_generations(&state);
    assert!(kept > 0, "the cancelled job left no checkpoint");
    eprintln!("job {first} cancelled with {kept} generations checkpointed");

    // Second allocation: the same state directory continues the same hevo job.
    let second = cluster.sbatch(&work, &args);
    let (status, exit) = cluster.wait_until_done(&second, Duration::from_secs(600));
    let second_log =
        std::fs::read_to_string(work.join(format!("hevo-{second}.out"))).unwrap_or_default();
    let leftovers = processes_mentioning(work.to_str().unwrap());
    kill_processes_mentioning(work.to_str().unwrap());
    assert_eq!(
        (status.as_str(), exit.as_str()),
        ("COMPLETED", "0:0"),
        "the resubmitted job {second} did not complete:\n{second_log}\n{}",
        cluster.daemon_logs()
    );
    assert!(
        leftovers.is_empty(),
        "processes outlived job {second}:\n{}",
        leftovers.join("\n")
    );
    assert!(
        second_log.contains("continuing job"),
        "the resubmission submitted anew instead of continuing:\n{second_log}"
    );
    let master_log = std::fs::read_to_string(state.join("master.log")).unwrap_or_default();
    assert!(
        master_log.contains("resuming job"),
        "the second master did not resume the job:\n{master_log}"
    );
    let redone = evaluations_in(&state);
    eprintln!("job {second}: {redone} of the experiment's {EVALUATIONS} evaluations");
    assert!(
        redone < EVALUATIONS,
        "the resubmitted job redid the whole experiment ({redone} evaluations): the checkpoints \
         were not used"
    );
    assert_same_results(&reference, &work.join("results"), None);
}
