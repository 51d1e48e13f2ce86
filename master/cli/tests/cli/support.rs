//! What the command line's tests share: the `hevo` binary under test, run in the repository's
//! root, a command that must succeed (its output in the failure message), the repository's
//! root and the small experiment of `tests/fixtures/`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The binary under test.
pub const HEVO: &str = env!("CARGO_BIN_EXE_hevo");

/// A small but real experiment: an exit-room primitive (1000-cycle samples make each
/// generation take long enough to kill the process in the middle of a run).
pub const SMALL: &str = include_str!("../../../../tests/fixtures/exit_room_small.toml");

/// The repository's root (the command line is `master/cli/`).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Writes `text` as `small.toml` in `dir`; its path.
pub fn write_experiment(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("small.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// `hevo` with `args`, not yet started: in the repository's root (so `scenarios/examples/...`
/// names the shipped files), logging warnings only.
pub fn hevo_command(args: &[&str]) -> Command {
    let mut command = Command::new(HEVO);
    command
        .args(args)
        .current_dir(repo_root())
        .env("RUST_LOG", "warn");
    command
}

/// `hevo` with `args`, run to its end.
pub fn hevo(args: &[&str]) -> Output {
    hevo_command(args).output().expect("hevo runs")
}

/// `hevo` with `args`, which must succeed.
pub fn hevo_ok(args: &[&str]) -> Output {
    succeeded(&format!("hevo {}", args.join(" ")), hevo(args))
}

/// `output` of the command `what`, which must have succeeded: otherwise the test fails with
/// its stdout and stderr.
pub fn succeeded(what: &str, output: Output) -> Output {
    assert!(
        output.status.success(),
        "`{what}` failed ({}):\n{}{}",
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}
