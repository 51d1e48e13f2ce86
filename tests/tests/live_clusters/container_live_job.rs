//! The image of deploy/Dockerfile, run for real with podman as compose.yaml runs it: a master
//! container with its state on a named volume and two worker containers that find it by its
//! name on a container network, each with the command and token variables of its compose
//! service; podman runs the compose healthcheck in the master's container. The tiny experiment submitted through the master's published port finishes with
//! results byte for byte those of a local `hevo run`; every container's process runs as the
//! image's non-root user; and SIGTERM (`podman stop`) ends each container with exit status 0.
//!
//! The image is built without a registry (tests/support/podman.rs). Needs root, podman, runc
//! and the CNI dnsname plugin (`scripts/install-test-tools.sh containers`); without them the
//! test fails under CI and is skipped, loudly, elsewhere.

use hevo_tests::podman::{IMAGE, Podman, wait_until};
use hevo_tests::{
    Scratch, assert_same_results, binaries, cluster_turn, fetch, hevo, hevo_ok, repo_root,
    run_locally, work_done,
};
use serde_norway::Value;
use std::path::Path;
use std::time::Duration;

const TEST: &str = "live_clusters::container_live_job";
const CLIENT_TOKEN: &str = "container-live-client-token";
const WORKER_TOKEN: &str = "container-live-worker-token";
/// Evaluations deploy/local/tiny.toml needs: 2 runs x 3 generations x 10 genomes x 3 samples,
/// and each run's post-evaluation of 10 samples.
const TINY_EVALUATIONS: u64 = 2 * 3 * 10 * 3 + 2 * 10;

/// A compose service's command, `${VAR:-default}` replaced by its default.
fn compose_command(compose: &Value, service: &str) -> Vec<String> {
    compose["services"][service]["command"]
        .as_sequence()
        .unwrap_or_else(|| panic!("compose.yaml: {service} has no command list"))
        .iter()
        .map(|v| {
            let text = v.as_str().expect("a string").to_string();
            match text.strip_prefix("${").and_then(|t| t.strip_suffix('}')) {
                Some(var) => var.split_once(":-").expect("a default").1.to_string(),
                None => text,
            }
        })
        .collect()
}

#[test]
fn a_master_and_two_worker_containers_run_the_tiny_experiment() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("container-live-job");
    let Some(podman) = Podman::start(TEST, &scratch) else {
        return;
    };
    podman.build_image(binaries());
    let compose: Value = serde_norway::from_str(
        &std::fs::read_to_string(repo_root().join("deploy/compose.yaml")).unwrap(),
    )
    .expect("compose.yaml parses");
    let experiment = repo_root().join("deploy/local/tiny.toml");
    let experiment = experiment.to_str().unwrap();

    let reference = scratch.join("local");
    run_locally(Path::new(experiment), &reference, &[]);

    // The master as compose runs it: both tokens in its environment, the state on a named
    // volume, gRPC and metrics published on the host's loopback (ports the kernel picks), and
    // the compose healthcheck as the container's.
    let healthcheck: Vec<String> = compose["services"]["master"]["healthcheck"]["test"]
        .as_sequence()
        .expect("the master's healthcheck test")
        .iter()
        .map(|v| v.as_str().expect("a string").to_string())
        .collect();
    assert_eq!(healthcheck[0], "CMD", "an exec-form healthcheck");
    let health_cmd = serde_json::to_string(&healthcheck[1..]).unwrap();
    let mut master = vec![
        "run",
        "--detach",
        "--name",
        "master",
        "--network",
        &podman.network,
        "--env",
        "HEVO_TOKEN",
        "--env",
        "HEVO_WORKER_TOKEN",
        "--volume",
        "state:/var/lib/hevo",
        "--publish",
        "127.0.0.1::50051",
        "--publish",
        "127.0.0.1::9090",
        "--health-cmd",
        &health_cmd,
        IMAGE,
    ];
    let master_command = compose_command(&compose, "master");
    master.extend(master_command.iter().map(String::as_str));
    let output = podman
        .command()
        .args(&master)
        .env("HEVO_TOKEN", CLIENT_TOKEN)
        .env("HEVO_WORKER_TOKEN", WORKER_TOKEN)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "podman run master: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let grpc = podman.published("master", 50051);
    let url = format!("http://{grpc}");
    wait_until(Duration::from_secs(60), || {
        let jobs = hevo(
            &["jobs", "--master", &url],
            Some(CLIENT_TOKEN),
            Duration::from_secs(10),
        );
        jobs.status
            .success()
            .then_some(())
            .ok_or_else(|| String::from_utf8_lossy(&jobs.stderr).into_owned())
    })
    .unwrap_or_else(|e| {
        panic!(
            "the master container does not answer: {e}\n{}",
            podman.logs("master")
        )
    });

    // The compose healthcheck, run by podman in the container with the container's token.
    let health = podman.output(&["healthcheck", "run", "master"]);
    assert!(
        health.status.success(),
        "the compose healthcheck {health_cmd} fails in the container: {}{}\n{}",
        String::from_utf8_lossy(&health.stdout),
        String::from_utf8_lossy(&health.stderr),
        podman.logs("master")
    );

    // Two workers as compose runs them: the master by its service name, the workers' token.
    let worker_command = compose_command(&compose, "worker");
    let workers = ["worker-1", "worker-2"];
    for name in workers {
        let mut args = vec![
            "run",
            "--detach",
            "--name",
            name,
            "--network",
            &podman.network,
            "--env",
            "HEVO_MASTER=http://master:50051",
            "--env",
            "HEVO_TOKEN",
            IMAGE,
        ];
        args.extend(worker_command.iter().map(String::as_str));
        let output = podman
            .command()
            .args(&args)
            .env("HEVO_TOKEN", WORKER_TOKEN)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "podman run {name}: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    }

    let submit = hevo_ok(
        &["submit", "--master", &url, experiment],
        Some(CLIENT_TOKEN),
        Duration::from_secs(30),
    );
    let job = String::from_utf8_lossy(&submit.stdout).trim().to_string();
    let watch = hevo(
        &["watch", "--master", &url, &job],
        Some(CLIENT_TOKEN),
        Duration::from_secs(600),
    );
    let container_logs = || -> String {
        ["master", "worker-1", "worker-2"]
            .iter()
            .map(|c| format!("--- {c}\n{}", podman.logs(c)))
            .collect()
    };
    assert!(
        watch.status.success(),
        "job {job} did not succeed: {}\n{}",
        String::from_utf8_lossy(&watch.stderr),
        container_logs()
    );
    let results = scratch.join("results");
    fetch(&url, CLIENT_TOKEN, &job, &results, &[]);
    assert_same_results(&reference, &results, None);

    // The image's user, 10001, in every container, as the host sees the processes.
    for container in ["master", "worker-1", "worker-2"] {
        let uids = podman.uids(container);
        assert!(
            uids.iter().all(|&uid| uid == 10001),
            "{container} runs with uids {uids:?}, not the image's 10001"
        );
    }

    // SIGTERM: the workers hand back their batches and exit 0, then the master.
    let codes = podman.stop(&["worker-1", "worker-2"], Duration::from_secs(90));
    assert_eq!(
        codes,
        [0, 0],
        "the workers' exit codes:\n{}",
        container_logs()
    );
    // Both worker containers took part, and between them did each evaluation once.
    let mut total = 0;
    for name in workers {
        let log = podman.logs(name);
        let (batches, evaluations) =
            work_done(&log).unwrap_or_else(|| panic!("{name} did not stop cleanly:\n{log}"));
        eprintln!("{name}: {batches} batches, {evaluations} evaluations");
        assert!(batches > 0, "{name} did no work:\n{log}");
        total += evaluations;
    }
    assert_eq!(
        total,
        TINY_EVALUATIONS,
        "the workers' evaluations:\n{}",
        container_logs()
    );
    let codes = podman.stop(&["master"], Duration::from_secs(60));
    assert_eq!(codes, [0], "the master's exit code:\n{}", container_logs());
}
