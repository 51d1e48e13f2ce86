//! Containers for the live container tests (`tests/tests/live_clusters/container_live_*.rs`): a
//! podman with its own storage, network configuration and settings in a scratch directory (nothing
//! of the machine's podman is used or changed), the image built from deploy/Dockerfile without a
//! container registry, and the containers the tests start, removed when [`Podman`] is dropped.
//!
//! The image: deploy/debian-base.sh assembles the runtime base from this machine's Debian
//! packages, and `podman build` builds the Dockerfile's runtime stage on it with the binaries
//! the tests use as the `build` stage's files (`--build-context build=...`), so everything the
//! runtime stage does (user, state directory, environment, command) is the Dockerfile's.
//!
//! Podman runs as root (rootful) with runc: crun refuses the hybrid cgroup layout of some
//! machines, and the default limits of rootful podman (1048576 files and processes) need
//! CAP_SYS_RESOURCE, which sandboxes drop, so the containers get this process's own limit of
//! open files and 4096 processes (podman's conmon itself runs with at most 32768).
//! Without root, podman, runc or the CNI dnsname plugin (`scripts/install-test-tools.sh
//! containers`), [`Podman::start`] fails the test under CI and skips it loudly elsewhere.

use crate::{Binaries, Scratch, repo_root, tools};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The image the tests build.
pub const IMAGE: &str = "localhost/hevo:e2e";
/// Its base, from deploy/debian-base.sh.
pub const BASE: &str = "localhost/hevo-base:debian";

/// Where Debian's CNI dnsname plugin is: containers find each other by name through it, as
/// compose services do.
const DNSNAME: &str = "/usr/lib/cni/dnsname";

/// A podman of its own, in a scratch directory; every container, volume, network and image it
/// made is removed when dropped.
#[derive(Debug)]
pub struct Podman {
    dir: PathBuf,
    /// The network the containers share.
    pub network: String,
}

/// A hard limit of this process (`Max open files`, ...) from /proc/self/limits.
fn hard_limit(name: &str) -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with(name))?;
    let fields: Vec<&str> = line[name.len()..].split_whitespace().collect();
    fields.get(1)?.parse().ok()
}

impl Podman {
    /// Sets up the podman for `test` in `scratch`/podman, or says why it cannot (see the
    /// module's documentation) and returns `None`.
    pub fn start(test: &str, scratch: &Scratch) -> Option<Podman> {
        if !crate::slurm::is_root() {
            return tools::unavailable(
                test,
                "the container tests run rootful podman, which needs root",
                "Run the tests as root",
            );
        }
        for program in ["podman", "runc", "apt-get", "dpkg-deb"] {
            tools::require(program, test)?;
        }
        if !Path::new(DNSNAME).is_file() {
            return tools::unavailable(
                test,
                &format!(
                    "no CNI dnsname plugin ({DNSNAME}): containers cannot find the master by name"
                ),
                "Install golang-github-containernetworking-plugin-dnsname (`bash scripts/install-test-tools.sh containers`)",
            );
        }
        let dir = scratch.join("podman");
        for sub in ["storage", "run", "tmp", "networks"] {
            std::fs::create_dir_all(dir.join(sub)).expect("a podman directory");
        }
        let files = hard_limit("Max open files").unwrap_or(1024).min(1 << 20);
        let path = |sub: &str| dir.join(sub).to_string_lossy().into_owned();
        std::fs::write(
            dir.join("containers.conf"),
            format!(
                "# Settings of the live container tests' podman (tests/support/podman.rs).\n\
                 [containers]\n\
                 default_ulimits = [\"nofile={files}:{files}\", \"nproc=4096:4096\"]\n\
                 [engine]\n\
                 runtime = \"runc\"\n\
                 cgroup_manager = \"cgroupfs\"\n\
                 events_logger = \"file\"\n\
                 events_logfile_path = \"{events}\"\n\
                 tmp_dir = \"{tmp}\"\n\
                 [network]\n\
                 network_backend = \"cni\"\n\
                 network_config_dir = \"{networks}\"\n",
                events = path("events.log"),
                tmp = path("tmp"),
                networks = path("networks"),
            ),
        )
        .expect("write containers.conf");
        std::fs::write(
            dir.join("storage.conf"),
            format!(
                "# Storage of the live container tests' podman (tests/support/podman.rs).\n\
                 [storage]\n\
                 driver = \"overlay\"\n\
                 graphroot = \"{}\"\n\
                 runroot = \"{}\"\n",
                path("storage"),
                path("run"),
            ),
        )
        .expect("write storage.conf");
        let podman = Podman {
            dir,
            network: format!("hevo-e2e-{}", std::process::id()),
        };
        podman.run(&["network", "create", &podman.network]);
        Some(podman)
    }

    /// `podman` with this podman's settings and storage, for commands of ours and scripts.
    pub fn command(&self) -> Command {
        let mut command = Command::new("podman");
        command
            .env("CONTAINERS_CONF", self.dir.join("containers.conf"))
            .env("CONTAINERS_STORAGE_CONF", self.dir.join("storage.conf"))
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        command
    }

    /// Runs `podman args` to its end.
    pub fn output(&self, args: &[&str]) -> Output {
        self.command()
            .args(args)
            .output()
            .expect("cannot run podman")
    }

    /// Runs `podman args`; its stdout, trimmed. Panics when it fails.
    pub fn run(&self, args: &[&str]) -> String {
        let output = self.output(args);
        assert!(
            output.status.success(),
            "podman {} failed: {}{}",
            args.join(" "),
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
        String::from_utf8_lossy(&output.stdout).trim().to_string()
    }

    /// Builds [`IMAGE`] from deploy/Dockerfile on [`BASE`] with `binaries`, without a registry
    /// (`--pull=never`: every image it uses must already be here).
    pub fn build_image(&self, binaries: &Binaries) {
        let started = Instant::now();
        let script = Command::new("bash")
            .arg(repo_root().join("deploy/debian-base.sh"))
            .arg(BASE)
            .env("CONTAINERS_CONF", self.dir.join("containers.conf"))
            .env("CONTAINERS_STORAGE_CONF", self.dir.join("storage.conf"))
            .env("CONTAINER_ENGINE", "podman")
            .stdin(Stdio::null())
            .output()
            .expect("cannot run deploy/debian-base.sh");
        assert!(
            script.status.success(),
            "deploy/debian-base.sh failed: {}",
            String::from_utf8_lossy(&script.stderr)
        );
        // The `build` stage's files, as the Dockerfile's build stage leaves them in /out.
        let context = self.dir.join("build-stage");
        let bin = context.join("out/bin");
        std::fs::create_dir_all(&bin).expect("out/bin");
        std::fs::create_dir_all(context.join("out/var/lib/hevo")).expect("out/var/lib/hevo");
        for (from, name) in [(&binaries.hevo, "hevo"), (&binaries.worker, "hevo-worker")] {
            std::fs::copy(from, bin.join(name))
                .unwrap_or_else(|e| panic!("cannot copy {}: {e}", from.display()));
        }
        let root = repo_root();
        self.run(&[
            "build",
            "--pull=never",
            "--network=none",
            "--file",
            root.join("deploy/Dockerfile").to_str().unwrap(),
            "--build-arg",
            &format!("RUNTIME_IMAGE={BASE}"),
            "--build-context",
            &format!("build={}", context.display()),
            "--tag",
            IMAGE,
            root.to_str().unwrap(),
        ]);
        eprintln!("built {IMAGE} in {:?}", started.elapsed());
    }

    /// The host's `127.0.0.1:PORT` that a container's `port` is published on.
    pub fn published(&self, container: &str, port: u16) -> String {
        let out = self.run(&["port", container, &format!("{port}/tcp")]);
        out.lines()
            .next()
            .unwrap_or_else(|| panic!("{container}: port {port} is not published"))
            .trim()
            .to_string()
    }

    /// A `podman inspect --format` field of a container.
    pub fn inspect(&self, container: &str, format: &str) -> String {
        self.run(&["inspect", "--format", format, container])
    }

    /// The real, effective, saved and file-system uids of a running container's main process,
    /// as the host sees them.
    pub fn uids(&self, container: &str) -> Vec<u32> {
        let pid = self.inspect(container, "{{.State.Pid}}");
        let status = std::fs::read_to_string(format!("/proc/{pid}/status"))
            .unwrap_or_else(|e| panic!("{container}'s process {pid}: {e}"));
        status
            .lines()
            .find_map(|l| l.strip_prefix("Uid:"))
            .expect("a Uid line")
            .split_whitespace()
            .map(|n| n.parse().expect("a number"))
            .collect()
    }

    /// A container's logs (stdout and stderr).
    pub fn logs(&self, container: &str) -> String {
        let output = self.output(&["logs", container]);
        format!(
            "{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        )
    }

    /// Stops containers with SIGTERM (SIGKILL after `grace`) and returns their exit codes.
    pub fn stop(&self, containers: &[&str], grace: Duration) -> Vec<i64> {
        let seconds = grace.as_secs().to_string();
        let mut args = vec!["stop", "--time", &seconds];
        args.extend_from_slice(containers);
        self.run(&args);
        containers
            .iter()
            .map(|c| {
                self.inspect(c, "{{.State.ExitCode}}")
                    .parse()
                    .expect("an exit code")
            })
            .collect()
    }
}

impl Drop for Podman {
    fn drop(&mut self) {
        let _ = self.output(&["rm", "--all", "--force", "--time", "5"]);
        let _ = self.output(&["volume", "rm", "--all", "--force"]);
        let _ = self.output(&["network", "rm", "--force", &self.network]);
        // Unmounts and deletes the layers; the directory goes with the scratch directory.
        let _ = self.output(&["rmi", "--all", "--force"]);
    }
}

/// Waits until `check` succeeds, for at most `timeout`; the last failure on timeout.
pub fn wait_until<T>(
    timeout: Duration,
    mut check: impl FnMut() -> Result<T, String>,
) -> Result<T, String> {
    let deadline = Instant::now() + timeout;
    loop {
        match check() {
            Ok(value) => return Ok(value),
            Err(e) if Instant::now() >= deadline => return Err(e),
            Err(_) => std::thread::sleep(Duration::from_millis(250)),
        }
    }
}
