//! The repository's own rules, one test binary: the crate layers of ARCHITECTURE.md
//! (`layers`), the integration tests kept to one binary per area (`test_targets`) and the
//! binaries users build one at a time sharing one build (`shared_builds`).

mod layers;
mod shared_builds;
mod test_targets;
