//! The distributed evaluation service end to end, with the real `hevo` and `hevo-worker`
//! binaries on 127.0.0.1: a job on a master and two workers gives byte for byte the results of
//! `hevo run` with the same seed; so does a job during which a worker is killed, and one whose
//! master is killed with SIGKILL and restarted on the same state directory; requests without
//! the token are refused; a broken experiment file is refused naming the key; TLS with a
//! private CA works; jobs can be cancelled; a job on a scenario file of one's own runs on a
//! worker that has no file and gives the local results; so does a job of every search
//! algorithm. The tests that evolve share one local
//! reference run and take turns with every other cluster test of the binary
//! ([`hevo_tests::cluster_turn`]), so timings stay realistic on a two-core machine.
//!
//! `overhead_benchmark` (ignored; `cargo test --release -p hevo-tests --test service --
//! distributed::overhead_benchmark --ignored --nocapture`) compares evaluations per second of a master with two single-thread
//! workers against local mode on two threads.

use hevo_tests::service::{CLIENT_TOKEN, WORKER_TOKEN, role_args};
use hevo_tests::{
    Master, Proc, Scratch, assert_same_results, binaries, cluster_turn, fetch, hevo, hevo_ok,
    http_get, lines_of, run_locally, start_master, start_worker, wait_for_line,
};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

const SEED: &str = "11";
const LONG: Duration = Duration::from_secs(180);

/// Three nodes: two small primitives and an arbitrator choosing between them, so batches carry
/// fixed sub-controllers and every arbitrator genome scores differently (a genome given the
/// wrong results would show). The arbitrator's samples run their full 1000 cycles (collisions
/// do not end them), so a generation takes long enough to kill things in the middle of it.
const EXPERIMENT: &str = include_str!("../../fixtures/three_nodes.toml");

fn write_experiment(dir: &Path) -> PathBuf {
    let path = dir.join("tree.toml");
    std::fs::write(&path, EXPERIMENT).unwrap();
    path
}

/// `hevo run` of the experiment with the test seed on two threads: what every distributed run
/// must reproduce. Computed once per test process.
fn reference() -> &'static Path {
    static REFERENCE: OnceLock<PathBuf> = OnceLock::new();
    REFERENCE.get_or_init(|| {
        // Kept for the whole process: every test compares against it.
        let scratch = Box::leak(Box::new(Scratch::new("reference")));
        let file = write_experiment(scratch.path());
        let out = scratch.join("local");
        run_locally(&file, &out, LOCAL);
        out
    })
}

/// The arguments of a local `hevo run` with the test seed on two threads.
const LOCAL: &[&str] = &["--threads", "2", "--seed", SEED];

fn submit(master: &Master, file: &Path, extra: &[&str]) -> String {
    let mut args = vec![
        "submit",
        "--master",
        &master.url,
        file.to_str().unwrap(),
        "--seed",
        SEED,
    ];
    args.extend_from_slice(extra);
    let output = hevo_ok(&args, Some(CLIENT_TOKEN), Duration::from_secs(30));
    let job = String::from_utf8(output.stdout).unwrap().trim().to_string();
    assert!(
        job.starts_with("job-") && !job.contains(char::is_whitespace),
        "submit printed {job:?}"
    );
    job
}

/// `hevo watch` in the background, its stdout lines on a channel.
fn spawn_watch(
    master: &Master,
    job: &str,
    extra: &[&str],
) -> (Proc, std::sync::mpsc::Receiver<String>) {
    let mut proc = Proc::spawn(
        "hevo watch",
        Command::new(&binaries().hevo)
            .args(["watch", "--master", &master.url, job])
            .args(extra)
            .env("HEVO_TOKEN", CLIENT_TOKEN)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit()),
    );
    let lines = lines_of(proc.child().stdout.take().unwrap());
    (proc, lines)
}

fn watch_to_end(master: &Master, job: &str, extra: &[&str]) -> String {
    watch_until_done(master, job, extra, 28)
}

/// `hevo watch` until the job succeeds, having run `generations` generations in all.
fn watch_until_done(master: &Master, job: &str, extra: &[&str], generations: u32) -> String {
    let mut args = vec!["watch", "--master", &master.url, job];
    args.extend_from_slice(extra);
    let output = hevo_ok(&args, Some(CLIENT_TOKEN), LONG);
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        stdout.trim_end().ends_with(&format!(
            "succeeded ({generations}/{generations} generations)"
        )),
        "{stdout}"
    );
    stdout
}

/// Fetches the job's results into the scratch directory's `fetched/` and compares them with
/// `expected`, byte for byte.
fn assert_fetched_same_as(master: &Master, job: &str, scratch: &Scratch, expected: &Path) {
    fetch(
        &master.url,
        CLIENT_TOKEN,
        job,
        &scratch.join("fetched"),
        &[],
    );
    assert_same_results(expected, &scratch.join("fetched"), None);
}

/// The master's metrics page (it must have been started with `--metrics-listen`).
fn metrics_text(master: &Master) -> String {
    let address = master
        .metrics
        .as_deref()
        .expect("the master serves metrics");
    let response = http_get(address, "/metrics");
    assert!(response.starts_with("HTTP/1.1 200"), "{response}");
    response
        .split_once("\r\n\r\n")
        .map(|(_, body)| body.to_string())
        .unwrap_or_default()
}

fn metric(text: &str, name: &str) -> f64 {
    text.lines()
        .find_map(|line| {
            line.strip_prefix(name)
                .and_then(|rest| rest.strip_prefix(' '))
        })
        .and_then(|value| value.trim().parse().ok())
        .unwrap_or_else(|| panic!("no metric {name} in:\n{text}"))
}

/// Two single-thread workers named PREFIX0 and PREFIX1, their logs in the scratch directory.
fn two_workers(master: &Master, scratch: &Scratch, prefix: &str) -> Vec<Proc> {
    (0..2)
        .map(|i| {
            let name = format!("{prefix}{i}");
            start_worker(
                &master.url,
                WORKER_TOKEN,
                &name,
                &[],
                &scratch.join(&format!("{name}.log")),
            )
        })
        .collect()
}

fn master_with(scratch: &Scratch, state: &str, extra: &[&str], log: &str) -> Master {
    let mut args: Vec<String> = vec![
        "--state-dir".into(),
        scratch.join(state).to_string_lossy().into_owned(),
    ];
    args.extend(role_args(scratch));
    args.extend(extra.iter().map(|s| s.to_string()));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    start_master(&args, &scratch.join(log))
}

#[test]
fn two_workers_give_exactly_the_local_results() {
    let expected = reference();
    let _turn = cluster_turn();
    let started = Instant::now();
    let scratch = Scratch::new("two-workers");
    let file = write_experiment(scratch.path());
    let master = master_with(
        &scratch,
        "state",
        &["--metrics-listen", "127.0.0.1:0"],
        "master.log",
    );
    let mut workers = two_workers(&master, &scratch, "w");
    let job = submit(&master, &file, &[]);
    watch_to_end(&master, &job, &[]);
    assert_fetched_same_as(&master, &job, &scratch, expected);

    let metrics = metrics_text(&master);
    assert_eq!(metric(&metrics, "hevo_workers_connected"), 2.0, "{metrics}");
    assert_eq!(
        metric(&metrics, "hevo_jobs{state=\"succeeded\"}"),
        1.0,
        "{metrics}"
    );
    assert!(
        metric(&metrics, "hevo_evaluations_total") > 3000.0,
        "{metrics}"
    );
    assert_eq!(metric(&metrics, "hevo_batches_queued"), 0.0);

    let listing = hevo(
        &["jobs", "--master", &master.url],
        Some(CLIENT_TOKEN),
        Duration::from_secs(10),
    );
    let listing = String::from_utf8_lossy(&listing.stdout);
    assert!(
        listing
            .lines()
            .any(|l| l.starts_with(&job) && l.contains("succeeded") && l.contains("28/28")),
        "{listing}"
    );

    // SIGTERM: an idle worker stops at once, with status 0.
    for worker in &mut workers {
        worker.signal("TERM");
        let status = worker
            .wait_timeout(Duration::from_secs(10))
            .expect("the worker did not stop on SIGTERM");
        assert!(status.success(), "{}: {status}", worker.name);
    }
    eprintln!("two workers: {:.1} s", started.elapsed().as_secs_f64());
}

/// A task of one's own: the example T-maze renamed, with a pit across its stem's top cell
/// that ends a sample, written beside the experiment and named by the node as `scenario`.
const OWN_SCENARIO_EXPERIMENT: &str = r#"
[experiment]
name = "own"

[evolution]
population = 8
elites = 2
post_evaluation_samples = 4

[[node]]
name = "pit_maze"
kind = "primitive"
inputs = ["ir", "light"]
hidden = 3
scenario = "pit_maze.toml"
samples = 4
generations = 3
runs = 1
"#;

#[test]
fn a_job_on_a_scenario_file_of_ones_own_gives_the_local_results() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("own-scenario");
    let own = include_str!("../../../scenarios/examples/t_maze.toml")
        .replacen("name = \"t_maze\"", "name = \"pit_maze\"", 1)
        .replacen("[end]\n", "[end]\nforbidden = \"in pit\"\n", 1)
        + "\n[regions]\npit = { rect = [-0.15, 0.75, 0.15, 1.05] }\n";
    let dir = scratch.join("job");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("pit_maze.toml"), own).unwrap();
    let file = dir.join("own.toml");
    std::fs::write(&file, OWN_SCENARIO_EXPERIMENT).unwrap();
    let local = scratch.join("local");
    run_locally(&file, &local, LOCAL);

    // The worker runs elsewhere, with no file: the job carries the scenario's text.
    let master = master_with(&scratch, "state", &[], "master.log");
    let _worker = start_worker(
        &master.url,
        WORKER_TOKEN,
        "own0",
        &[],
        &scratch.join("own0.log"),
    );
    let job = submit(&master, &file, &[]);
    std::fs::remove_file(dir.join("pit_maze.toml")).unwrap();
    watch_until_done(&master, &job, &[], 3);
    assert_fetched_same_as(&master, &job, &scratch, &local);
    let summary = std::fs::read_to_string(scratch.join("fetched/pit_maze/summary.json")).unwrap();
    assert!(summary.contains("\"task\": \"pit_maze\""), "{summary}");
}

/// One small node per search algorithm besides the GA, each named by its `[node.evolution]`:
/// a worker evaluates genomes and never knows which algorithm asked for them.
fn algorithms_experiment() -> String {
    let nodes = [
        ("by_cmaes", r#"{ algorithm = "cmaes" }"#),
        (
            "by_sep_cmaes_ipop",
            r#"{ algorithm = "cmaes", cmaes_variant = "separable", restarts = 2 }"#,
        ),
        (
            "by_novelty",
            r#"{ algorithm = "novelty", elites = 2, novelty_neighbours = 3 }"#,
        ),
        (
            "by_map_elites",
            r#"{ algorithm = "map_elites", map_elites_bins = [3, 3], map_elites_ranges = [[-2.0, 2.0], [-2.0, 2.0]] }"#,
        ),
    ];
    let mut text = String::from(
        "[experiment]\nname = \"algorithms\"\n\n[evolution]\npopulation = 8\npost_evaluation_samples = 4\n",
    );
    for (name, evolution) in nodes {
        text.push_str(&format!(
            "\n[[node]]\nname = \"{name}\"\nkind = \"primitive\"\ninputs = [\"ir\"]\nhidden = 3\n\
             task = \"exit_room\"\nsamples = 4\ngenerations = 3\nruns = 1\nevolution = {evolution}\n"
        ));
    }
    text
}

#[test]
fn every_algorithm_on_two_workers_gives_the_local_results() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("algorithms");
    let file = scratch.join("algorithms.toml");
    std::fs::write(&file, algorithms_experiment()).unwrap();
    let local = scratch.join("local");
    run_locally(&file, &local, LOCAL);
    assert!(
        local.join("by_map_elites/run-0/archive.json").is_file(),
        "MAP-Elites keeps its archive"
    );

    let master = master_with(&scratch, "state", &[], "master.log");
    let _workers = two_workers(&master, &scratch, "a");
    let job = submit(&master, &file, &[]);
    watch_until_done(&master, &job, &[], 12);
    assert_fetched_same_as(&master, &job, &scratch, &local);
}

/// A `name=value` field of a log line.
fn log_field(line: &str, name: &str) -> Option<u64> {
    let start = line.find(&format!(" {name}="))? + name.len() + 2;
    line[start..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?
        .parse()
        .ok()
}

/// The (batch id, lease id) a worker's log shows it evaluating: the last `leased a batch` line
/// (a debug line) when no `batch done` or `result not needed` line for that batch follows it.
fn batch_in_hand(log: &str) -> Option<(u64, u64)> {
    let mut held = None;
    for line in log.lines() {
        if line.contains("leased a batch") {
            held = log_field(line, "batch_id").zip(log_field(line, "lease_id"));
        } else if (line.contains("batch done") || line.contains("result not needed"))
            && log_field(line, "batch_id") == held.map(|(batch, _)| batch)
        {
            held = None;
        }
    }
    held
}

/// The text of field `name` in a log line, without the quotes the log puts around string
/// values (`worker="doomed@127.0.0.1:5000"`) and does not put around displayed ones
/// (`worker=doomed@127.0.0.1:5000`).
fn log_text_field<'l>(line: &'l str, name: &str) -> Option<&'l str> {
    let start = line.find(&format!(" {name}="))? + name.len() + 2;
    let rest = &line[start..];
    match rest.strip_prefix('"') {
        Some(quoted) => quoted.split('"').next(),
        None => rest.split_whitespace().next(),
    }
}

/// Whether the master's log shows it taking back `worker`'s lease of a batch: revoked when the
/// worker's connection closed (`worker gone`, naming the lease) or run out (`lease expired`,
/// naming the batch).
fn lease_taken_back(master_log: &str, worker: &str, (batch, lease): (u64, u64)) -> bool {
    // The master names a lease's holder `<worker>@<peer>`.
    let held_by = |line: &str| {
        log_text_field(line, "worker")
            .and_then(|holder| holder.strip_prefix(worker))
            .is_some_and(|rest| rest.starts_with('@'))
    };
    master_log.lines().any(|line| {
        held_by(line)
            && ((line.contains("worker gone") && log_field(line, "lease_id") == Some(lease))
                || (line.contains("lease expired") && log_field(line, "batch_id") == Some(batch)))
    })
}

#[test]
fn the_master_log_names_the_holder_of_a_lease_taken_back() {
    let log = "\
2026-12-01T23:28:53.664593Z  WARN hevo_engine::dispatch: worker gone; its batch re-queued lease_id=184 worker=\"doomed@127.0.0.1:58458\"
2026-12-01T23:28:55.000000Z  WARN hevo_engine::dispatch: lease expired; batch re-queued lease_id=190 batch_id=185 worker=survivor@127.0.0.1:58460";
    assert!(lease_taken_back(log, "doomed", (179, 184)));
    assert!(lease_taken_back(log, "survivor", (185, 190)));
    // Another lease, another batch or another worker is not the one taken back.
    assert!(!lease_taken_back(log, "doomed", (179, 183)));
    assert!(!lease_taken_back(log, "survivor", (186, 190)));
    assert!(!lease_taken_back(log, "survivor", (179, 184)));
    assert!(!lease_taken_back(log, "doom", (179, 184)));
}

#[test]
fn a_worker_killed_mid_job_changes_nothing_but_time() {
    let expected = reference();
    let _turn = cluster_turn();
    let started = Instant::now();
    let scratch = Scratch::new("killed-worker");
    let file = write_experiment(scratch.path());
    // Short leases, so the dead worker's batch is given to the other one soon.
    let master = master_with(
        &scratch,
        "state",
        &["--lease-seconds", "2", "--metrics-listen", "127.0.0.1:0"],
        "master.log",
    );
    // The doomed worker logs each batch it leases (at debug level), so that it can be killed
    // while it holds one.
    let doomed_log = scratch.join("doomed.log");
    let mut doomed = Proc::spawn(
        "doomed",
        Command::new(&binaries().worker)
            .args([
                "--master",
                &master.url,
                "--threads",
                "1",
                "--name",
                "doomed",
            ])
            .env("HEVO_TOKEN", WORKER_TOKEN)
            .env("RUST_LOG", "info,hevo_worker=debug")
            .env_remove("HEVO_MASTER")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&doomed_log).unwrap()),
    );
    let _survivor = start_worker(
        &master.url,
        WORKER_TOKEN,
        "survivor",
        &[],
        &scratch.join("survivor.log"),
    );
    let job = submit(&master, &file, &[]);
    let (mut watch, lines) = spawn_watch(&master, &job, &[]);
    wait_for_line(&lines, LONG, |l| l.contains("top run 0 generation 2/"))
        .unwrap_or_else(|seen| panic!("no progress: {seen:#?}"));
    // Into the next generation's batches: as soon as the doomed worker takes a new batch, stop
    // it (SIGSTOP, so it cannot finish the batch while we look), check that it still holds
    // the batch, and SIGKILL it: no goodbye, no hand-back.
    let read_log = || std::fs::read_to_string(&doomed_log).unwrap_or_default();
    let before = batch_in_hand(&read_log());
    let killed_batch = loop {
        assert!(
            started.elapsed() < LONG,
            "the doomed worker took no new batch:\n{}",
            read_log()
        );
        match batch_in_hand(&read_log()) {
            Some(batch) if Some(batch) != before => {
                doomed.signal("STOP");
                if batch_in_hand(&read_log()) == Some(batch) {
                    doomed.kill();
                    break batch;
                }
                doomed.signal("CONT");
            }
            _ => std::thread::sleep(Duration::from_millis(5)),
        }
    };
    let status = watch.wait_timeout(LONG).expect("the job did not finish");
    assert!(status.success());

    // The fault happened: the lease the worker held when it died was taken back (its
    // connection closed, or the lease ran out) and its batch evaluated again elsewhere.
    let master_log = std::fs::read_to_string(scratch.join("master.log")).unwrap();
    let (batch, lease) = killed_batch;
    assert!(
        lease_taken_back(&master_log, "doomed", killed_batch),
        "the master did not take back lease {lease} (batch {batch}) of the killed worker:\n{master_log}"
    );
    let metrics = metrics_text(&master);
    let expiries = metric(&metrics, "hevo_lease_expiries_total");
    let revocations = metric(&metrics, "hevo_lease_revocations_total");
    assert!(
        expiries + revocations >= 1.0,
        "no lease expiry or revocation counted:\n{metrics}"
    );

    assert_fetched_same_as(&master, &job, &scratch, expected);
    eprintln!(
        "killed worker: {:.1} s, lease expiries {expiries}, revocations {revocations}",
        started.elapsed().as_secs_f64(),
    );
}

#[test]
fn a_master_killed_and_restarted_resumes_to_the_same_results() {
    use std::os::unix::process::ExitStatusExt;
    let expected = reference();
    let _turn = cluster_turn();
    let started = Instant::now();
    let scratch = Scratch::new("killed-master");
    let file = write_experiment(scratch.path());
    let job;
    let first_pid;
    {
        let mut master = master_with(&scratch, "state", &["--lease-seconds", "2"], "master-1.log");
        first_pid = master.proc.id();
        let _workers = two_workers(&master, &scratch, "a");
        job = submit(&master, &file, &[]);
        let (_watch, lines) = spawn_watch(&master, &job, &[]);
        wait_for_line(&lines, LONG, |l| l.contains("top run 0 generation 3/"))
            .unwrap_or_else(|seen| panic!("no progress: {seen:#?}"));
        std::thread::sleep(Duration::from_millis(40));
        // kill -9 in the middle of a generation; its workers and watcher go with the guards.
        master.proc.child().kill().unwrap();
        let status = master.proc.child().wait().unwrap();
        assert_eq!(
            status.signal(),
            Some(9),
            "the master died of the SIGKILL, not before it: {status}"
        );
    }
    let log = std::fs::read_to_string(scratch.join("master-1.log")).unwrap();
    assert!(
        log.contains("job started") && !log.contains("job succeeded"),
        "the first master did not die in the middle of the job:\n{log}"
    );
    // A new master on the same state directory (on another port), new workers.
    let master = master_with(&scratch, "state", &["--lease-seconds", "2"], "master-2.log");
    assert_ne!(master.proc.id(), first_pid, "a new master process");
    let _workers = two_workers(&master, &scratch, "b");
    watch_to_end(&master, &job, &[]);
    let log = std::fs::read_to_string(scratch.join("master-2.log")).unwrap();
    assert!(
        log.contains("resuming job"),
        "the job was not resumed:\n{log}"
    );
    // From the checkpoint the first master wrote, not from the start: generation 3 had been
    // reported, so at least 2 generations of top's run 0 were checkpointed.
    let resumed_at: u32 = log
        .lines()
        .find_map(|line| {
            let rest = &line[line.find("top run 0: resuming at generation ")?..];
            rest.split_whitespace().nth(6)?.parse().ok()
        })
        .unwrap_or_else(|| panic!("top run 0 did not resume from a checkpoint:\n{log}"));
    assert!(
        (2..8).contains(&resumed_at),
        "resumed at generation {resumed_at}"
    );
    assert_fetched_same_as(&master, &job, &scratch, expected);
    eprintln!("killed master: {:.1} s", started.elapsed().as_secs_f64());
}

#[test]
fn requests_without_the_right_token_are_refused() {
    let scratch = Scratch::new("token");
    let file = write_experiment(scratch.path());
    let master = master_with(&scratch, "state", &[], "master.log");
    let url = master.url.as_str();
    for token in [None, Some("wrong-token")] {
        let output = hevo(
            &["submit", "--master", url, file.to_str().unwrap()],
            token,
            Duration::from_secs(30),
        );
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            !output.status.success() && stderr.contains("UNAUTHENTICATED"),
            "{token:?}: {stderr}"
        );
        let output = hevo(&["jobs", "--master", url], token, Duration::from_secs(30));
        assert!(
            !output.status.success()
                && String::from_utf8_lossy(&output.stderr).contains("UNAUTHENTICATED")
        );
    }
    let output = hevo_ok(
        &["jobs", "--master", url],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert_eq!(
        String::from_utf8_lossy(&output.stdout).lines().count(),
        1,
        "only the header: nothing was submitted"
    );

    // A worker with the wrong token gives up at once instead of retrying forever.
    let mut worker = start_worker(
        url,
        "wrong-token",
        "intruder",
        &[],
        &scratch.join("intruder.log"),
    );
    let status = worker
        .wait_timeout(Duration::from_secs(20))
        .expect("a refused worker kept running");
    assert!(!status.success());
    let log = std::fs::read_to_string(scratch.join("intruder.log")).unwrap();
    assert!(log.contains("UNAUTHENTICATED"), "{log}");

    // Health stays open to probes; the job service does not.
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    runtime.block_on(async {
        use tonic_health::pb::health_client::HealthClient;
        let channel = tonic::transport::Channel::from_shared(master.url.clone())
            .unwrap()
            .connect()
            .await
            .unwrap();
        let mut health = HealthClient::new(channel);
        for service in ["", "hevo.v1.JobService", "hevo.v1.WorkerService"] {
            let response = health
                .check(tonic_health::pb::HealthCheckRequest {
                    service: service.into(),
                })
                .await
                .unwrap();
            assert_eq!(
                response.into_inner().status,
                tonic_health::pb::health_check_response::ServingStatus::Serving as i32,
                "{service:?}"
            );
        }
    });

    // A master without a token does not start.
    let output = hevo(
        &[
            "serve",
            "--listen",
            "127.0.0.1:0",
            "--state-dir",
            scratch.join("other").to_str().unwrap(),
        ],
        None,
        Duration::from_secs(30),
    );
    assert!(
        !output.status.success() && String::from_utf8_lossy(&output.stderr).contains("no tokens")
    );
}

#[test]
fn a_broken_job_file_is_refused_naming_the_key() {
    let scratch = Scratch::new("broken");
    let master = master_with(&scratch, "state", &[], "master.log");
    let broken = scratch.join("broken.toml");
    std::fs::write(
        &broken,
        EXPERIMENT.replacen("hidden = 3", "hidden = \"three\"", 1),
    )
    .unwrap();
    let good = write_experiment(scratch.path());
    let cases: [(&Path, &[&str], &[&str]); 5] = [
        (
            &broken,
            &[],
            &[
                "INVALID_ARGUMENT",
                "experiment_toml",
                "broken.toml",
                "node[0].hidden",
            ],
        ),
        (
            &good,
            &["--node", "nope"],
            &[
                "INVALID_ARGUMENT",
                "node: no node named 'nope'",
                "fw, tl, top",
            ],
        ),
        (
            &good,
            &["--runs", "0"],
            &["INVALID_ARGUMENT", "runs: must be between 1"],
        ),
        (
            &good,
            &["--generations", "0"],
            &["INVALID_ARGUMENT", "generations: must be between 1"],
        ),
        (
            &scratch.join("missing.toml"),
            &[],
            &["cannot read", "missing.toml"],
        ),
    ];
    for (file, extra, wanted) in cases {
        let mut args = vec!["submit", "--master", &master.url, file.to_str().unwrap()];
        args.extend_from_slice(extra);
        let output = hevo(&args, Some(CLIENT_TOKEN), Duration::from_secs(30));
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{args:?} was accepted");
        assert!(output.stdout.is_empty(), "{args:?} printed a job id");
        for piece in wanted {
            assert!(
                stderr.contains(piece),
                "{args:?}: {piece:?} not in: {stderr}"
            );
        }
    }
    let output = hevo(
        &["jobs", "--master", &master.url],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert_eq!(
        String::from_utf8_lossy(&output.stdout).lines().count(),
        1,
        "a refused job was stored"
    );
}

#[test]
fn jobs_can_be_cancelled() {
    let scratch = Scratch::new("cancel");
    let file = write_experiment(scratch.path());
    // No workers: the job waits for them until it is cancelled.
    let master = master_with(&scratch, "state", &[], "master.log");
    let job = submit(&master, &file, &[]);
    let output = hevo_ok(
        &["cancel", "--master", &master.url, &job],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert_eq!(
        String::from_utf8_lossy(&output.stdout).trim(),
        format!("{job}: cancelled")
    );
    let output = hevo(
        &["watch", "--master", &master.url, &job],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert!(
        !output.status.success() && String::from_utf8_lossy(&output.stderr).contains("cancelled")
    );
    let output = hevo(
        &["cancel", "--master", &master.url, "job-999999"],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert!(
        !output.status.success() && String::from_utf8_lossy(&output.stderr).contains("NOT_FOUND")
    );
}

#[test]
fn tls_with_a_private_certificate() {
    let expected = reference();
    let _turn = cluster_turn();
    let scratch = Scratch::new("tls");
    let certified = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let (cert, key) = (scratch.join("cert.pem"), scratch.join("key.pem"));
    std::fs::write(&cert, certified.cert.pem()).unwrap();
    std::fs::write(&key, certified.signing_key.serialize_pem()).unwrap();
    let master = master_with(
        &scratch,
        "state",
        &[
            "--tls-cert",
            cert.to_str().unwrap(),
            "--tls-key",
            key.to_str().unwrap(),
        ],
        "master.log",
    );
    assert!(master.url.starts_with("https://localhost:"));
    let ca = ["--tls-ca", cert.to_str().unwrap()];
    let _worker = start_worker(
        &master.url,
        WORKER_TOKEN,
        "tls-worker",
        &ca,
        &scratch.join("worker.log"),
    );
    let file = write_experiment(scratch.path());
    // Without the CA the certificate is not trusted.
    let output = hevo(
        &["jobs", "--master", &master.url],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    assert!(!output.status.success());
    let job = submit(
        &master,
        &file,
        &["--node", "fw", "--tls-ca", cert.to_str().unwrap()],
    );
    hevo_ok(
        &[
            "watch",
            "--master",
            &master.url,
            &job,
            "--tls-ca",
            cert.to_str().unwrap(),
        ],
        Some(CLIENT_TOKEN),
        LONG,
    );
    fetch(
        &master.url,
        CLIENT_TOKEN,
        &job,
        &scratch.join("fetched"),
        &ca,
    );
    // Only the primitive was asked for: its results are those of the full local run.
    assert_same_results(expected, &scratch.join("fetched"), Some(&["fw"]));
    assert!(!scratch.join("fetched/top").exists());
}

/// Evaluations per second: master + two single-thread workers versus `hevo run --threads 2`,
/// on the same experiment (the results are identical, so the work is too).
#[test]
#[ignore = "benchmark: run with -- distributed::overhead_benchmark --ignored --nocapture in release"]
fn overhead_benchmark() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("overhead");
    let experiment = EXPERIMENT
        .replace("generations = 8", "generations = 12")
        .replace("population = 20", "population = 40");
    let file = scratch.join("bench.toml");
    std::fs::write(&file, &experiment).unwrap();
    let rounds = std::env::var("HEVO_OVERHEAD_ROUNDS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let master = master_with(
        &scratch,
        "state",
        &["--metrics-listen", "127.0.0.1:0"],
        "master.log",
    );
    let _workers = two_workers(&master, &scratch, "w");
    let evaluations_so_far = || metric(&metrics_text(&master), "hevo_evaluations_total");
    let (mut local, mut remote) = (Vec::new(), Vec::new());
    let mut evaluations = 0.0;
    for round in 0..rounds {
        let out = scratch.join(&format!("local-{round}"));
        let begun = Instant::now();
        run_locally(&file, &out, LOCAL);
        local.push(begun.elapsed().as_secs_f64());
        let before = evaluations_so_far();
        let begun = Instant::now();
        let job = submit(&master, &file, &[]);
        let output = hevo(
            &["watch", "--master", &master.url, &job],
            Some(CLIENT_TOKEN),
            LONG,
        );
        assert!(output.status.success());
        remote.push(begun.elapsed().as_secs_f64());
        // The same work both ways: the results are identical (checked below).
        evaluations = evaluations_so_far() - before;
        fetch(
            &master.url,
            CLIENT_TOKEN,
            &job,
            &scratch.join(&format!("remote-{round}")),
            &[],
        );
        assert_same_results(&out, &scratch.join(&format!("remote-{round}")), None);
    }
    // Medians: the machine is shared and one slow round should not decide the figure.
    let median = |times: &[f64]| {
        let mut sorted = times.to_vec();
        sorted.sort_by(f64::total_cmp);
        sorted[sorted.len() / 2]
    };
    let (local_rate, remote_rate) = (evaluations / median(&local), evaluations / median(&remote));
    println!(
        "overhead: {evaluations} evaluations; local 2 threads {local_rate:.0}/s (median of {local:.2?} s), \
         master + 2 single-thread workers {remote_rate:.0}/s (median of {remote:.2?} s): {:.1}% of local",
        100.0 * remote_rate / local_rate
    );
}
