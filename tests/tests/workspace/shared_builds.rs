//! The binaries a user builds one at a time share one build: `hevo` (`cargo run --bin hevo`),
//! `hevo-worker` and the Python module (`pip install ./python`) each compile every third-party
//! crate with the features the whole workspace gives it, so the second and third builds reuse
//! the first's instead of compiling rapier, tonic and tokio again. master/workspace-hack asks
//! for those features; this test fails when a new dependency or feature makes a build differ
//! from the workspace's, and names the crates.

use std::collections::{BTreeMap, BTreeSet};
use std::process::Command;

/// The packages built on their own, by their users.
const BUILT_ALONE: [&str; 3] = ["hevo-cli", "hevo-worker", "hevo-python"];

/// Each third-party crate of the build (`name version`) and the feature lists it is compiled
/// with (once per context it is compiled in: for the target, or for build scripts and macros).
fn features(selection: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let output = Command::new(cargo)
        .current_dir(hevo_tests::repo_root())
        .args(["tree", "--locked", "-e", "normal,build", "--no-dedupe"])
        .args(["--prefix", "none", "--format", "{p}|{f}"])
        .args(selection)
        .output()
        .expect("cannot run cargo tree");
    assert!(
        output.status.success(),
        "cargo tree {selection:?} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut features: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&output.stdout).lines() {
        let Some((package, enabled)) = line.split_once('|') else {
            continue;
        };
        // Workspace members are `name vX (path)`; only registry crates are compared.
        let package = package.trim_end_matches(" (*)").trim();
        if package.contains(" (") {
            continue;
        }
        features
            .entry(package.to_string())
            .or_default()
            .insert(enabled.trim().to_string());
    }
    features
}

#[test]
fn separately_built_binaries_compile_shared_crates_as_the_workspace_does() {
    let workspace = features(&["--workspace"]);
    let mut differences = Vec::new();
    for package in BUILT_ALONE {
        for (dependency, lists) in features(&["-p", package]) {
            let in_workspace = workspace.get(&dependency).cloned().unwrap_or_default();
            for list in lists.difference(&in_workspace) {
                differences.push(format!(
                    "{package}: {dependency} with features [{list}], the workspace with {in_workspace:?}"
                ));
            }
        }
    }
    assert!(
        differences.is_empty(),
        "built alone, these would compile crates again instead of reusing the workspace's \
         build; run `cargo hakari generate` (cargo install cargo-hakari --locked) to update \
         master/workspace-hack:\n{}",
        differences.join("\n")
    );
}
