//! What the engine's tests share: the repository's root, and its files read with their path
//! in any failure.

use hevo_sim_core::ControllerFile;
use std::path::{Path, PathBuf};

/// The repository's root (the engine is `master/engine/`).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A file's text; a failure names the file.
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A shipped controller file from `controllers/`.
pub fn shipped_controller(file: &str) -> ControllerFile {
    let path = repo_root().join("controllers").join(file);
    ControllerFile::from_json_str(&read(&path))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
