//! deploy/local/one-box.sh run for real: a `hevo serve` master and three `hevo-worker`
//! processes on loopback finish a small job and its results are fetched; and a SIGTERM in the
//! middle of a job stops every process the script started. This is the cluster path (gRPC,
//! token, leases, submit/watch/fetch) end to end, on one machine. The SLURM script runs too,
//! with the allocation's environment and a stand-in for srun.
//!
//! The binaries come from `cargo build -p hevo-cli -p hevo-worker` in the tests' profile
//! (see `hevo_tests::binaries`), or from the directory in `HEVO_TEST_BIN_DIR` when it is set.

use hevo_tests::{
    Proc, Scratch, binaries, cluster_turn, kill_processes_mentioning, processes_mentioning,
    repo_root, work_done,
};
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Evaluations deploy/local/tiny.toml needs: 2 runs x 3 generations x 10 genomes x 3 samples,
/// and each run's post-evaluation of 10 samples (follow_wall has one configuration).
const TINY_EVALUATIONS: u64 = 2 * 3 * 10 * 3 + 2 * 10;

/// Every worker log stopped cleanly, and together they account for every evaluation the tiny
/// job needed, each once.
fn assert_workers_did_the_job(logs: &[(String, String)]) {
    let mut total = 0;
    let mut working = 0;
    for (name, log) in logs {
        assert!(
            log.contains("connected to the master"),
            "{name} never connected:\n{log}"
        );
        let (batches, evaluations) =
            work_done(log).unwrap_or_else(|| panic!("{name} did not stop cleanly:\n{log}"));
        assert_eq!(batches == 0, evaluations == 0, "{name}:\n{log}");
        eprintln!("{name}: {batches} batches, {evaluations} evaluations");
        total += evaluations;
        working += usize::from(batches > 0);
    }
    assert_eq!(
        total, TINY_EVALUATIONS,
        "the workers' evaluations do not add up to the job's: {logs:#?}"
    );
    assert!(working >= 2, "the work did not spread: {logs:#?}");
}

/// The directory holding `hevo` and `hevo-worker` (the scripts take one directory for both).
fn bin_dir() -> &'static Path {
    let binaries = binaries();
    let dir = binaries.hevo.parent().expect("hevo is in a directory");
    assert_eq!(
        Some(dir),
        binaries.worker.parent(),
        "hevo and hevo-worker built into different directories"
    );
    dir
}

/// The script, running in its own process group so that a timeout can kill everything.
struct Script {
    proc: Proc,
    stderr: mpsc::Receiver<String>,
    log: Vec<String>,
    /// The scratch directory, which every process the script starts has on its command line.
    work: String,
}

impl Script {
    fn start(work: &Path, args: &[&str]) -> Script {
        use std::os::unix::process::CommandExt;
        let mut proc = Proc::spawn(
            "one-box.sh",
            Command::new("bash")
                .arg(repo_root().join("deploy/local/one-box.sh"))
                .args(["--work-dir", work.to_str().unwrap()])
                .args(args)
                .current_dir(repo_root())
                .env_remove("HEVO_TOKEN")
                .env_remove("HEVO_MASTER")
                .stdout(Stdio::inherit())
                .stderr(Stdio::piped())
                .process_group(0),
        );
        let (sender, stderr) = mpsc::channel();
        let pipe = proc.child().stderr.take().unwrap();
        std::thread::spawn(move || {
            for line in BufReader::new(pipe).lines().map_while(Result::ok) {
                eprintln!("| {line}");
                if sender.send(line).is_err() {
                    break;
                }
            }
        });
        Script {
            proc,
            stderr,
            log: Vec::new(),
            work: work.to_string_lossy().into_owned(),
        }
    }

    /// Waits until a stderr line contains `needle`.
    fn wait_for_line(&mut self, needle: &str, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(line) = self.stderr.recv_timeout(Duration::from_millis(200)) {
                let found = line.contains(needle);
                self.log.push(line);
                if found {
                    return;
                }
            }
            if let Some(status) = self.proc.child().try_wait().unwrap() {
                panic!(
                    "one-box.sh exited with {status} before printing {needle:?}:\n{}",
                    self.log.join("\n")
                );
            }
        }
        self.kill();
        panic!(
            "one-box.sh printed no {needle:?} within {timeout:?}:\n{}",
            self.log.join("\n")
        );
    }

    /// Waits for the script to end; kills its whole process group after `timeout`.
    fn wait(&mut self, timeout: Duration) -> ExitStatus {
        let deadline = Instant::now() + timeout;
        loop {
            while let Ok(line) = self.stderr.try_recv() {
                self.log.push(line);
            }
            if let Some(status) = self.proc.child().try_wait().unwrap() {
                return status;
            }
            if Instant::now() > deadline {
                self.kill();
                panic!(
                    "one-box.sh did not finish within {timeout:?}:\n{}",
                    self.log.join("\n")
                );
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Kills the script and, since it puts its children in process groups of their own,
    /// every process that has the scratch directory on its command line.
    fn kill(&mut self) {
        let _ = Command::new("kill")
            .args(["-KILL", &format!("-{}", self.proc.id())])
            .status();
        self.proc.kill();
        kill_processes_mentioning(&self.work);
    }
}

impl Drop for Script {
    fn drop(&mut self) {
        if self.proc.child().try_wait().ok().flatten().is_none() {
            self.kill();
        }
    }
}

#[test]
fn one_box_runs_a_small_job_on_three_workers_and_fetches_it() {
    let _turn = cluster_turn();
    let dir = Scratch::new("one-box-job");
    let work = dir.join("work");
    let results = dir.join("results");
    let mut script = Script::start(
        &work,
        &[
            "--workers",
            "3",
            "--bin-dir",
            bin_dir().to_str().unwrap(),
            "--out",
            results.to_str().unwrap(),
            "deploy/local/tiny.toml",
        ],
    );
    let status = script.wait(Duration::from_secs(180));
    let leftovers = processes_mentioning(work.to_str().unwrap());
    kill_processes_mentioning(work.to_str().unwrap());
    assert!(
        status.success(),
        "one-box.sh failed with {status}:\n{}",
        script.log.join("\n")
    );
    assert!(
        leftovers.is_empty(),
        "processes outlived one-box.sh:\n{}",
        leftovers.join("\n")
    );

    // deploy/local/tiny.toml: one node, follow_wall, 2 runs of 3 generations.
    for run in 0..2 {
        let run_dir = results.join("follow_wall").join(format!("run-{run}"));
        for file in ["fitness.csv", "best.json", "summary.json"] {
            let path = run_dir.join(file);
            let text = std::fs::read_to_string(&path)
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(!text.trim().is_empty(), "{} is empty", path.display());
            if file.ends_with(".json") {
                serde_json::from_str::<serde_json::Value>(&text)
                    .unwrap_or_else(|e| panic!("{}: not JSON: {e}", path.display()));
            } else {
                assert!(
                    text.lines().count() >= 2,
                    "{} has no generation rows:\n{text}",
                    path.display()
                );
            }
        }
    }
    // The three workers did the job's evaluations between them and were stopped by the script.
    let logs: Vec<(String, String)> = (1..=3)
        .map(|worker| {
            let log = work.join(format!("worker-{worker}.log"));
            let text =
                std::fs::read_to_string(&log).unwrap_or_else(|e| panic!("{}: {e}", log.display()));
            (format!("worker-{worker}"), text)
        })
        .collect();
    assert_workers_did_the_job(&logs);
}

#[test]
fn one_box_stops_every_process_on_sigterm() {
    let _turn = cluster_turn();
    let dir = Scratch::new("one-box-stop");
    let work = dir.join("work");
    // Long enough that the job is still running when the signal comes.
    let mut script = Script::start(
        &work,
        &[
            "--workers",
            "3",
            "--bin-dir",
            bin_dir().to_str().unwrap(),
            "--out",
            dir.join("results").to_str().unwrap(),
            "--generations",
            "100000",
            "--grace",
            "60",
            "deploy/local/tiny.toml",
        ],
    );
    script.wait_for_line("submitted", Duration::from_secs(60));
    std::thread::sleep(Duration::from_secs(2));
    let running = processes_mentioning(work.to_str().unwrap());
    assert!(
        running.len() >= 4,
        "expected a master and 3 workers running:\n{}",
        running.join("\n")
    );
    script.proc.signal("TERM");
    let signalled = Instant::now();
    let status = script.wait(Duration::from_secs(120));
    let stopping = signalled.elapsed();
    let leftovers = processes_mentioning(work.to_str().unwrap());
    kill_processes_mentioning(work.to_str().unwrap());
    assert!(
        leftovers.is_empty(),
        "processes outlived one-box.sh:\n{}",
        leftovers.join("\n")
    );
    assert_eq!(
        status.code(),
        Some(143),
        "one-box.sh should exit 143 after SIGTERM:\n{}",
        script.log.join("\n")
    );
    // Workers hand back their small batches at once; the grace period (60 s) is a bound,
    // not a wait.
    assert!(
        stopping < Duration::from_secs(45),
        "stopping took {stopping:?}:\n{}",
        script.log.join("\n")
    );
    assert!(
        script.log.iter().any(|l| l.contains("stopping 3 workers")),
        "the script did not stop the workers:\n{}",
        script.log.join("\n")
    );
}

/// A stand-in for `srun` (no SLURM here): runs `--ntasks` copies of the command on this machine,
/// each with its `--output` file, and passes SIGTERM on to them, as srun does.
const FAKE_SRUN: &str = r#"#!/usr/bin/env bash
# Test stand-in for srun: N local copies of the command, SIGTERM forwarded.
set -euo pipefail
ntasks=1
output=/dev/stderr
while (($# > 0)); do
    case "$1" in
        --ntasks=*) ntasks=${1#*=} ;;
        --output=*) output=${1#*=} ;;
        -*) ;;
        *) break ;;
    esac
    shift
done
pids=()
for ((task = 0; task < ntasks; task++)); do
    SLURM_PROCID=$task "$@" >"${output//%t/$task}" 2>&1 &
    pids+=("$!")
done
trap 'kill -TERM "${pids[@]}" 2>/dev/null || true' TERM INT
status=0
for pid in "${pids[@]}"; do
    wait "$pid" || status=$?
done
for pid in "${pids[@]}"; do
    wait "$pid" 2>/dev/null || true
done
exit "$status"
"#;

/// deploy/slurm/hevo.sbatch with the allocation's environment and a stand-in srun: the master
/// starts, writes its address where the workers find it, two workers run the tiny job, the
/// results are fetched, and nothing is left running.
#[test]
fn slurm_script_runs_a_job_with_a_stand_in_srun() {
    use std::os::unix::fs::PermissionsExt;
    let _turn = cluster_turn();
    let dir = Scratch::new("one-box-slurm");
    let shims = dir.join("bin");
    std::fs::create_dir_all(&shims).unwrap();
    let srun = shims.join("srun");
    std::fs::write(&srun, FAKE_SRUN).unwrap();
    std::fs::set_permissions(&srun, std::fs::Permissions::from_mode(0o755)).unwrap();
    let path = format!(
        "{}:{}:{}",
        shims.display(),
        bin_dir().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let experiment = repo_root().join("deploy/local/tiny.toml");
    let mut sbatch = Proc::spawn(
        "hevo.sbatch",
        Command::new("bash")
            .arg(repo_root().join("deploy/slurm/hevo.sbatch"))
            .args(["--state-dir", "state", "--out", "results"])
            .arg(&experiment)
            .current_dir(dir.path())
            .env("PATH", path)
            .env("SLURM_JOB_ID", "4242")
            .env("SLURM_NTASKS", "2")
            .env("SLURM_CPUS_PER_TASK", "1")
            // The master's node, as the workers dial it: loopback here.
            .env("SLURMD_NODENAME", "127.0.0.1")
            .env_remove("HEVO_TOKEN")
            .env_remove("HEVO_MASTER"),
    );
    let Some(status) = sbatch.wait_timeout(Duration::from_secs(180)) else {
        sbatch.kill();
        kill_processes_mentioning(dir.path().to_str().unwrap());
        panic!("hevo.sbatch did not finish within 180 s");
    };
    let leftovers = processes_mentioning(dir.path().to_str().unwrap());
    kill_processes_mentioning(dir.path().to_str().unwrap());
    let logs: String = ["master.log", "worker-0.log", "worker-1.log"]
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(dir.join("state").join(f)).unwrap_or_default();
            format!("--- {f}\n{text}")
        })
        .collect();
    assert!(
        status.success(),
        "hevo.sbatch failed with {status}:\n{logs}"
    );
    assert!(
        leftovers.is_empty(),
        "processes outlived hevo.sbatch:\n{}",
        leftovers.join("\n")
    );
    let url = std::fs::read_to_string(dir.join("state/master.url")).unwrap();
    assert!(
        url.trim().starts_with("http://127.0.0.1:"),
        "master.url is {url:?}"
    );
    let job = std::fs::read_to_string(dir.join("state/job-id")).unwrap();
    assert!(!job.trim().is_empty(), "no job id was recorded");
    let worker_logs: Vec<(String, String)> = ["worker-0.log", "worker-1.log"]
        .iter()
        .map(|worker| {
            let text = std::fs::read_to_string(dir.join("state").join(worker))
                .unwrap_or_else(|e| panic!("{worker}: {e}\n{logs}"));
            (worker.to_string(), text)
        })
        .collect();
    assert_workers_did_the_job(&worker_logs);
    for run in 0..2 {
        let run_dir = dir.join("results/follow_wall").join(format!("run-{run}"));
        for file in ["fitness.csv", "best.json", "summary.json"] {
            assert!(
                run_dir.join(file).is_file(),
                "{} is missing",
                run_dir.join(file).display()
            );
        }
    }
}
