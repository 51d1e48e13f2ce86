//! The image of deploy/Dockerfile run with podman the way deploy/k8s/master.yaml runs the
//! master: its command and arguments, the token Secret's two files mounted read-only at the
//! manifest's path, a read-only root filesystem with a scratch /tmp, every capability dropped,
//! no privilege escalation, and the state on a volume. Through the published ports, each
//! health service the manifest's gRPC probes ask for answers SERVING without a token, and the
//! metrics port serves the path of the scrape annotations.
//!
//! The image is built without a registry (tests/support/podman.rs). Needs root, podman, runc
//! and the CNI dnsname plugin (`scripts/install-test-tools.sh containers`); without them the
//! test fails under CI and is skipped, loudly, elsewhere.

use hevo_tests::deploy::{Analysis, DeployFiles};
use hevo_tests::podman::{IMAGE, Podman, wait_until};
use hevo_tests::service::health_status;
use hevo_tests::{Scratch, binaries, cluster_turn, http_get};
use std::time::Duration;

const TEST: &str = "live_clusters::container_live_probes";

#[test]
fn the_master_container_as_kubernetes_runs_it_answers_its_probes() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("container-live-probes");
    let Some(podman) = Podman::start(TEST, &scratch) else {
        return;
    };
    podman.build_image(binaries());
    let facts = Analysis::of(&DeployFiles::load()).facts;
    let argv = facts
        .k8s_master_argv
        .clone()
        .expect("the manifests run hevo serve");
    assert!(
        !facts.probe_services.is_empty(),
        "the manifests have no gRPC probes"
    );

    // The Secret's two keys, as files readable by the pod's user.
    let secret = scratch.join("secret");
    std::fs::create_dir_all(&secret).unwrap();
    for (key, token) in [
        ("token", "container-probes-client-token"),
        ("worker-token", "container-probes-worker-token"),
    ] {
        std::fs::write(secret.join(key), token).unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(secret.join(key), std::fs::Permissions::from_mode(0o444)).unwrap();
    }
    let secret_mount = format!("{}:/etc/hevo/token:ro", secret.display());
    let mut run = vec![
        "run",
        "--detach",
        "--name",
        "master",
        "--network",
        &podman.network,
        "--read-only",
        "--tmpfs",
        "/tmp",
        "--cap-drop",
        "ALL",
        "--security-opt",
        "no-new-privileges",
        "--volume",
        &secret_mount,
        "--volume",
        "k8s-state:/var/lib/hevo",
        "--publish",
        "127.0.0.1::50051",
        "--publish",
        "127.0.0.1::9090",
        IMAGE,
    ];
    run.extend(argv.iter().map(String::as_str));
    podman.run(&run);
    let grpc = podman.published("master", 50051);
    let metrics = podman.published("master", 9090);

    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let serving = tonic_health::pb::health_check_response::ServingStatus::Serving as i32;
    for service in &facts.probe_services {
        wait_until(Duration::from_secs(60), || {
            match health_status(&runtime, &grpc, service) {
                Ok(status) if status == serving => Ok(()),
                other => Err(format!("{other:?}")),
            }
        })
        .unwrap_or_else(|last| {
            panic!(
                "health check of {service:?} in the container: {last}, not SERVING\n{}",
                podman.logs("master")
            )
        });
        eprintln!("health service {service:?}: SERVING");
    }
    for path in facts
        .metrics_paths
        .iter()
        .chain(std::iter::once(&"/metrics".to_string()))
    {
        let response = http_get(&metrics, path);
        let status = response.lines().next().unwrap_or_default();
        assert!(
            status.contains(" 200"),
            "GET {path} on the container's metrics port answered {status:?}"
        );
    }
    drop(runtime);
    let uids = podman.uids("master");
    assert!(
        uids.iter().all(|&uid| uid == 10001),
        "the master runs with uids {uids:?}, not the image's 10001"
    );
    let codes = podman.stop(&["master"], Duration::from_secs(60));
    assert_eq!(
        codes,
        [0],
        "the master's exit code:\n{}",
        podman.logs("master")
    );
}
