//! The repository's own rules, one test binary: the crate layers of ARCHITECTURE.md
//! (`layers`) and the integration tests kept to one binary per area (`test_targets`).

mod layers;
mod test_targets;
