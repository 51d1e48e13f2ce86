//! The one-box and SLURM scripts: bash with a shebang, a comment and `set -euo pipefail`,
//! `bash -n` clean, running the master (with the clients' and the workers' token, two
//! different ones), the workers (with the workers'), submit, watch and fetch (with the
//! clients') (the SLURM script with `#SBATCH` directives and srun); and shellcheck finds nothing in them,
//! nor in the shell blocks of deploy/README.md.

use hevo_tests::deploy::readme::shell_blocks;
use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected, scripts};
use hevo_tests::{Scratch, tools};
use std::path::Path;

#[test]
fn the_scripts_run_every_step_with_the_token_of_its_role() {
    Analysis::of(&DeployFiles::load())
        .problems
        .assert_none(Concern::Scripts, "deploy/ scripts");
}

#[test]
fn script_drift_is_reported() {
    assert_drift_detected(
        Concern::Scripts,
        None,
        &[
            Drift {
                path: "deploy/local/one-box.sh",
                from: "set -euo pipefail\n",
                to: "set -eu\n",
                expected: "no `set -euo pipefail`",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "    worker_pids+=(\"$!\")\ndone",
                to: "    worker_pids+=(\"$!\")\n",
                expected: "bash -n",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "\"$hevo\" fetch --master \"$master_url\" --token-file \"$client_token_file\"",
                to: "\"$hevo\" fetch --master \"$master_url\"",
                expected: "deploy/local/one-box.sh:246: `hevo fetch` without the token",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "\"$hevo_worker\" --master \"$master_url\" --token-file \"$worker_token_file\"",
                to: "\"$hevo_worker\" --master \"$master_url\" --token-file \"$client_token_file\"",
                expected: "deploy/local/one-box.sh:227: `hevo-worker` gets $client_token_file, the other role's token",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: " --worker-token-file \"$worker_token_file\"",
                to: "",
                expected: "deploy/local/one-box.sh:207: `hevo serve` without the workers' token",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "--worker-token-file \"$worker_token_file\"",
                to: "--worker-token-file \"$client_token_file\"",
                expected: "deploy/slurm/hevo.sbatch:167: `hevo serve` gets one token, $client_token_file, for both roles",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "submit --master \"$HEVO_MASTER\" --token-file \"$client_token_file\"",
                to: "submit --master \"$HEVO_MASTER\" --token-file \"$worker_token_file\"",
                expected: "`hevo submit` gets $worker_token_file, the other role's token",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "\"$hevo\" watch --master",
                to: "echo --master",
                expected: "runs no `hevo watch`",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "srun --ntasks=",
                to: "env --ntasks=",
                expected: "the workers are not started with srun",
            },
        ],
    );
}

/// shellcheck on `files`' scripts and README shell blocks, written below `dir`: its report, if
/// it found anything.
fn shellcheck(shellcheck: &Path, files: &DeployFiles, dir: &Path) -> Result<(), String> {
    files.write_to(dir);
    let mut targets: Vec<String> = scripts::paths(files).into_iter().cloned().collect();
    let mut blocks = Vec::new();
    // Each README block as a script of its own, padded so that shellcheck's line numbers are
    // the README's. SC1091 (cannot follow a sourced file) is off for them: they source
    // deploy/.env, which the user creates and the repository does not have.
    let readme = files.get("deploy/README.md");
    for (number, (body, start)) in shell_blocks(readme).into_iter().enumerate() {
        let name = format!("README.md-block-{}.sh", number + 1);
        let padding = "\n".repeat(start.saturating_sub(2));
        let header = "# shellcheck shell=bash disable=SC1091";
        std::fs::write(dir.join(&name), format!("{header}\n{padding}{body}"))
            .expect("write a README block");
        targets.push(name.clone());
        blocks.push(name);
    }
    let mut args = vec!["--format=gcc".to_string()];
    args.extend(targets);
    let run = tools::run(shellcheck, &args, dir);
    if run.success {
        return Ok(());
    }
    // `README.md-block-3.sh:84:8: ...` -> `deploy/README.md:84:8: ...`.
    let mut report = run.output;
    for name in blocks {
        report = report.replace(&format!("{name}:"), "deploy/README.md:");
    }
    Err(report)
}

#[test]
fn shellcheck_finds_nothing() {
    let Some(tool) = tools::require("shellcheck", "shellcheck_finds_nothing") else {
        return;
    };
    let scratch = Scratch::new("shellcheck");
    let files = DeployFiles::load();
    if let Err(report) = shellcheck(&tool, &files, &scratch.join("pristine")) {
        panic!("shellcheck:\n{report}");
    }

    // shellcheck runs for real: an unquoted variable, in a script and in the README, is found.
    let mut files = files;
    files.replace(
        "deploy/local/one-box.sh",
        "rm -rf \"$work_dir\"",
        "rm -rf $work_dir",
    );
    files.replace(
        "deploy/README.md",
        "hevo watch --master http://127.0.0.1:50051 \"$job\"",
        "hevo watch --master http://127.0.0.1:50051 $job",
    );
    let report = shellcheck(&tool, &files, &scratch.join("drift"))
        .expect_err("shellcheck found nothing in scripts with unquoted variables");
    let readme_line = files
        .get("deploy/README.md")
        .lines()
        .position(|l| l.ends_with("50051 $job"))
        .expect("the changed line")
        + 1;
    for expected in [
        "deploy/local/one-box.sh:".to_string(),
        format!("deploy/README.md:{readme_line}:"),
    ] {
        assert!(
            report.contains(&expected) && report.contains("SC2086"),
            "shellcheck did not report SC2086 at {expected}:\n{report}"
        );
    }
}
