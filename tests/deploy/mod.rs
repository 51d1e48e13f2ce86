//! What the `deploy` tests share: the files of `deploy/` read into memory, parsed (the
//! Dockerfile, the compose file, the Kubernetes manifests and kustomizations, the SLURM and
//! one-box scripts, the shell blocks of deploy/README.md), and the facts gathered from them:
//! every `hevo` and `hevo-worker` command line, environment variable, port, state directory,
//! uid and health probe they use.
//!
//! [`Analysis::of`] parses all files in one pass (the compose file and the manifests fall back
//! on the Dockerfile's `CMD` and `ENV`, so the order matters) and files each problem it finds
//! under the [`Concern`] of the test that reports it: one module of the `deploy` test binary
//! per concern (`tests/tests/deploy/*.rs`). What needs the binaries' `--help` is checked
//! separately, by [`check_flags`], and what is compared across files by [`check_conventions`].
//!
//! Each test works on a [`DeployFiles`], which the drift tests change in memory (a wrong flag,
//! a wrong port) to show that the check they cover reports it.

pub mod compose;
pub mod dockerfile;
pub mod help;
pub mod invocation;
pub mod kubernetes;
pub mod readme;
pub mod scripts;
pub mod shell;
pub mod yaml;

use crate::repo_root;
use help::Helps;
use invocation::Invocation;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Display;
use std::path::Path;

/// The files of deploy/, by path relative to the repository root (`deploy/compose.yaml`).
#[derive(Debug, Clone)]
pub struct DeployFiles {
    /// Path -> text.
    pub files: BTreeMap<String, String>,
}

impl DeployFiles {
    /// Every text file under deploy/.
    pub fn load() -> DeployFiles {
        let root = repo_root();
        let mut files = BTreeMap::new();
        let mut stack = vec![root.join("deploy")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).expect("read deploy/") {
                let path = entry.expect("a directory entry").path();
                if path.is_dir() {
                    stack.push(path);
                } else if let Ok(text) = std::fs::read_to_string(&path) {
                    let relative = path
                        .strip_prefix(&root)
                        .expect("below the repository root")
                        .to_string_lossy()
                        .replace('\\', "/");
                    files.insert(relative, text);
                }
            }
        }
        DeployFiles { files }
    }

    /// The text of `path`; panics when there is no such file.
    pub fn get(&self, path: &str) -> &str {
        self.files
            .get(path)
            .map_or_else(|| panic!("{path} is missing"), String::as_str)
    }

    /// Replaces the first `from` in `path` by `to`; panics when `from` is not there, so that a
    /// drift case cannot silently test nothing.
    pub fn replace(&mut self, path: &str, from: &str, to: &str) {
        let text = self
            .files
            .get_mut(path)
            .unwrap_or_else(|| panic!("{path} is missing"));
        assert!(text.contains(from), "{path} does not contain {from:?}");
        *text = text.replacen(from, to, 1);
    }

    /// Writes the files below `dir` (as `dir/deploy/...`), for the external tools.
    pub fn write_to(&self, dir: &Path) {
        for (path, text) in &self.files {
            let target = dir.join(path);
            std::fs::create_dir_all(target.parent().expect("a file has a directory"))
                .expect("cannot create a directory");
            std::fs::write(&target, text).expect("cannot write a copy of a deploy file");
        }
    }
}

/// What a problem is about: each module `tests/tests/deploy/*.rs` reports one concern.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Concern {
    /// Subcommands, flags, values, required arguments and `HEVO_*` variables against the
    /// binaries' `--help` (`flags.rs`).
    Flags,
    /// The Dockerfile's stages, user, command and build (`dockerfile.rs`).
    Dockerfile,
    /// The compose file's services (`compose.rs`).
    Compose,
    /// The manifests and kustomizations (`kubernetes.rs`).
    Kubernetes,
    /// The one-box and SLURM scripts (`scripts.rs`).
    Scripts,
    /// deploy/README.md's commands and references (`readme.rs`).
    Readme,
    /// One gRPC port, one metrics port, one state directory and one uid everywhere
    /// (`conventions.rs`).
    Conventions,
}

/// Problems found, by concern, each as `origin: message` (`deploy/k8s/worker.yaml: ...`).
#[derive(Debug, Default)]
pub struct Problems(BTreeMap<Concern, Vec<String>>);

impl Problems {
    /// Records a problem.
    pub fn add(&mut self, concern: Concern, origin: &str, message: impl Display) {
        self.0
            .entry(concern)
            .or_default()
            .push(format!("{origin}: {message}"));
    }

    /// Records a problem unless `ok`.
    pub fn check(&mut self, ok: bool, concern: Concern, origin: &str, message: impl Display) {
        if !ok {
            self.add(concern, origin, message);
        }
    }

    /// A view that files every problem under `concern`.
    pub fn scoped(&mut self, concern: Concern) -> Scoped<'_> {
        Scoped {
            problems: self,
            concern,
        }
    }

    /// The problems of one concern.
    pub fn of(&self, concern: Concern) -> &[String] {
        self.0.get(&concern).map_or(&[], Vec::as_slice)
    }

    /// Adds the problems of `other`.
    pub fn extend(&mut self, other: Problems) {
        for (concern, problems) in other.0 {
            self.0.entry(concern).or_default().extend(problems);
        }
    }

    /// Panics, listing them, if there are problems of `concern`.
    pub fn assert_none(&self, concern: Concern, what: &str) {
        let problems = self.of(concern);
        assert!(problems.is_empty(), "{what}:\n  {}", problems.join("\n  "));
    }
}

/// [`Problems`] of one concern.
#[derive(Debug)]
pub struct Scoped<'p> {
    problems: &'p mut Problems,
    concern: Concern,
}

impl Scoped<'_> {
    /// Records a problem.
    pub fn add(&mut self, origin: &str, message: impl Display) {
        self.problems.add(self.concern, origin, message);
    }

    /// Records a problem unless `ok`.
    pub fn check(&mut self, ok: bool, origin: &str, message: impl Display) {
        self.problems.check(ok, self.concern, origin, message);
    }
}

/// Facts gathered from all files, compared across them by [`check_conventions`] and used by
/// the live test.
#[derive(Debug, Default)]
pub struct Facts {
    /// Every command line that runs hevo, hevo-worker or one of the scripts.
    pub invocations: Vec<Invocation>,
    /// (origin, port) of every `hevo serve --listen` and `--metrics-listen` in a container or
    /// script that gives a fixed one.
    pub grpc_ports: Vec<(String, u16)>,
    /// As `grpc_ports`, for `--metrics-listen`.
    pub metrics_ports: Vec<(String, u16)>,
    /// (origin, directory) of the master's state directory.
    pub state_dirs: Vec<(String, String)>,
    /// Health service names used by probes.
    pub probe_services: BTreeSet<String>,
    /// Metrics paths named by scrape annotations.
    pub metrics_paths: BTreeSet<String>,
    /// (origin, uid) of every Kubernetes container's `runAsUser`.
    pub run_as_users: Vec<(String, i64)>,
    /// The Dockerfile's numeric `USER`.
    pub dockerfile_user: Option<i64>,
    /// The image's `CMD`.
    pub dockerfile_cmd: Vec<String>,
    /// The variables the image's `ENV` sets.
    pub dockerfile_env: BTreeSet<String>,
    /// The image's `EXPOSE`d ports.
    pub exposed: Vec<u16>,
    /// The compose master's healthcheck command line.
    pub compose_healthcheck: Option<Vec<String>>,
    /// The compose master's command line and the variables it gets.
    pub compose_master_argv: Option<(Vec<String>, BTreeSet<String>)>,
    /// The Kubernetes master's command line.
    pub k8s_master_argv: Option<Vec<String>>,
}

/// Every file parsed once: the problems each concern's checks found, and the facts.
#[derive(Debug)]
pub struct Analysis {
    /// Problems by concern (flag checks not included: see [`check_flags`]).
    pub problems: Problems,
    /// What the files say.
    pub facts: Facts,
}

impl Analysis {
    /// Parses and checks every file (all but the flags, which need the binaries).
    pub fn of(files: &DeployFiles) -> Analysis {
        let mut problems = Problems::default();
        let mut facts = Facts::default();
        dockerfile::check(files, &mut problems, &mut facts);
        compose::check(files, &mut problems, &mut facts);
        kubernetes::check(files, &mut problems, &mut facts);
        scripts::check(files, &mut problems, &mut facts);
        readme::check(files, &mut problems, &mut facts);
        check_conventions(&facts, &mut problems);
        Analysis { problems, facts }
    }

    /// [`Analysis::of`] and [`check_flags`] together.
    pub fn with_flags(files: &DeployFiles, helps: &Helps) -> Analysis {
        let mut analysis = Analysis::of(files);
        let flags = check_flags(files, &analysis.facts, helps);
        analysis.problems.extend(flags);
        analysis
    }
}

/// Every invocation against its program's `--help`, and every `HEVO_` variable anywhere in
/// deploy/ against the variables the binaries read.
pub fn check_flags(files: &DeployFiles, facts: &Facts, helps: &Helps) -> Problems {
    let mut all = Problems::default();
    let problems = &mut all.scoped(Concern::Flags);
    for invocation in &facts.invocations {
        invocation::check(helps, invocation, problems);
    }
    // The prefix is the binaries': a `HEVO_` variable they do not read is a typo or a leftover.
    let accepted = helps.all_env();
    for (path, text) in &files.files {
        for (number, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(at) = rest.find("HEVO_") {
                let name: String = rest[at..]
                    .chars()
                    .take_while(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_')
                    .collect();
                problems.check(
                    accepted.contains(&name),
                    &format!("{path}:{}", number + 1),
                    format!("`{name}` is not an environment variable hevo or hevo-worker reads (they read {accepted:?})"),
                );
                rest = &rest[at + name.len()..];
            }
        }
    }
    all
}

/// Records the master's ports and state directory from a `hevo serve` command line; a
/// command line without a literal `--listen HOST:PORT` or without `--state-dir` is a problem of
/// the file's concern.
fn record_serve(invocation: &Invocation, problems: &mut Scoped, facts: &mut Facts) {
    match invocation.flag("--listen").and_then(invocation::port_of) {
        Some(port) => facts.grpc_ports.push((invocation.origin.clone(), port)),
        None => problems.add(
            &invocation.origin,
            "`hevo serve` without a literal --listen HOST:PORT",
        ),
    }
    if let Some(port) = invocation
        .flag("--metrics-listen")
        .and_then(invocation::port_of)
    {
        facts.metrics_ports.push((invocation.origin.clone(), port));
    }
    match invocation.flag("--state-dir") {
        Some(dir) => facts
            .state_dirs
            .push((invocation.origin.clone(), dir.to_string())),
        None => problems.add(&invocation.origin, "`hevo serve` without --state-dir"),
    }
}

/// One gRPC port, one metrics port and one state directory in every file; the image exposes
/// exactly the ports the master listens on; every Kubernetes container runs as the image's user.
pub fn check_conventions(facts: &Facts, problems: &mut Problems) {
    let problems = &mut problems.scoped(Concern::Conventions);
    for (what, ports) in [
        ("gRPC", &facts.grpc_ports),
        ("metrics", &facts.metrics_ports),
    ] {
        let distinct: BTreeSet<u16> = ports.iter().map(|(_, p)| *p).collect();
        problems.check(
            distinct.len() == 1,
            "deploy/",
            format!("the {what} port differs between files: {ports:?}"),
        );
    }
    let listened: BTreeSet<u16> = facts
        .grpc_ports
        .iter()
        .chain(&facts.metrics_ports)
        .map(|(_, p)| *p)
        .collect();
    let exposed: BTreeSet<u16> = facts.exposed.iter().copied().collect();
    problems.check(
        exposed == listened,
        dockerfile::PATH,
        format!("EXPOSE {exposed:?} is not the set of ports the master listens on in the deploy files, {listened:?}"),
    );
    let dirs: BTreeSet<&String> = facts.state_dirs.iter().map(|(_, d)| d).collect();
    problems.check(
        dirs.len() == 1,
        "deploy/",
        format!(
            "the master's state directory differs between files: {:?}",
            facts.state_dirs
        ),
    );
    if let Some(user) = facts.dockerfile_user {
        for (origin, uid) in &facts.run_as_users {
            problems.check(
                *uid == user,
                origin,
                format!("runs as uid {uid}, the image's user is {user}"),
            );
        }
    }
}

/// A drift case: `from` replaced by `to` in `path` must be reported, under the concern the
/// test covers, by a problem that contains `expected`.
#[derive(Debug, Clone, Copy)]
pub struct Drift {
    /// The file changed.
    pub path: &'static str,
    /// The text replaced (its first occurrence).
    pub from: &'static str,
    /// What it becomes.
    pub to: &'static str,
    /// A part of the problem that must be reported.
    pub expected: &'static str,
}

/// Applies each case to a fresh copy of the files and asserts that `concern` reports it.
/// `helps`, when given, adds the flag checks.
pub fn assert_drift_detected(concern: Concern, helps: Option<&Helps>, cases: &[Drift]) {
    let pristine = DeployFiles::load();
    for case in cases {
        let mut files = pristine.clone();
        files.replace(case.path, case.from, case.to);
        let analysis = match helps {
            Some(helps) => Analysis::with_flags(&files, helps),
            None => Analysis::of(&files),
        };
        let reported = analysis.problems.of(concern);
        assert!(
            reported.iter().any(|p| p.contains(case.expected)),
            "changing {:?} to {:?} in {} was not reported as {:?} ({concern:?}); reported:\n  {}",
            case.from,
            case.to,
            case.path,
            case.expected,
            reported.join("\n  ")
        );
    }
}
