//! What `--help` cannot show, against a live `hevo serve` started with the deploy files' own
//! command lines (addresses and paths made local), once with the compose master's and once
//! with the Kubernetes one: the health services the probes ask for answer SERVING without a
//! token, the metrics path of the scrape annotations answers, the compose healthcheck passes
//! with the clients' token and is refused without it or with the workers' token, a worker is
//! served with the workers' token and refused with the clients', and SIGTERM stops the master. The master gets both tokens the
//! way its deploy file gives them (files or variables), so it starts only if the file wires both
//! roles.
//!
//! The binaries come from `cargo build -p hevo-cli -p hevo-worker` in the tests' profile
//! (see `hevo_tests::binaries`), or from the directory in `HEVO_TEST_BIN_DIR` when it is set.

use hevo_tests::deploy::{Analysis, DeployFiles};
use hevo_tests::service::health_status;
use hevo_tests::{Proc, Scratch, binaries, http_get, lines_of};
use std::collections::BTreeSet;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The clients' token the master is given.
const CLIENT_TOKEN: &str = "deploy-probes-client-token";
/// The workers' token the master is given.
const WORKER_TOKEN: &str = "deploy-probes-worker-token";

/// A running master, started with the deploy files' own arguments (addresses and paths made
/// local), stopped with SIGTERM by [`Master::stop`] and killed when dropped.
struct Master {
    proc: Proc,
    grpc: String,
    metrics: Option<String>,
    /// Its stdout after the address lines, kept open so the master never writes to a closed
    /// pipe.
    _stdout: mpsc::Receiver<String>,
}

impl Master {
    /// `env` names the token variables the deploy file sets for the master: each gets its
    /// role's token; a `--token-file` or `--worker-token-file` becomes a local file of it.
    fn start(argv: &[String], dir: &Path, env: &BTreeSet<String>) -> Master {
        std::fs::create_dir_all(dir).unwrap();
        let token_file = dir.join("token");
        std::fs::write(&token_file, CLIENT_TOKEN).unwrap();
        let worker_token_file = dir.join("worker-token");
        std::fs::write(&worker_token_file, WORKER_TOKEN).unwrap();
        let mut args = Vec::new();
        let mut previous = String::new();
        for arg in &argv[1..] {
            let arg = match previous.as_str() {
                "--listen" | "--metrics-listen" => "127.0.0.1:0".to_string(),
                "--state-dir" => dir.join("state").to_string_lossy().into_owned(),
                "--token-file" => token_file.to_string_lossy().into_owned(),
                "--worker-token-file" => worker_token_file.to_string_lossy().into_owned(),
                _ => arg.clone(),
            };
            previous = arg.clone();
            args.push(arg);
        }
        let mut command = Command::new(&binaries().hevo);
        command
            .args(&args)
            .env_remove("HEVO_TOKEN")
            .env_remove("HEVO_WORKER_TOKEN")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        for (var, token) in [
            ("HEVO_TOKEN", CLIENT_TOKEN),
            ("HEVO_WORKER_TOKEN", WORKER_TOKEN),
        ] {
            if env.contains(var) {
                command.env(var, token);
            }
        }
        let mut proc = Proc::spawn("hevo serve", &mut command);
        let lines = lines_of(proc.child().stdout.take().expect("piped stdout"));
        let next_line = || {
            lines
                .recv_timeout(Duration::from_secs(20))
                .unwrap_or_default()
        };
        let first = next_line();
        let grpc = first
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("hevo {args:?} printed {first:?} first"))
            .to_string();
        let metrics = if args.iter().any(|a| a == "--metrics-listen") {
            let second = next_line();
            Some(
                second
                    .strip_prefix("metrics on ")
                    .unwrap_or_else(|| panic!("expected `metrics on ADDR`, got {second:?}"))
                    .to_string(),
            )
        } else {
            None
        };
        Master {
            proc,
            grpc,
            metrics,
            _stdout: lines,
        }
    }

    fn stop(mut self) -> std::process::ExitStatus {
        self.proc.signal("TERM");
        self.proc
            .wait_timeout(Duration::from_secs(30))
            .expect("hevo serve did not exit within 30 s of SIGTERM")
    }
}

/// A `hevo-worker` with `token` against the master, its stderr in `log`.
fn worker(grpc: &str, token: &str, log: &Path) -> Proc {
    Proc::spawn(
        "hevo-worker",
        Command::new(&binaries().worker)
            .args(["--master", &format!("http://{grpc}"), "--threads", "1"])
            .env("HEVO_TOKEN", token)
            .env_remove("HEVO_MASTER")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(log).unwrap()),
    )
}

/// A worker with the clients' token is refused (a refused worker exits at once), and one with
/// the workers' token is taken on: it still runs well after the refused one exited.
fn assert_serves_workers_with_their_token_only(grpc: &str, dir: &Path) {
    let log = dir.join("refused-worker.log");
    let mut refused = worker(grpc, CLIENT_TOKEN, &log);
    let status = refused.wait_timeout(Duration::from_secs(15));
    assert!(
        status.is_some_and(|s| !s.success()),
        "a worker with the clients' token was not refused ({status:?}):\n{}",
        std::fs::read_to_string(&log).unwrap_or_default()
    );
    let log = dir.join("worker.log");
    let mut served = worker(grpc, WORKER_TOKEN, &log);
    let status = served.wait_timeout(Duration::from_secs(3));
    assert!(
        status.is_none(),
        "a worker with the workers' token exited ({status:?}):\n{}",
        std::fs::read_to_string(&log).unwrap_or_default()
    );
    served.kill();
}

#[test]
fn the_master_answers_the_probes_the_deploy_files_use() {
    let analysis = Analysis::of(&DeployFiles::load());
    let facts = &analysis.facts;
    let scratch = Scratch::new("deploy-probes");
    let mut services = facts.probe_services.clone();
    services.insert(String::new());

    let (compose_argv, compose_env) = facts
        .compose_master_argv
        .clone()
        .expect("the compose file runs hevo serve");
    let k8s_argv = facts
        .k8s_master_argv
        .clone()
        .expect("the manifests run hevo serve");
    for (name, argv, env) in [
        ("compose", compose_argv, compose_env),
        ("k8s", k8s_argv, BTreeSet::new()),
    ] {
        let master = Master::start(&argv, &scratch.join(name), &env);
        // One runtime per master, dropped before the master is stopped so that no gRPC
        // connection of ours holds its shutdown up.
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        for service in &services {
            let deadline = Instant::now() + Duration::from_secs(15);
            loop {
                let status = health_status(&runtime, &master.grpc, service);
                if status
                    == Ok(tonic_health::pb::health_check_response::ServingStatus::Serving as i32)
                {
                    break;
                }
                assert!(
                    Instant::now() < deadline,
                    "{name}: health check of {service:?} without a token: {status:?}, not SERVING"
                );
                std::thread::sleep(Duration::from_millis(200));
            }
        }
        if let Some(metrics) = &master.metrics {
            for path in facts
                .metrics_paths
                .iter()
                .chain(std::iter::once(&"/metrics".to_string()))
            {
                let response = http_get(metrics, path);
                let status = response.lines().next().unwrap_or_default();
                assert!(
                    status.contains(" 200"),
                    "{name}: GET {path} on the metrics port answered {status:?}"
                );
            }
        }
        if name == "compose" {
            let healthcheck = facts
                .compose_healthcheck
                .clone()
                .expect("compose healthcheck");
            let mut args: Vec<String> = healthcheck[1..].to_vec();
            if let Some(at) = args.iter().position(|a| a == "--master") {
                args[at + 1] = format!("http://{}", master.grpc);
            }
            let healthcheck = |token: Option<&str>| {
                let mut command = Command::new(&binaries().hevo);
                command
                    .args(&args)
                    .env_remove("HEVO_TOKEN")
                    .env_remove("HEVO_WORKER_TOKEN");
                if let Some(token) = token {
                    command.env("HEVO_TOKEN", token);
                }
                command.output().unwrap()
            };
            let passed = healthcheck(Some(CLIENT_TOKEN));
            assert!(
                passed.status.success(),
                "the compose healthcheck {args:?} fails: {}",
                String::from_utf8_lossy(&passed.stderr)
            );
            for (token, what) in [
                (None, "without a token"),
                (Some(WORKER_TOKEN), "with the workers' token"),
            ] {
                assert!(
                    !healthcheck(token).status.success(),
                    "the master answered `hevo {}` {what}",
                    args.join(" ")
                );
            }
        }
        assert_serves_workers_with_their_token_only(&master.grpc, &scratch.join(name));
        drop(runtime);
        let status = master.stop();
        eprintln!("{name}: hevo serve exited with {status} after SIGTERM");
    }
}
