//! The conventions deploy/README.md promises for every path: one gRPC port and one metrics
//! port for the master in every file that fixes one (compose, Kubernetes), which are exactly
//! the ports the image exposes; one state directory (the image's, compose's, Kubernetes'); and
//! the image's uid for every Kubernetes container.

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};

#[test]
fn every_file_uses_the_same_ports_state_directory_and_uid() {
    let analysis = Analysis::of(&DeployFiles::load());
    let facts = &analysis.facts;
    eprintln!(
        "gRPC ports {:?}, metrics ports {:?}, state directories {:?}",
        facts.grpc_ports, facts.metrics_ports, facts.state_dirs
    );
    analysis
        .problems
        .assert_none(Concern::Conventions, "deploy/ disagrees with itself");
}

#[test]
fn convention_drift_is_reported() {
    assert_drift_detected(
        Concern::Conventions,
        None,
        &[
            Drift {
                path: "deploy/Dockerfile",
                from: "USER 10001:10001",
                to: "USER 10002:10001",
                expected: "runs as uid 10001, the image's user is 10002",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "EXPOSE 50051 9090",
                to: "EXPOSE 50052 9090",
                expected: "EXPOSE {9090, 50052}",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "      - 0.0.0.0:9090",
                to: "      - 0.0.0.0:9091",
                expected: "the metrics port differs between files",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "            - --state-dir\n            - /var/lib/hevo",
                to: "            - --state-dir\n            - /var/lib/hevo-state",
                expected: "the master's state directory differs between files",
            },
        ],
    );
}
