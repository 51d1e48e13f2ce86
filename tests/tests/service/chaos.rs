//! The chaos benchmark (opt-in: `cargo test --release -p hevo-tests --test service -- chaos::
//! --ignored --nocapture`, for `HEVO_CHAOS_SECONDS`, default 300): a master and three workers run a
//! stream of small jobs while, at random moments drawn from a fixed seed, workers are killed with
//! SIGKILL, stopped with SIGSTOP (and continued later) and restarted, and the master is killed with
//! SIGKILL and restarted on the same state directory and port. At the end every job must have
//! succeeded with results byte for byte equal to a local `hevo run` of the same experiment and
//! seed. It prints the faults injected, the jobs, how many were identical and anything lost.

use hevo_tests::service::{CLIENT_TOKEN, SMALL, WORKER_TOKEN, role_args};
use hevo_tests::{
    Master, Proc, Scratch, assert_same_results, fetch, hevo, run_locally, start_master_listening,
    start_worker,
};
use std::net::TcpListener;
use std::path::PathBuf;
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
    let mut identical = 0;
    let mut lost = Vec::new();
    for (job, seed) in &jobs {
        let output = hevo(
            &["watch", "--master", &url, job],
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
        fetch(&url, CLIENT_TOKEN, job, &fetched, &[]);
        let local: PathBuf = scratch.join(&format!("local-{seed}"));
        let file = scratch.join(&format!("job-{seed}.toml"));
        run_locally(&file, &local, &["--threads", "1"]);
        assert_same_results(&local, &fetched, None);
        identical += 1;
    }
    println!(
        "chaos: {seconds} s, {} faults ({kills} worker kills, {stops} worker stops, {master_kills} master kills), {} jobs, {identical} identical to local runs, {} lost",
        kills + stops + master_kills,
        jobs.len(),
        lost.len()
    );
    assert!(lost.is_empty(), "{lost:#?}");
    assert!(!jobs.is_empty() && kills + master_kills > 0);
}
