//! External tools some tests run (shellcheck, yamllint, kubernetes-validate, ...), installed by
//! `scripts/install-test-tools.sh` into `.tools/` at the repository root (or the directory in
//! `HEVO_TEST_TOOLS_DIR`), from package registries only.
//!
//! A test that needs a tool asks [`require`]: the tool from `.tools/bin`, else from `PATH`. When
//! it is in neither place the test fails if the environment variable `CI` is set (CI installs
//! the tools first, so a missing one is a broken install, not a reason to pass), and otherwise
//! says so loudly on stderr and returns early, counted as skipped.

use crate::repo_root;
use std::io::Write;
use std::path::{Path, PathBuf};

/// How to install the tools.
pub const INSTALL_COMMAND: &str = "bash scripts/install-test-tools.sh";

/// Where the install script puts the tools.
pub fn tools_dir() -> PathBuf {
    std::env::var_os("HEVO_TEST_TOOLS_DIR")
        .filter(|d| !d.is_empty())
        .map_or_else(|| repo_root().join(".tools"), PathBuf::from)
}

/// Whether this is a CI run: `CI` set to anything but empty, `0` or `false`.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false"))
}

fn executable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::metadata(path).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
}

/// The tool `name` from the tools directory's `bin/`, else from `PATH`.
pub fn find(name: &str) -> Option<PathBuf> {
    let local = tools_dir().join("bin").join(name);
    if executable(&local) {
        return Some(local);
    }
    std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())
        .map(|dir| dir.join(name))
        .find(|path| executable(path))
}

/// The tool `name` for the test `test`; see the module's documentation for what happens when
/// it is missing. Use as `let Some(tool) = tools::require("x", "my_test") else { return };`.
pub fn require(name: &str, test: &str) -> Option<PathBuf> {
    if let Some(path) = find(name) {
        return Some(path);
    }
    let place = tools_dir().join("bin");
    unavailable(
        test,
        &format!(
            "`{name}` is not installed (not in {} nor on PATH)",
            place.display()
        ),
        &format!("Install the test tools with `{INSTALL_COMMAND}`"),
    )
}

/// Reports that `test` cannot run because of `what` (`fix` says what to do about it): under CI
/// a failure (a panic), elsewhere a loud message on stderr and `None`, for the test to return
/// early, counted as skipped. For what [`require`] cannot find: root, a daemon's package.
pub fn unavailable<T>(test: &str, what: &str, fix: &str) -> Option<T> {
    if in_ci() {
        panic!(
            "{test}: {what}, and CI is set: CI must be able to run it ({fix}; CI runs \
             `{INSTALL_COMMAND}` before the tests)"
        );
    }
    // Straight to the process's stderr: libtest captures `eprintln!` of a passing test, and a
    // skipped test passes (libtest has no way to mark it skipped at run time).
    let bar = "!".repeat(100);
    let message = format!(
        "\n{bar}\n!!! SKIPPED {test}: {what}.\n!!! {fix}. With CI set, this is a failure.\n{bar}\n"
    );
    let _ = std::io::stderr().lock().write_all(message.as_bytes());
    None
}

/// What a tool printed, stdout and stderr together, and whether it succeeded.
#[derive(Debug)]
pub struct Run {
    /// Exit status 0.
    pub success: bool,
    /// stdout, then stderr.
    pub output: String,
}

/// Runs `tool` with `args` in `dir`.
pub fn run<S: AsRef<std::ffi::OsStr>>(tool: &Path, args: &[S], dir: &Path) -> Run {
    let output = std::process::Command::new(tool)
        .args(args)
        .current_dir(dir)
        .stdin(std::process::Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", tool.display()));
    Run {
        success: output.status.success(),
        output: format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        ),
    }
}
