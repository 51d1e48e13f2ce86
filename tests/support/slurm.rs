//! A real single-node SLURM cluster for the live SLURM tests
//! (`tests/tests/live_clusters/slurm_live_*.rs`): `deploy/slurm/local-cluster.sh` starts munged,
//! slurmctld and slurmd in a scratch directory and stops them when the [`Cluster`] is dropped; the
//! commands a user types (sbatch, squeue, scontrol, scancel) run against it through `SLURM_CONF`.
//!
//! The cluster needs root (slurmd starts jobs as their users) and Debian's slurm-wlm and munge,
//! which `scripts/install-test-tools.sh slurm` installs. Without either, [`Cluster::start`]
//! fails the test under CI and skips it loudly elsewhere ([`crate::tools::unavailable`]).

use crate::{Scratch, repo_root, tools};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The daemons and commands the cluster and the tests run.
const PROGRAMS: [&str; 8] = [
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "squeue",
    "scontrol",
    "scancel",
    "sinfo",
];

/// Whether this process runs as root: the owner of `/proc/self` is the process's user.
pub fn is_root() -> bool {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0)
}

/// A running one-node cluster; stopped (every daemon) when dropped.
#[derive(Debug)]
pub struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Cluster {
    /// Starts a cluster with `cpus` CPUs in `scratch`/slurm for `test`, or says why it cannot
    /// (see the module's documentation) and returns `None`.
    pub fn start(test: &str, scratch: &Scratch, cpus: u32) -> Option<Cluster> {
        if !is_root() {
            return tools::unavailable(
                test,
                "a SLURM cluster needs root (slurmd starts jobs as their users)",
                "Run the tests as root",
            );
        }
        for program in PROGRAMS {
            tools::require(program, test)?;
        }
        let dir = scratch.join("slurm");
        let output = Command::new("bash")
            .arg(script())
            .args(["up", dir.to_str().expect("a UTF-8 path")])
            .args(["--cpus", &cpus.to_string()])
            .stdin(Stdio::null())
            .output()
            .expect("cannot run local-cluster.sh");
        let cluster = Cluster {
            conf: dir.join("slurm.conf"),
            dir,
        };
        assert!(
            output.status.success(),
            "local-cluster.sh up failed: {}{}\n{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr),
            cluster.daemon_logs()
        );
        Some(cluster)
    }

    /// A command of SLURM's (`sbatch`, ...) talking to this cluster.
    pub fn command(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        command
            .env("SLURM_CONF", &self.conf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        command
    }

    /// Runs a SLURM command to its end; panics, with the daemons' logs, when it fails.
    pub fn run(&self, program: &str, args: &[&str]) -> String {
        let output = self
            .command(program)
            .args(args)
            .output()
            .unwrap_or_else(|e| panic!("cannot run {program}: {e}"));
        assert!(
            output.status.success(),
            "{program} {} failed: {}\n{}",
            args.join(" "),
            text(&output),
            self.daemon_logs()
        );
        String::from_utf8_lossy(&output.stdout).into_owned()
    }

    /// `sbatch --parsable` of `args` in `dir` (relative paths in the job are taken from there):
    /// the job's id.
    pub fn sbatch(&self, dir: &Path, args: &[&str]) -> String {
        let mut all = vec!["--parsable", "--chdir", dir.to_str().expect("a UTF-8 path")];
        all.extend_from_slice(args);
        let out = self.run("sbatch", &all);
        let id = out.trim().split(';').next().unwrap_or_default().to_string();
        assert!(
            !id.is_empty() && id.chars().all(|c| c.is_ascii_digit()),
            "sbatch printed no job id: {out:?}"
        );
        id
    }

    /// The job's fields as `scontrol show job --oneliner` gives them (`JobState`, `ExitCode`,
    /// ...); finished jobs stay there for five minutes (MinJobAge).
    pub fn job_field(&self, job: &str, field: &str) -> Option<String> {
        let out = self.run("scontrol", &["--oneliner", "show", "job", job]);
        out.split_whitespace()
            .find_map(|pair| pair.strip_prefix(&format!("{field}=")))
            .map(str::to_string)
    }

    /// Whether `squeue` lists the job in a state before its end (pending, running,
    /// completing, ...).
    pub fn in_queue(&self, job: &str) -> bool {
        const ACTIVE: [&str; 6] = [
            "PENDING",
            "CONFIGURING",
            "RUNNING",
            "COMPLETING",
            "SUSPENDED",
            "REQUEUED",
        ];
        let out = self.run(
            "squeue",
            &["--noheader", "--jobs", job, "--format", "%i %T"],
        );
        out.lines().any(|l| {
            let mut fields = l.split_whitespace();
            fields.next() == Some(job) && fields.next().is_some_and(|s| ACTIVE.contains(&s))
        })
    }

    /// Waits (up to `timeout`) until the job has left the queue, and returns its final state
    /// (`COMPLETED`, `CANCELLED`, `FAILED`, ...) and exit code (`0:0`).
    pub fn wait_until_done(&self, job: &str, timeout: Duration) -> (String, String) {
        let deadline = Instant::now() + timeout;
        while self.in_queue(job) {
            assert!(
                Instant::now() < deadline,
                "job {job} still queued after {timeout:?}: {}\n{}",
                self.run("scontrol", &["show", "job", job]),
                self.daemon_logs()
            );
            std::thread::sleep(Duration::from_millis(500));
        }
        let state = self.job_field(job, "JobState").unwrap_or_default();
        let exit = self.job_field(job, "ExitCode").unwrap_or_default();
        (state, exit)
    }

    /// Waits until the job runs.
    pub fn wait_until_running(&self, job: &str, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        loop {
            let state = self.job_field(job, "JobState").unwrap_or_default();
            if state == "RUNNING" {
                return;
            }
            assert!(
                state == "PENDING" && Instant::now() < deadline,
                "job {job} is {state}, not running:\n{}\n{}",
                self.run("scontrol", &["show", "job", job]),
                self.daemon_logs()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// The daemons' logs, for failure messages.
    pub fn daemon_logs(&self) -> String {
        ["slurmctld.log", "slurmd.log", "munged.log"]
            .iter()
            .map(|name| {
                let text = std::fs::read_to_string(self.dir.join("log").join(name))
                    .unwrap_or_else(|e| format!("({e})"));
                let tail: Vec<&str> = text.lines().rev().take(40).collect();
                let tail: Vec<&str> = tail.into_iter().rev().collect();
                format!("--- {name} (last lines)\n{}\n", tail.join("\n"))
            })
            .collect()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let status = Command::new("bash")
            .arg(script())
            .args(["down", self.dir.to_str().expect("a UTF-8 path")])
            .stdin(Stdio::null())
            .status();
        if !status.as_ref().is_ok_and(|s| s.success()) && !std::thread::panicking() {
            panic!("local-cluster.sh down failed ({status:?})");
        }
    }
}

/// deploy/slurm/local-cluster.sh.
fn script() -> PathBuf {
    repo_root().join("deploy/slurm/local-cluster.sh")
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

/// The sbatch options that fit the script's job into the one-node cluster: one node, two
/// single-core tasks (two workers; the script asks for one task per node, which these
/// override) and a time limit that ends a hung test.
pub const ONE_NODE: [&str; 4] = [
    "--nodes=1",
    "--ntasks-per-node=2",
    "--cpus-per-task=1",
    "--time=00:15:00",
];
