//! Every `hevo`, `hevo-worker`, `one-box.sh` and `hevo.sbatch` command line in deploy/ (the
//! Dockerfile's CMD, the compose services and healthcheck, the Kubernetes containers, the
//! scripts, the README's shell blocks, down into `$(...)`, `bash -c` and `sbatch --wrap`)
//! uses only what the program's own `--help` lists: its subcommands, its options, a value where
//! an option takes one and none where it does not, its required flags (or their environment
//! variables) and arguments; and every `HEVO_*` variable in deploy/ is one the binaries read.
//!
//! The binaries come from `cargo build -p hevo-cli -p hevo-worker` in the tests' profile
//! (see `hevo_tests::binaries`), or from the directory in `HEVO_TEST_BIN_DIR` when it is set.

use hevo_tests::deploy::help::helps;
use hevo_tests::deploy::{Analysis, Concern, DeployFiles, Drift, assert_drift_detected};
use std::collections::BTreeMap;

#[test]
fn every_command_line_uses_only_what_the_binaries_accept() {
    let analysis = Analysis::with_flags(&DeployFiles::load(), helps());
    let mut summary: BTreeMap<String, usize> = BTreeMap::new();
    for invocation in &analysis.facts.invocations {
        *summary.entry(invocation.name()).or_default() += 1;
    }
    eprintln!(
        "checked {} command lines: {summary:?}",
        analysis.facts.invocations.len()
    );
    analysis
        .problems
        .assert_none(Concern::Flags, "deploy/ has drifted from the binaries");
    assert!(
        analysis.facts.invocations.len() >= 20,
        "suspiciously few command lines found: {:#?}",
        analysis.facts.invocations
    );
}

/// The checker itself: a wrong subcommand, flag, value, variable or missing required flag,
/// injected into a copy of each kind of file, is reported with the file and line.
#[test]
fn a_wrong_flag_is_reported() {
    assert_drift_detected(
        Concern::Flags,
        Some(helps()),
        &[
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "- --state-dir",
                to: "- --state-directory",
                expected: "deploy/k8s/master.yaml:92: StatefulSet hevo-master container master: `hevo serve` has no option `--state-directory`",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "HEVO_MASTER: http://master:50051",
                to: "HEVO_MASTERS: http://master:50051",
                expected: "deploy/compose.yaml:65: `HEVO_MASTERS` is not an environment variable",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "test: [CMD, hevo, jobs, --master,",
                to: "test: [CMD, hevo, job, --master,",
                expected: "deploy/compose.yaml:50: services.master.healthcheck: `hevo job`: hevo has no subcommand `job`",
            },
            Drift {
                path: "deploy/compose.yaml",
                from: "HEVO_WORKER_TOKEN: ${HEVO_WORKER_TOKEN:?",
                to: "HEVO_WORKERS_TOKEN: ${HEVO_WORKER_TOKEN:?",
                expected: "deploy/compose.yaml:40: `HEVO_WORKERS_TOKEN` is not an environment variable",
            },
            Drift {
                path: "deploy/k8s/master.yaml",
                from: "- --worker-token-file",
                to: "- --workers-token-file",
                expected: "deploy/k8s/master.yaml:98: StatefulSet hevo-master container master: `hevo serve` has no option `--workers-token-file`",
            },
            Drift {
                path: "deploy/Dockerfile",
                from: "CMD [\"hevo\", \"--help\"]",
                to: "CMD [\"hevo\", \"--helpp\"]",
                expected: "deploy/Dockerfile:53: CMD: `hevo` has no option `--helpp`",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "\"$hevo\" watch --master",
                to: "\"$hevo\" wait --master",
                expected: "deploy/local/one-box.sh:238: `hevo wait`: hevo has no subcommand `wait`",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "--token-file \"$worker_token_file\" --threads",
                to: "--token-file \"$worker_token_file\" --thread",
                expected: "deploy/local/one-box.sh:227: `hevo-worker` has no option `--thread`",
            },
            Drift {
                path: "deploy/local/one-box.sh",
                from: "--metrics-listen 127.0.0.1:0 --state-dir",
                to: "--metrics-listen --state-dir",
                expected: "`hevo serve --metrics-listen` needs a value, got the option `--state-dir`",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "\"$hevo_worker\" --token-file \"$worker_token_file\" --threads \"$cpus\"",
                to: "\"$hevo_worker\" --token-file \"$worker_token_file\" --threads",
                expected: "deploy/slurm/hevo.sbatch:193: `hevo-worker --threads` needs a value",
            },
            Drift {
                path: "deploy/slurm/hevo.sbatch",
                from: "export HEVO_MASTER\n",
                to: "\n",
                expected: "`hevo-worker` needs `--master`",
            },
            Drift {
                path: "deploy/README.md",
                from: "hevo fetch --master http://127.0.0.1:50051 \"$job\" --out results/",
                to: "hevo fetch --master http://127.0.0.1:50051 \"$job\" --output results/",
                expected: "deploy/README.md:97: `hevo fetch` has no option `--output`",
            },
            Drift {
                path: "deploy/README.md",
                from: "--workers 3 deploy/local/tiny.toml",
                to: "--worker 3 deploy/local/tiny.toml",
                expected: "deploy/README.md:55: `one-box.sh` has no option `--worker`",
            },
            Drift {
                path: "deploy/README.md",
                from: "--wrap 'srun hevo-worker --master",
                to: "--wrap 'srun hevo-worker --masters",
                expected: "deploy/README.md:270: `hevo-worker` has no option `--masters`",
            },
        ],
    );
}
