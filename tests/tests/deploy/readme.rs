//! deploy/README.md: its shell blocks show the one-box and SLURM scripts and the submit, watch
//! and fetch commands, and every `deploy/...` path it names and every relative link exists.
//! (Their flags are checked by `flags.rs`, their shell by `scripts.rs`.)

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};

#[test]
fn the_readme_shows_each_path_and_points_only_to_files_that_exist() {
    Analysis::of(&DeployFiles::load())
        .problems
        .assert_none(Concern::Readme, "deploy/README.md");
}

#[test]
fn readme_drift_is_reported() {
    assert_drift_detected(
        Concern::Readme,
        None,
        &[
            Drift {
                path: "deploy/README.md",
                from: "[`compose.yaml`](compose.yaml)",
                to: "[`compose.yaml`](compose.yml)",
                expected: "deploy/README.md:26: links to compose.yml, which does not exist",
            },
            Drift {
                path: "deploy/README.md",
                from: "sbatch deploy/slurm/hevo.sbatch deploy/local/tiny.toml",
                to: "sbatch deploy/slurm/hevo.batch deploy/local/tiny.toml",
                expected: "refers to deploy/slurm/hevo.batch, which does not exist",
            },
            Drift {
                path: "deploy/README.md",
                from: "deploy/local/one-box.sh --workers 2",
                to: "deploy/local/one-box.bash --workers 2",
                expected: "refers to deploy/local/one-box.bash",
            },
        ],
    );
}
