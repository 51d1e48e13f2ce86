//! The files of `deploy/` checked, one test binary: each module is one concern of
//! `hevo_tests::deploy` (the Dockerfile, the compose file, the Kubernetes manifests, the
//! scripts, deploy/README.md, the flags every command line uses, the conventions shared across
//! files, the YAML's style), and `probes` starts a live master as the manifests run it. Run one
//! module with `cargo test -p hevo-tests --test deploy MODULE::`.

mod compose;
mod conventions;
mod dockerfile;
mod flags;
mod kubernetes;
mod probes;
mod readme;
mod scripts;
mod yaml;
