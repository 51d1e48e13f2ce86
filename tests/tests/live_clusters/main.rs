//! The real cluster engines on this machine, one test binary: a one-node SLURM cluster
//! (`slurm_live_job`, `slurm_live_resume`, with `hevo_tests::slurm`) and podman running the
//! image built from deploy/Dockerfile (`container_live_job`, `container_live_probes`, with
//! `hevo_tests::podman`). They need root and the engines' packages; without them each test
//! fails under CI and is skipped, loudly, elsewhere. The tests take turns
//! (`hevo_tests::cluster_turn`): two clusters at once would share this machine's daemons,
//! bridges and two cores. Run one module with `cargo test -p hevo-tests --test live_clusters
//! MODULE::`.

mod container_live_job;
mod container_live_probes;
mod slurm_live_job;
mod slurm_live_resume;
