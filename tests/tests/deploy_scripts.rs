//! The one-box and SLURM scripts: bash with a shebang, a comment and `set -euo pipefail`,
//! `bash -n` clean, running the master, the workers, submit, watch and fetch with the token
//! (the SLURM script with `#SBATCH` directives and srun).

use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};

#[test]
fn the_scripts_run_every_step_with_the_token() {
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
                from: "\"$hevo\" fetch --master \"$master_url\" --token-file \"$token_file\"",
                to: "\"$hevo\" fetch --master \"$master_url\"",
                expected: "deploy/local/one-box.sh:236: `hevo fetch` without the token",
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
