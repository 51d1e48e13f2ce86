//! The chaos benchmark (opt-in: `cargo test --release -p hevo-tests --test service -- chaos::
//! --ignored --nocapture`, for `HEVO_CHAOS_SECONDS`, default 300): a master and three workers run a
//! stream of small jobs while, at random moments drawn from a fixed seed, workers are killed with
//! SIGKILL, stopped with SIGSTOP (and continued later) and restarted, and the master is killed with
//! SIGKILL and restarted on the same state directory and port. At the end every job must have
//! succeeded with results byte for byte equal to a local `hevo run` of the same experiment and
//! seed. It prints the faults injected, the jobs, how many were identical and anything lost.
//! Beside it, the submit storm: many submissions at once with the master killed among them.

use hevo_proto::v1;
use hevo_tests::service::{CLIENT_TOKEN, SMALL, WORKER_TOKEN, jobs, role_args, runtime};
use hevo_tests::{
    Master, Proc, Scratch, assert_same_results, binaries, fetch, hevo, lines_of, run_locally,
    start_master_listening, start_worker,
};
use std::collections::{HashMap, HashSet};
use std::net::TcpListener;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A small deterministic generator (xorshift), so a chaos run can be repeated exactly.
struct Chaos(u64);

impl Chaos {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

fn experiment(seed: u64) -> String {
    SMALL
        .replace("seed = 3", &format!("seed = {seed}"))
        .replace("generations = 2", "generations = 6")
        .replace("samples = 2\n", "samples = 6\n")
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

fn master(scratch: &Scratch, port: u16, restart: usize) -> Master {
    let mut args = role_args(scratch);
    args.extend(
        [
            "--state-dir",
            &scratch.join("state").to_string_lossy(),
            "--lease-seconds",
            "3",
        ]
        .map(str::to_string),
    );
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    // One port for every restart: the workers keep looking for the master there.
    start_master_listening(
        &format!("127.0.0.1:{port}"),
        &args,
        &scratch.join(&format!("master-{restart}.log")),
    )
}

fn worker(url: &str, scratch: &Scratch, idx: usize, generation: usize) -> Proc {
    start_worker(
        url,
        WORKER_TOKEN,
        &format!("chaos-{idx}-{generation}"),
        &[],
        &scratch.join(&format!("worker-{idx}-{generation}.log")),
    )
}

#[test]
#[ignore = "benchmark: run with -- chaos:: --ignored --nocapture in release"]
fn chaos_loses_nothing() {
    let seconds: u64 = std::env::var("HEVO_CHAOS_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(300);
    let scratch = Scratch::new("chaos");
    let port = free_port();
    let url = format!("http://127.0.0.1:{port}");
    let mut chaos = Chaos(0x9E37_79B9_7F4A_7C15);
    let mut restarts = 0;
    let mut the_master = Some(master(&scratch, port, restarts));
    let mut generation = 0;
    let mut workers: Vec<Option<Proc>> =
        (0..3).map(|i| Some(worker(&url, &scratch, i, 0))).collect();
    let mut stopped: Vec<bool> = vec![false; 3];
    let (mut kills, mut stops, mut master_kills) = (0, 0, 0);
    let mut jobs: Vec<(String, u64)> = Vec::new();
    let started = Instant::now();
    let mut next_submit = Instant::now();
    while started.elapsed() < Duration::from_secs(seconds) {
        if Instant::now() >= next_submit && the_master.is_some() {
            let seed = 100 + jobs.len() as u64;
            let file = scratch.join(&format!("job-{seed}.toml"));
            std::fs::write(&file, experiment(seed)).unwrap();
            let output = hevo(
                &["submit", "--master", &url, file.to_str().unwrap()],
                Some(CLIENT_TOKEN),
                Duration::from_secs(60),
            );
            if output.status.success() {
                let id = String::from_utf8_lossy(&output.stdout).trim().to_string();
                jobs.push((id, seed));
            }
            next_submit = Instant::now() + Duration::from_secs(2 + chaos.below(4));
        }
        std::thread::sleep(Duration::from_millis(200 + chaos.below(1800)));
        match chaos.below(10) {
            0..=3 => {
                let idx = chaos.below(3) as usize;
                if let Some(mut proc) = workers[idx].take() {
                    proc.kill();
                    kills += 1;
                }
                generation += 1;
                stopped[idx] = false;
                workers[idx] = Some(worker(&url, &scratch, idx, generation));
            }
            4..=6 => {
                let idx = chaos.below(3) as usize;
                if let Some(proc) = &workers[idx] {
                    if stopped[idx] {
                        proc.signal("CONT");
                    } else {
                        proc.signal("STOP");
                        stops += 1;
                    }
                    stopped[idx] = !stopped[idx];
                }
            }
            7 => {
                if let Some(mut master) = the_master.take() {
                    master.proc.kill();
                    master_kills += 1;
                }
                std::thread::sleep(Duration::from_millis(chaos.below(2000)));
                restarts += 1;
                the_master = Some(master(&scratch, port, restarts));
            }
            _ => {}
        }
    }
    // Let everything finish: continue the stopped workers, wait for each job.
    for (idx, proc) in workers.iter().enumerate() {
        if stopped[idx]
            && let Some(proc) = proc
        {
            proc.signal("CONT");
        }
    }
    let (identical, lost) = compare_with_local_runs(&url, &scratch, &jobs);
    println!(
        "chaos: {seconds} s, {} faults ({kills} worker kills, {stops} worker stops, {master_kills} master kills), {} jobs, {identical} identical to local runs, {} lost",
        kills + stops + master_kills,
        jobs.len(),
        lost.len()
    );
    assert!(lost.is_empty(), "{lost:#?}");
    assert!(!jobs.is_empty() && kills + master_kills > 0);
}

/// The submit storm (opt-in, like the chaos benchmark; `HEVO_STORM_SUBMITS` per storm, default
/// 30): three times, that many `hevo submit`s start at once and the master is killed with
/// SIGKILL in the middle of them and restarted on the same state directory and port. Each
/// submission sends the same request id on every retry, so one whose answer was lost is not
/// stored twice. At the end the master must hold exactly one job per acknowledged submission
/// (none duplicated, none lost), and every job's results must equal a local run's.
#[test]
#[ignore = "benchmark: run with -- chaos::submit_storms --ignored --nocapture"]
fn submit_storms_lose_nothing() {
    const N_STORMS: usize = 3;
    let per_storm: usize = std::env::var("HEVO_STORM_SUBMITS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let scratch = Scratch::new("submit-storm");
    let port = free_port();
    let url = format!("http://127.0.0.1:{port}");
    let mut chaos = Chaos(0x2545_F491_4F6C_DD1D);
    let mut the_master = master(&scratch, port, 0);
    let _workers: Vec<Proc> = (0..2).map(|i| worker(&url, &scratch, i, 0)).collect();
    let mut acknowledged: Vec<(String, u64)> = Vec::new();
    let mut refused = Vec::new();
    let mut retried = 0;
    for storm in 0..N_STORMS {
        let submits: Vec<(u64, Proc)> = (0..per_storm)
            .map(|i| {
                let seed = 1000 + (storm * per_storm + i) as u64;
                let file = scratch.join(&format!("job-{seed}.toml"));
                let text = experiment(seed)
                    .replace("name = \"small\"", &format!("name = \"storm-{seed}\""));
                std::fs::write(&file, text).unwrap();
                let proc = Proc::spawn(
                    "hevo submit",
                    Command::new(&binaries().hevo)
                        .args(["submit", "--master", &url, file.to_str().unwrap()])
                        .env_remove("HEVO_MASTER")
                        .env("HEVO_TOKEN", CLIENT_TOKEN)
                        .stdout(Stdio::piped())
                        .stderr(Stdio::piped()),
                );
                (seed, proc)
            })
            .collect();
        // The kill lands while submissions are arriving, being checked and being stored.
        std::thread::sleep(Duration::from_millis(100 + chaos.below(900)));
        the_master.proc.kill();
        std::thread::sleep(Duration::from_millis(chaos.below(1000)));
        the_master = master(&scratch, port, storm + 1);
        for (seed, mut proc) in submits {
            let stdout = lines_of(proc.child().stdout.take().expect("piped"));
            let stderr = lines_of(proc.child().stderr.take().expect("piped"));
            let status = proc
                .wait_timeout(Duration::from_secs(180))
                .unwrap_or_else(|| panic!("hevo submit of seed {seed} did not finish"));
            let id: String = stdout.iter().collect::<Vec<_>>().join("");
            let stderr: Vec<String> = stderr.iter().collect();
            // A submission the kill interrupted says so and sends the same request again.
            if stderr.iter().any(|line| line.contains("retrying")) {
                retried += 1;
            }
            if status.success() {
                acknowledged.push((id.trim().to_string(), seed));
            } else {
                refused.push(format!("{seed}: {}", stderr.join("; ")));
            }
        }
    }
    let listed = runtime().block_on(async {
        jobs(&url, CLIENT_TOKEN)
            .list_jobs(v1::ListJobsRequest {})
            .await
            .expect("the master lists its jobs")
            .into_inner()
            .jobs
    });
    let mut per_name: HashMap<String, usize> = HashMap::new();
    for job in &listed {
        *per_name.entry(job.experiment_name.clone()).or_default() += 1;
    }
    let duplicates: usize = per_name.values().map(|n| n - 1).sum();
    let listed_ids: HashSet<&str> = listed.iter().map(|j| j.job_id.as_str()).collect();
    let missing: Vec<&(String, u64)> = acknowledged
        .iter()
        .filter(|(id, _)| !listed_ids.contains(id.as_str()))
        .collect();
    let (identical, lost) = compare_with_local_runs(&url, &scratch, &acknowledged);
    println!(
        "submit storm: {N_STORMS} storms of {per_storm} submissions, the master killed in each: {retried} retried after a kill, {} acknowledged, {} refused, {} jobs stored, {duplicates} duplicates, {} acknowledged but missing, {identical} identical to local runs, {} lost",
        acknowledged.len(),
        refused.len(),
        listed.len(),
        missing.len(),
        lost.len()
    );
    assert_eq!(duplicates, 0, "{per_name:#?}");
    assert!(missing.is_empty(), "{missing:#?}");
    assert!(lost.is_empty(), "{lost:#?}");
    assert!(refused.is_empty(), "{refused:#?}");
    assert!(retried > 0, "no submission was interrupted by a kill");
}

/// Waits for each `(job, seed)` to finish, fetches it and compares its results with a local
/// `hevo run` of the same experiment file, byte for byte; returns how many were identical and
/// the jobs that did not succeed.
fn compare_with_local_runs(
    url: &str,
    scratch: &Scratch,
    jobs: &[(String, u64)],
) -> (usize, Vec<String>) {
    let mut identical = 0;
    let mut lost = Vec::new();
    for (job, seed) in jobs {
        let output = hevo(
            &["watch", "--master", url, job],
            Some(CLIENT_TOKEN),
            Duration::from_secs(600),
        );
        if !output.status.success() {
            lost.push(format!(
                "{job}: {}",
                String::from_utf8_lossy(&output.stderr)
            ));
            continue;
        }
        let fetched = scratch.join(&format!("fetched-{seed}"));
        fetch(url, CLIENT_TOKEN, job, &fetched, &[]);
        let local: PathBuf = scratch.join(&format!("local-{seed}"));
        let file = scratch.join(&format!("job-{seed}.toml"));
        run_locally(&file, &local, &["--threads", "1"]);
        assert_same_results(&local, &fetched, None);
        identical += 1;
    }
    (identical, lost)
}
