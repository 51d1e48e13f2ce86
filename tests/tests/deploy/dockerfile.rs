//! deploy/Dockerfile: a multi-stage build of the workspace packages that own `hevo` and
//! `hevo-worker`, both copied into a runtime stage that runs as a numeric non-root user with an
//! exec-form `CMD` and no `ENTRYPOINT`, the state directory created for that user; and hadolint,
//! the Dockerfile linter, finds nothing.

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};
use hevo_tests::{Scratch, repo_root, tools};

#[test]
fn the_dockerfile_builds_both_binaries_into_a_non_root_image() {
    Analysis::of(&DeployFiles::load())
        .problems
        .assert_none(Concern::Dockerfile, "deploy/Dockerfile");
}

#[test]
fn dockerfile_drift_is_reported() {
    assert_drift_detected(
        Concern::Dockerfile,
        None,
        &[
            Drift {
                path: "deploy/Dockerfile",
                from: "-p hevo-worker",
                to: "-p hevo-wrker",
                expected: "`cargo build -p hevo-wrker`: no such workspace package",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "USER 10001:10001",
                to: "USER 0:0",
                expected: "the runtime stage runs as root",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "USER 10001:10001",
                to: "USER nonroot",
                expected: "use a numeric uid",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "CMD [\"hevo\", \"--help\"]",
                to: "CMD hevo --help",
                expected: "use the exec (JSON) form",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: " target/release/hevo-worker /out/bin/",
                to: " /out/bin/",
                expected: "target/release/hevo-worker is not copied out of the build",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "--chown=10001:10001",
                to: "--chown=10002:10001",
                expected: "is not owned by the runtime user 10001",
            },
        ],
    );
}

#[test]
fn hadolint_finds_nothing() {
    let Some(hadolint) = tools::require("hadolint", "hadolint_finds_nothing") else {
        return;
    };
    let root = repo_root();
    let run = tools::run(&hadolint, &["deploy/Dockerfile"], &root);
    assert!(run.success, "hadolint deploy/Dockerfile:\n{}", run.output);

    // The linter runs for real: a Dockerfile it must reject is rejected.
    let scratch = Scratch::new("hadolint");
    let mut files = DeployFiles::load();
    files.replace(
        "deploy/Dockerfile",
        "WORKDIR /var/lib/hevo",
        "WORKDIR var/lib/hevo",
    );
    files.write_to(scratch.path());
    let run = tools::run(&hadolint, &["deploy/Dockerfile"], scratch.path());
    assert!(
        !run.success && run.output.contains("DL3000"),
        "hadolint accepted a relative WORKDIR:\n{}",
        run.output
    );
}
