//! Helpers for hevo's end-to-end tests, which drive the real binaries: the `hevo` and
//! `hevo-worker` executables built once per test process (`cargo build`, in the profile the
//! tests themselves were built in, or taken from `HEVO_TEST_BIN_DIR`), child processes that
//! are killed when their guard is dropped (so a failing test leaves nothing running), a master
//! started on 127.0.0.1 port 0 whose address is read from its first line of output, `hevo`
//! commands that must succeed (a local run, a fetch), the turn the cluster tests take, scratch
//! directories, a plain HTTP GET for the metrics endpoint, and a byte-for-byte comparison of two
//! result directories in the layout `hevo run --out` writes.
//!
//! The tests are one binary per area (`tests/tests/AREA/main.rs`, one module per behaviour), so
//! tests of different modules share a process: what a test holds process-wide (a scratch
//! directory, a port, a cluster) must not collide with another module's.
//!
//! [`deploy`] parses and checks the files of `deploy/` for the `deploy` tests; [`tools`]
//! finds the external tools (shellcheck, ...) that `scripts/install-test-tools.sh` installs.

pub mod deploy;
pub mod tools;

#[path = "support/service.rs"]
pub mod service;

#[path = "support/browser.rs"]
pub mod browser;

#[path = "support/dashboard.rs"]
pub mod dashboard;

#[path = "support/slurm.rs"]
pub mod slurm;

#[path = "support/podman.rs"]
pub mod podman;

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// The repository's root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tests/ has a parent")
        .to_path_buf()
}

/// The two executables.
#[derive(Debug, Clone)]
pub struct Binaries {
    /// `hevo`.
    pub hevo: PathBuf,
    /// `hevo-worker`.
    pub worker: PathBuf,
}

/// The binaries, built once per test process in the tests' own profile. `cargo test` builds
/// them in the dev profile, which reuses what the test build already compiled (dependencies
/// and sim-core are optimised there) and saves CI a separate release build of the workspace;
/// `cargo test --release`, as the benchmarks are run, builds release binaries.
pub fn binaries() -> &'static Binaries {
    static BINARIES: OnceLock<Binaries> = OnceLock::new();
    BINARIES.get_or_init(|| {
        if let Some(dir) = std::env::var_os("HEVO_TEST_BIN_DIR") {
            let dir = PathBuf::from(dir);
            return Binaries {
                hevo: dir.join("hevo"),
                worker: dir.join("hevo-worker"),
            };
        }
        let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
        let mut args = vec![
            "build",
            "-p",
            "hevo-cli",
            "-p",
            "hevo-worker",
            "--message-format=json",
        ];
        if !cfg!(debug_assertions) {
            args.push("--release");
        }
        let mut command = Command::new(cargo);
        command
            .current_dir(repo_root())
            .args(&args)
            .stderr(Stdio::inherit());
        // The variables cargo sets for this test process describe hevo-tests, not the build:
        // build scripts that watch one (ring's watches CARGO_MANIFEST_DIR) would otherwise
        // rerun, and their crates rebuild, every time `cargo test` and this build alternate.
        for (name, _) in std::env::vars_os() {
            let name = name.to_string_lossy();
            if name.starts_with("CARGO_PKG_")
                || [
                    "CARGO_MANIFEST_DIR",
                    "CARGO_MANIFEST_PATH",
                    "CARGO_CRATE_NAME",
                    "CARGO_PRIMARY_PACKAGE",
                ]
                .contains(&name.as_ref())
            {
                command.env_remove(name.as_ref());
            }
        }
        let output = command.output().expect("cannot run cargo");
        assert!(output.status.success(), "cargo {} failed", args.join(" "));
        let (mut hevo, mut worker) = (None, None);
        for line in String::from_utf8_lossy(&output.stdout).lines() {
            let Ok(message) = serde_json::from_str::<serde_json::Value>(line) else {
                continue;
            };
            let Some(executable) = message.get("executable").and_then(|e| e.as_str()) else {
                continue;
            };
            let path = PathBuf::from(executable);
            match path.file_name().and_then(|n| n.to_str()) {
                Some("hevo") => hevo = Some(path),
                Some("hevo-worker") => worker = Some(path),
                _ => {}
            }
        }
        Binaries {
            hevo: hevo.expect("cargo built no `hevo`"),
            worker: worker.expect("cargo built no `hevo-worker`"),
        }
    })
}

/// A directory under the system's temporary directory, removed when dropped.
#[derive(Debug)]
pub struct Scratch {
    path: PathBuf,
}

impl Scratch {
    /// A fresh, empty directory, named after `name`, the process and a count of the process's
    /// scratch directories: the tests of one binary share its process, so no two of them can
    /// be given the same directory.
    pub fn new(name: &str) -> Scratch {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let count = COUNT.fetch_add(1, Ordering::Relaxed);
        let path =
            std::env::temp_dir().join(format!("hevo-e2e-{name}-{}-{count}", std::process::id()));
        let _ = std::fs::remove_dir_all(&path);
        std::fs::create_dir_all(&path).expect("cannot create a scratch directory");
        Scratch { path }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A path inside it.
    pub fn join(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        // Kept after a failure, to look at.
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.path);
        }
    }
}

/// A child process that is killed (SIGKILL) when dropped.
#[derive(Debug)]
pub struct Proc {
    /// For messages.
    pub name: String,
    child: Child,
}

impl Proc {
    /// Starts a command with stdin closed; stdout/stderr as configured by the caller.
    pub fn spawn(name: &str, command: &mut Command) -> Proc {
        let child = command
            .stdin(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        Proc {
            name: name.to_string(),
            child,
        }
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// The child, for its pipes.
    pub fn child(&mut self) -> &mut Child {
        &mut self.child
    }

    /// SIGKILL, and reaps it.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// Sends a signal by name (`TERM`, `INT`) with the system's `kill`.
    pub fn signal(&self, signal: &str) {
        let status = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(self.id().to_string())
            .status()
            .expect("cannot run kill");
        assert!(status.success(), "kill -{signal} {} failed", self.id());
    }

    /// Waits up to `timeout` for the process to exit.
    pub fn wait_timeout(&mut self, timeout: Duration) -> Option<ExitStatus> {
        let until = Instant::now() + timeout;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            if Instant::now() >= until {
                return None;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Forwards a pipe's lines to a channel from a thread (so reading never blocks a test).
pub fn lines_of(pipe: impl std::io::Read + Send + 'static) -> mpsc::Receiver<String> {
    let (sender, receiver) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines() {
            let Ok(line) = line else { break };
            if sender.send(line).is_err() {
                break;
            }
        }
    });
    receiver
}

/// Waits for a line that satisfies `wanted`; the lines seen are returned on timeout for the
/// failure message.
pub fn wait_for_line(
    lines: &mpsc::Receiver<String>,
    timeout: Duration,
    wanted: impl Fn(&str) -> bool,
) -> Result<String, Vec<String>> {
    let until = Instant::now() + timeout;
    let mut seen = Vec::new();
    loop {
        let left = until.saturating_duration_since(Instant::now());
        match lines.recv_timeout(left) {
            Ok(line) if wanted(&line) => return Ok(line),
            Ok(line) => seen.push(line),
            Err(_) => return Err(seen),
        }
    }
}

/// A running `hevo serve`.
#[derive(Debug)]
pub struct Master {
    /// The process.
    pub proc: Proc,
    /// `http://127.0.0.1:PORT` (or `https://localhost:PORT` with TLS).
    pub url: String,
    /// `127.0.0.1:PORT` of the metrics endpoint, when enabled.
    pub metrics: Option<String>,
    /// `http://127.0.0.1:PORT` of the dashboard, when enabled (`--http-listen`).
    pub dashboard: Option<String>,
}

/// Starts a master on 127.0.0.1 port 0 with `args` after `serve --listen 127.0.0.1:0`, its
/// logs in `log`; returns once it printed its address.
pub fn start_master(args: &[&str], log: &Path) -> Master {
    start_master_listening("127.0.0.1:0", args, log)
}

/// [`start_master`] on a given address (a master restarted where its workers look for it).
pub fn start_master_listening(listen: &str, args: &[&str], log: &Path) -> Master {
    start_master_with(Command::new(&binaries().hevo), listen, args, log)
}

/// [`start_master`] with its open-file limit, soft and hard, held to `open_files` (by
/// util-linux's `prlimit`), as a small machine or container would hold it.
pub fn start_master_with_open_files(open_files: u64, args: &[&str], log: &Path) -> Master {
    let mut command = Command::new("prlimit");
    command
        .arg(format!("--nofile={open_files}:{open_files}"))
        .arg("--")
        .arg(&binaries().hevo);
    start_master_with(command, "127.0.0.1:0", args, log)
}

/// Starts `command` (the `hevo` binary, or a command that runs it) with `serve --listen
/// LISTEN ARGS`.
fn start_master_with(mut command: Command, listen: &str, args: &[&str], log: &Path) -> Master {
    let stderr = std::fs::File::create(log).expect("cannot create the master's log");
    let mut proc = Proc::spawn(
        "hevo serve",
        command
            .args(["serve", "--listen", listen])
            .args(args)
            .env_remove("HEVO_TOKEN")
            .stdout(Stdio::piped())
            .stderr(stderr),
    );
    let lines = lines_of(proc.child().stdout.take().expect("piped stdout"));
    let first = lines
        .recv_timeout(Duration::from_secs(20))
        .unwrap_or_else(|_| {
            panic!(
                "the master printed no address; its log:\n{}",
                std::fs::read_to_string(log).unwrap_or_default()
            )
        });
    let address = first
        .strip_prefix("listening on ")
        .unwrap_or_else(|| panic!("unexpected first line: {first}"))
        .to_string();
    let metrics = args.contains(&"--metrics-listen").then(|| {
        let line = lines
            .recv_timeout(Duration::from_secs(5))
            .expect("no metrics line");
        line.strip_prefix("metrics on ")
            .unwrap_or_else(|| panic!("unexpected second line: {line}"))
            .to_string()
    });
    let dashboard = args.contains(&"--http-listen").then(|| {
        let line = lines
            .recv_timeout(Duration::from_secs(5))
            .expect("no dashboard line");
        line.strip_prefix("dashboard on ")
            .unwrap_or_else(|| panic!("unexpected dashboard line: {line}"))
            .to_string()
    });
    let tls = args.contains(&"--tls-cert");
    let url = if tls {
        format!(
            "https://localhost:{}",
            address.rsplit(':').next().unwrap_or_default()
        )
    } else {
        format!("http://{address}")
    };
    Master {
        proc,
        url,
        metrics,
        dashboard,
    }
}

/// Starts a `hevo-worker` on `url` with one thread and the given extra arguments; its logs go
/// to `log`.
pub fn start_worker(url: &str, token: &str, name: &str, extra: &[&str], log: &Path) -> Proc {
    start_worker_with_threads(url, token, name, 1, extra, log)
}

/// Starts a `hevo-worker` on `url` with `threads` evaluation threads.
pub fn start_worker_with_threads(
    url: &str,
    token: &str,
    name: &str,
    threads: usize,
    extra: &[&str],
    log: &Path,
) -> Proc {
    let stderr = std::fs::File::create(log).expect("cannot create a worker's log");
    let threads = threads.to_string();
    Proc::spawn(
        name,
        Command::new(&binaries().worker)
            .args(["--master", url, "--threads", &threads, "--name", name])
            .args(extra)
            .env("HEVO_TOKEN", token)
            .env_remove("HEVO_MASTER")
            .stdout(Stdio::null())
            .stderr(stderr),
    )
}

/// Runs `hevo` with `args` (and `HEVO_TOKEN` = `token` when given) to completion, at most
/// `timeout`.
pub fn hevo(args: &[&str], token: Option<&str>, timeout: Duration) -> Output {
    let mut command = Command::new(&binaries().hevo);
    command
        .args(args)
        .env_remove("HEVO_TOKEN")
        .env_remove("HEVO_MASTER")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(token) = token {
        command.env("HEVO_TOKEN", token);
    }
    let mut proc = Proc::spawn("hevo", &mut command);
    let stdout = lines_of(proc.child().stdout.take().expect("piped"));
    let stderr = lines_of(proc.child().stderr.take().expect("piped"));
    let status = proc
        .wait_timeout(timeout)
        .unwrap_or_else(|| panic!("hevo {} did not finish within {timeout:?}", args.join(" ")));
    // The reader threads end with the pipes.
    let collect = |lines: mpsc::Receiver<String>| {
        lines
            .iter()
            .map(|l| l + "\n")
            .collect::<String>()
            .into_bytes()
    };
    Output {
        status,
        stdout: collect(stdout),
        stderr: collect(stderr),
    }
}

/// [`hevo`], which must succeed: otherwise the test fails with its stdout and stderr.
pub fn hevo_ok(args: &[&str], token: Option<&str>, timeout: Duration) -> Output {
    let output = hevo(args, token, timeout);
    assert!(
        output.status.success(),
        "hevo {} failed ({}):\n{}{}",
        args.join(" "),
        output.status,
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// `hevo run FILE --out OUT EXTRA...` on this machine, which must succeed: the results a job
/// of the same experiment and seed must reproduce byte for byte. Bounded at ten minutes.
pub fn run_locally(file: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "run",
        file.to_str().expect("a UTF-8 path"),
        "--out",
        out.to_str().expect("a UTF-8 path"),
    ];
    args.extend_from_slice(extra);
    hevo_ok(&args, None, Duration::from_secs(600));
}

/// `hevo fetch --master URL JOB --out OUT EXTRA...` with the client token `token`, which must
/// succeed.
pub fn fetch(url: &str, token: &str, job: &str, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "fetch",
        "--master",
        url,
        job,
        "--out",
        out.to_str().expect("a UTF-8 path"),
    ];
    args.extend_from_slice(extra);
    hevo_ok(&args, Some(token), Duration::from_secs(60));
}

/// A turn for a test that runs a cluster (a master, two or three workers and the client
/// commands, or a script that starts them): such tests take turns across the whole test
/// binary, since two cores running two clusters at once make kill timings and time limits
/// meaningless. Held until the guard is dropped; a test that failed holding it passes it on.
pub fn cluster_turn() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    TURN.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A plain HTTP/1.1 GET (the metrics endpoint): the whole response, status line, headers and
/// body. The connection is closed after one request, so the response ends where the stream does.
pub fn http_get(address: &str, path: &str) -> String {
    let mut stream = std::net::TcpStream::connect(address)
        .unwrap_or_else(|e| panic!("cannot connect to {address}: {e}"));
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .expect("a read timeout can be set");
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {address}\r\nConnection: close\r\n\r\n"
    )
    .unwrap_or_else(|e| panic!("cannot send GET {path} to {address}: {e}"));
    let mut response = String::new();
    stream
        .read_to_string(&mut response)
        .unwrap_or_else(|e| panic!("cannot read the answer to GET {path} from {address}: {e}"));
    response
}

/// Every result file under `dir` in the layout `hevo run --out` writes (checkpoints excluded:
/// they are the run driver's working state, not results), as sorted relative paths.
pub fn result_files(dir: &Path) -> Vec<String> {
    fn walk(root: &Path, dir: &Path, found: &mut Vec<String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                walk(root, &path, found);
            } else if path.file_name().is_some_and(|n| n != "checkpoint.json") {
                found.push(
                    path.strip_prefix(root)
                        .expect("below root")
                        .to_string_lossy()
                        .into_owned(),
                );
            }
        }
    }
    let mut found = Vec::new();
    walk(dir, dir, &mut found);
    found.sort();
    found
}

/// Asserts that two result directories hold the same files with the same bytes (only those of
/// `nodes`, when given).
pub fn assert_same_results(expected: &Path, found: &Path, nodes: Option<&[&str]>) {
    let keep = |files: Vec<String>| -> Vec<String> {
        files
            .into_iter()
            .filter(|f| {
                nodes.is_none_or(|nodes| nodes.iter().any(|n| f.starts_with(&format!("{n}/"))))
            })
            .collect()
    };
    let (a, b) = (keep(result_files(expected)), keep(result_files(found)));
    assert!(!a.is_empty(), "no results under {}", expected.display());
    assert_eq!(
        a,
        b,
        "different result files in {} and {}",
        expected.display(),
        found.display()
    );
    for file in &a {
        let (x, y) = (
            std::fs::read(expected.join(file)).expect("readable"),
            std::fs::read(found.join(file)).expect("readable"),
        );
        assert!(
            x == y,
            "{file} differs between {} and {}",
            expected.display(),
            found.display()
        );
    }
}

/// What a worker's log says it did: the `worker stopped` line it writes when it stops cleanly,
/// as (batches, evaluations) accepted by the master.
pub fn work_done(log: &str) -> Option<(u64, u64)> {
    let line = log.lines().rev().find(|l| l.contains("worker stopped"))?;
    let field = |name: &str| -> Option<u64> {
        let start = line.find(&format!("{name}="))? + name.len() + 1;
        let digits: String = line[start..]
            .chars()
            .take_while(char::is_ascii_digit)
            .collect();
        digits.parse().ok()
    };
    Some((field("batches")?, field("evaluations")?))
}

/// Processes whose command line mentions `needle` (the scratch directory of one test), as
/// `PID: COMMAND LINE`.
pub fn processes_mentioning(needle: &str) -> Vec<String> {
    let mut found = Vec::new();
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return found;
    };
    for entry in entries.flatten() {
        if !entry
            .file_name()
            .to_string_lossy()
            .chars()
            .all(|c| c.is_ascii_digit())
        {
            continue;
        }
        let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) else {
            continue;
        };
        let cmdline = String::from_utf8_lossy(&cmdline).replace('\0', " ");
        if cmdline.contains(needle) {
            found.push(format!(
                "{}: {cmdline}",
                entry.file_name().to_string_lossy()
            ));
        }
    }
    found
}

/// SIGKILL to every process [`processes_mentioning`] `needle` finds (what a failed test left).
pub fn kill_processes_mentioning(needle: &str) {
    for line in processes_mentioning(needle) {
        let pid = line.split(':').next().unwrap_or_default();
        let _ = Command::new("kill").args(["-KILL", pid]).status();
    }
}
