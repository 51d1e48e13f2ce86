//! Files that must survive a kill at any instant: every output is written to a temporary file
//! in the same directory, flushed to disk, and renamed over the old one, so a reader (or a
//! resumed run) sees either the old or the new content, never a torn one.

use serde::Serialize;
pub use serde::de::DeserializeOwned;
use std::io::Write;
use std::path::{Path, PathBuf};

/// What marks a temporary file: `write_atomic` writes `<dir>/.<file>.tmp-<pid>` first.
const TEMPORARY_INFIX: &str = ".tmp-";

/// Writes `bytes` to `path` atomically, creating the parent directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(
        ".{file_name}{TEMPORARY_INFIX}{}",
        std::process::id()
    ));
    {
        let mut file = std::fs::File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()?;
    }
    std::fs::rename(&tmp, path)?;
    // The rename is durable only once the directory entry is on disk too.
    if let Ok(dir_handle) = std::fs::File::open(dir) {
        let _ = dir_handle.sync_all();
    }
    Ok(())
}

/// Whether `name` is a temporary file of `write_atomic`: `.<file>.tmp-<pid>`.
fn is_temporary(name: &str) -> bool {
    name.starts_with('.')
        && name
            .rsplit_once(TEMPORARY_INFIX)
            .is_some_and(|(_, pid)| !pid.is_empty() && pid.bytes().all(|b| b.is_ascii_digit()))
}

/// Removes the temporary files that `write_atomic` leaves in `dir` when its process is killed
/// between creating one and renaming it, and returns how many it removed. A kill costs time,
/// not results, and should not leave litter either. Call it only where this process is the
/// directory's one writer (the directory of a run or node it is about to continue): another
/// live writer's temporary would be removed from under it. A missing directory has none.
pub fn remove_leftover_temporaries(dir: &Path) -> std::io::Result<usize> {
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(0),
        Err(e) => return Err(e),
    };
    let mut n_removed = 0;
    for entry in entries {
        let entry = entry?;
        if entry.file_type()?.is_file() && is_temporary(&entry.file_name().to_string_lossy()) {
            std::fs::remove_file(entry.path())?;
            n_removed += 1;
        }
    }
    Ok(n_removed)
}

/// Writes a value as pretty JSON, atomically.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> std::io::Result<()> {
    let mut text = serde_json::to_string_pretty(value).map_err(std::io::Error::other)?;
    text.push('\n');
    write_atomic(path, text.as_bytes())
}

/// A JSON file that exists but cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadJsonError {
    /// Reading failed.
    #[error("{path}: cannot read: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
    /// It is not the JSON expected.
    #[error("{path}: malformed JSON: {cause}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// Where and what.
        cause: serde_json::Error,
    },
}

/// Reads a JSON file; `Ok(None)` when it does not exist, an error when it is unreadable or
/// malformed (never silently ignored: a corrupt checkpoint must be looked at).
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<Option<T>, ReadJsonError> {
    read_json_with(path, |text| serde_json::from_str(text))
}

/// [`read_json`] with a parser of its own (a format read in more than one way).
pub fn read_json_with<T>(
    path: &Path,
    parse: impl FnOnce(&str) -> Result<T, serde_json::Error>,
) -> Result<Option<T>, ReadJsonError> {
    match std::fs::read_to_string(path) {
        Ok(text) => parse(&text)
            .map(Some)
            .map_err(|cause| ReadJsonError::Malformed {
                path: path.to_path_buf(),
                cause,
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(cause) => Err(ReadJsonError::Io {
            path: path.to_path_buf(),
            cause,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_killed_writers_temporaries_are_removed_and_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            ".fitness.csv.tmp-4277",
            ".checkpoint.json.tmp-12",
            "fitness.csv",
            ".hidden",
            ".notes.tmp-abc",
        ] {
            std::fs::write(dir.path().join(name), "x").unwrap();
        }
        assert_eq!(remove_leftover_temporaries(dir.path()).unwrap(), 2);
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        assert_eq!(left, [".hidden", ".notes.tmp-abc", "fitness.csv"]);
        assert_eq!(
            remove_leftover_temporaries(&dir.path().join("missing")).unwrap(),
            0
        );
    }

    #[test]
    fn atomic_writes_replace_and_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a/b/c.json");
        write_json_atomic(&path, &vec![1, 2, 3]).unwrap();
        write_json_atomic(&path, &vec![4]).unwrap();
        assert_eq!(read_json::<Vec<i32>>(&path).unwrap(), Some(vec![4]));
        assert_eq!(
            read_json::<Vec<i32>>(&dir.path().join("missing.json")).unwrap(),
            None
        );
        std::fs::write(&path, "{").unwrap();
        let error = read_json::<Vec<i32>>(&path).unwrap_err().to_string();
        assert!(
            error.starts_with(&format!("{}: malformed JSON", path.display())),
            "{error}"
        );
        // No temporary files are left behind.
        let leftovers: Vec<_> = std::fs::read_dir(path.parent().unwrap()).unwrap().collect();
        assert_eq!(leftovers.len(), 1);
    }
}
