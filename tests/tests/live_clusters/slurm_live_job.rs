//! deploy/slurm/hevo.sbatch on a real SLURM cluster (one node on loopback, started by
//! deploy/slurm/local-cluster.sh): `sbatch` queues the script for the tiny experiment, slurmd
//! runs it, its `srun` starts two worker tasks, and the results it fetches are byte for byte
//! those of `hevo run` of the same experiment and seed on this machine.
//!
//! Needs root and Debian's slurm-wlm and munge (`scripts/install-test-tools.sh slurm`);
//! without them the test fails under CI and is skipped, loudly, elsewhere. The binaries come
//! from `hevo_tests::binaries` (`HEVO_TEST_BIN_DIR` or a cargo build).

use hevo_tests::slurm::{Cluster, ONE_NODE};
use hevo_tests::{
    Scratch, assert_same_results, binaries, cluster_turn, kill_processes_mentioning,
    processes_mentioning, repo_root, run_locally, work_done,
};
use std::path::Path;
use std::time::Duration;

const TEST: &str = "live_clusters::slurm_live_job";

#[test]
fn sbatch_runs_the_tiny_experiment_to_the_local_results() {
    let _turn = cluster_turn();
    let scratch = Scratch::new("slurm-live-job");
    let Some(cluster) = Cluster::start(TEST, &scratch, 2) else {
        return;
    };
    let experiment = repo_root().join("deploy/local/tiny.toml");
    let experiment = experiment.to_str().unwrap();
    let bin_dir = binaries().hevo.parent().unwrap().to_str().unwrap();

    let reference = scratch.join("local");
    run_locally(Path::new(experiment), &reference, &[]);

    let work = scratch.join("job");
    std::fs::create_dir_all(&work).unwrap();
    let script = repo_root().join("deploy/slurm/hevo.sbatch");
    let mut args: Vec<&str> = ONE_NODE.to_vec();
    args.extend([
        script.to_str().unwrap(),
        "--bin-dir",
        bin_dir,
        "--state-dir",
        "state",
        "--out",
        "results",
        experiment,
    ]);
    let job = cluster.sbatch(&work, &args);
    let (state, exit) = cluster.wait_until_done(&job, Duration::from_secs(600));
    let job_log = std::fs::read_to_string(work.join(format!("hevo-{job}.out"))).unwrap_or_default();
    let leftovers = processes_mentioning(work.to_str().unwrap());
    kill_processes_mentioning(work.to_str().unwrap());
    assert_eq!(
        (state.as_str(), exit.as_str()),
        ("COMPLETED", "0:0"),
        "job {job} did not complete; its log:\n{job_log}\n{}",
        cluster.daemon_logs()
    );
    assert!(
        leftovers.is_empty(),
        "processes outlived job {job}:\n{}",
        leftovers.join("\n")
    );
    assert!(
        job_log.contains("starting 2 workers with 1 threads each"),
        "the job did not start its workers on the allocation's tasks:\n{job_log}"
    );

    // srun ran one worker per task, and both took part.
    for task in 0..2 {
        let log = std::fs::read_to_string(work.join(format!("state/worker-{task}.log")))
            .unwrap_or_else(|e| panic!("worker-{task}.log: {e}\n{job_log}"));
        let (batches, evaluations) = work_done(&log)
            .unwrap_or_else(|| panic!("worker task {task} did not stop cleanly:\n{log}"));
        eprintln!("worker task {task}: {batches} batches, {evaluations} evaluations");
        assert!(batches > 0, "worker task {task} did no work:\n{log}");
    }
    assert_same_results(&reference, &work.join("results"), None);
}
