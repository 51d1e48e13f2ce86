//! deploy/compose.yaml: the master publishes only its own ports, keeps its state on a named
//! volume and has a healthcheck that is a real client call on its port; the workers are told
//! where the master is, wait for it to be healthy and get a minute and more to stop; the master
//! gets two different tokens, the clients' and the workers', each worker only the workers' and
//! the client service only the clients'; and the file is valid against the Compose Specification's schema
//! (check-jsonschema's bundled copy).

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};
use hevo_tests::{Scratch, repo_root, tools};

#[test]
fn the_compose_services_are_wired_together() {
    Analysis::of(&DeployFiles::load())
        .problems
        .assert_none(Concern::Compose, "deploy/compose.yaml");
}

#[test]
fn compose_drift_is_reported() {
    assert_drift_detected(
        Concern::Compose,
        None,
        &[
            Drift {
                path: "deploy/compose.yaml",
                from: "HEVO_MASTER: http://master:50051",
                to: "HEVO_MASTER: http://master:50052",
                expected: "the worker dials http://master:50052",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "--master, \"http://127.0.0.1:50051\"]",
                to: "--master, \"http://127.0.0.1:9090\"]",
                expected: "healthcheck dials port Some(9090)",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "stop_grace_period: 90s",
                to: "stop_grace_period: 10s",
                expected: "stop_grace_period Some(10.0) s",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "      - state:/var/lib/hevo",
                to: "      - /tmp:/var/lib/hevo",
                expected: "the state directory /var/lib/hevo is not on a named volume",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "\"127.0.0.1:9090:9090\"",
                to: "\"127.0.0.1:9091:9091\"",
                expected: "publishes 127.0.0.1:9091:9091",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "    depends_on:\n      master:",
                to: "    depends_on:\n      mastr:",
                expected: "the worker does not depend_on the master",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "HEVO_TOKEN: ${HEVO_WORKER_TOKEN:?",
                to: "HEVO_TOKEN: ${HEVO_TOKEN:?",
                expected: "services.worker: the worker's token is ${HEVO_TOKEN}, not the master's workers' token ${HEVO_WORKER_TOKEN}",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "      # The clients' token.\n      HEVO_TOKEN: ${HEVO_TOKEN:?",
                to: "      HEVO_TOKEN: ${HEVO_TOKEN:?create}\n      X: ${HEVO_WORKER_TOKEN:?",
                expected: "services.hevo: the client is given ${HEVO_WORKER_TOKEN}, the other role's token",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "      HEVO_WORKER_TOKEN: ${HEVO_WORKER_TOKEN:?",
                to: "      X: ${HEVO_WORKER_TOKEN:?",
                expected: "services.master: the master gets no workers' token",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "      HEVO_WORKER_TOKEN: ${HEVO_WORKER_TOKEN:?",
                to: "      HEVO_WORKER_TOKEN: ${HEVO_TOKEN:?",
                expected: "services.master: the master gets one token, ${HEVO_TOKEN}, for both roles",
            },
        ],
    );
}

#[test]
fn compose_file_matches_the_compose_specification() {
    let test = "compose_file_matches_the_compose_specification";
    let Some(check_jsonschema) = tools::require("check-jsonschema", test) else {
        return;
    };
    let args = [
        "--builtin-schema",
        "vendor.compose-spec",
        "deploy/compose.yaml",
    ];
    let run = tools::run(&check_jsonschema, &args, &repo_root());
    assert!(
        run.success,
        "check-jsonschema (compose spec):\n{}",
        run.output
    );

    // The schema is really applied: a misspelt key is rejected.
    let scratch = Scratch::new("compose-spec");
    let mut files = DeployFiles::load();
    files.replace(
        "deploy/compose.yaml",
        "stop_grace_period: 90s",
        "stop_grace_perod: 90s",
    );
    files.write_to(scratch.path());
    let run = tools::run(&check_jsonschema, &args, scratch.path());
    assert!(
        !run.success && run.output.contains("stop_grace_perod"),
        "check-jsonschema accepted a misspelt key:\n{}",
        run.output
    );
}
