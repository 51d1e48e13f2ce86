//! The workspace's integration tests stay a few binaries: each integration-test target links
//! the whole stack, and when each behaviour was a target of its own, some fifty of them once
//! filled CI's disk while linking. A crate's tests are one target per area,
//! `tests/AREA/main.rs`, whose modules are its behaviours (one file each) and its `support`.

use serde_json::Value;
use std::process::Command;

/// The most integration-test targets the workspace may have.
const MAX_TEST_TARGETS: usize = 15;

/// Every integration-test target of the workspace, as `package: target (source)`.
fn test_targets() -> Vec<String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = Command::new(cargo)
        .current_dir(hevo_tests::repo_root())
        .args(["metadata", "--locked", "--no-deps", "--format-version", "1"])
        .output()
        .expect("cannot run cargo metadata");
    assert!(
        output.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: Value = serde_json::from_slice(&output.stdout).expect("cargo metadata's JSON");
    let mut targets = Vec::new();
    for package in metadata["packages"].as_array().expect("a package list") {
        for target in package["targets"].as_array().expect("a target list") {
            if target["kind"] == serde_json::json!(["test"]) {
                targets.push(format!(
                    "{}: {} ({})",
                    package["name"].as_str().unwrap_or_default(),
                    target["name"].as_str().unwrap_or_default(),
                    target["src_path"].as_str().unwrap_or_default()
                ));
            }
        }
    }
    targets
}

#[test]
fn the_workspace_has_at_most_fifteen_integration_test_targets() {
    let targets = test_targets();
    // The listing must see the targets there are, or the limit would hold vacuously.
    assert!(
        targets
            .iter()
            .any(|t| t.starts_with("hevo-tests: workspace ")),
        "cargo metadata did not list this test's own target: {targets:#?}"
    );
    assert!(
        targets.len() <= MAX_TEST_TARGETS,
        "{} integration-test targets, more than {MAX_TEST_TARGETS}: add a new test as a module \
         of its area's target (tests/AREA/main.rs), not as a file of its own in tests/:\n{}",
        targets.len(),
        targets.join("\n")
    );
}
