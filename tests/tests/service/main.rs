//! The evaluation service end to end, one test binary: the real `hevo` and `hevo-worker` on
//! 127.0.0.1. Each module is one behaviour: a job on a master and workers gives a local run's
//! results (`distributed`), deploy/local/one-box.sh runs for real (`one_box`), the master
//! against hostile or unlucky clients and workers (`connections`, `delete`, `leases`,
//! `limits`, `roles`, `store`, `tls_plain`), a batch of genomes evaluated on the workers for a
//! client (`remote_evaluate`), and the chaos and submit-storm benchmarks (`chaos`, ignored). The
//! helpers they share are the `hevo_tests` library's. Run one module with `cargo test -p
//! hevo-tests --test service MODULE::`.

mod chaos;
mod connections;
mod delete;
mod distributed;
mod leases;
mod limits;
mod one_box;
mod remote_evaluate;
mod roles;
mod store;
mod tls_plain;
