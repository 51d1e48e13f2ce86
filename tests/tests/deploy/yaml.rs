//! Every YAML file in deploy/ (the compose file, the manifests, the kustomizations) passes
//! yamllint with the project's settings (deploy/.yamllint.yaml), warnings included: no
//! duplicate keys, consistent indentation and spacing, lines within the project's width.

use hevo_tests::deploy::DeployFiles;
use hevo_tests::{Scratch, repo_root, tools};
use std::path::Path;

fn yamllint(tool: &Path, dir: &Path) -> tools::Run {
    tools::run(
        tool,
        &[
            "--strict",
            "--format",
            "parsable",
            "-c",
            "deploy/.yamllint.yaml",
            "deploy/",
        ],
        dir,
    )
}

#[test]
fn yamllint_finds_nothing() {
    let Some(tool) = tools::require("yamllint", "yamllint_finds_nothing") else {
        return;
    };
    let run = yamllint(&tool, &repo_root());
    assert!(run.success, "yamllint --strict deploy/:\n{}", run.output);

    // yamllint runs for real: a duplicated key is found, with its file and line.
    let scratch = Scratch::new("yamllint");
    let mut files = DeployFiles::load();
    files.replace(
        "deploy/k8s/worker.yaml",
        "  replicas: 2\n",
        "  replicas: 2\n  replicas: 3\n",
    );
    files.write_to(scratch.path());
    let line = files
        .get("deploy/k8s/worker.yaml")
        .lines()
        .position(|l| l == "  replicas: 3")
        .expect("the changed line")
        + 1;
    let run = yamllint(&tool, scratch.path());
    let expected = format!("deploy/k8s/worker.yaml:{line}:");
    assert!(
        !run.success && run.output.contains(&expected) && run.output.contains("key-duplicates"),
        "yamllint did not report the duplicated key at {expected}:\n{}",
        run.output
    );
}
