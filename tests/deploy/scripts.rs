//! The scripts under deploy/: bash with a shebang, a comment saying what they are for and
//! `set -euo pipefail`, and `bash -n` passes. The two that run hevo, the one-box and SLURM
//! scripts ([`RUNS_HEVO`]; the others set up what those run on), each run the master, the workers, submit, watch and
//! fetch, each with the token of its role (the master with two different ones, the clients'
//! and the workers', the workers with the master's workers' token, submit, watch and fetch
//! with its clients' token); the SLURM script has `#SBATCH` directives and
//! starts its workers with srun. Their command lines are recorded for the flag checks.

use super::invocation::{Invocation, Program, shell_invocations};
use super::shell::exported_names;
use super::{Concern, DeployFiles, Facts, Problems, Scoped};
use std::collections::BTreeSet;
use std::io::Write;
use std::process::{Command, Stdio};

/// The scripts' paths (the `.sh` and `.sbatch` files under deploy/).
pub fn paths(files: &DeployFiles) -> Vec<&String> {
    files
        .files
        .keys()
        .filter(|p| p.ends_with(".sh") || p.ends_with(".sbatch"))
        .collect()
}

/// The scripts that run a master, workers and the client commands; the other scripts
/// (deploy/slurm/local-cluster.sh, deploy/debian-base.sh) prepare a machine for them.
pub const RUNS_HEVO: [&str; 2] = ["deploy/local/one-box.sh", "deploy/slurm/hevo.sbatch"];

/// `bash -n` on a text: the error output when it does not parse.
fn bash_syntax(text: &str) -> Result<(), String> {
    let mut child = Command::new("bash")
        .arg("-n")
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run bash");
    child
        .stdin
        .take()
        .expect("piped stdin")
        .write_all(text.as_bytes())
        .expect("cannot write to bash");
    let output = child.wait_with_output().expect("bash -n");
    if output.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&output.stderr).into_owned())
    }
}

/// A command line's token of one role: the value of its file flag or of its value flag, or the
/// variable when it is exported.
fn role_token(invocation: &Invocation, file_flag: &str, flag: &str, var: &str) -> Option<String> {
    invocation
        .flag(file_flag)
        .map(str::to_string)
        .or_else(|| invocation.flag(flag).map(str::to_string))
        .or_else(|| invocation.env.contains(var).then(|| format!("${var}")))
}

/// The clients' token of a command line (for hevo-worker: its own, the workers').
fn token(invocation: &Invocation) -> Option<String> {
    role_token(invocation, "--token-file", "--token", "HEVO_TOKEN")
}

/// Each `hevo serve` of a script gets a clients' and a workers' token, two different ones;
/// every worker gets the master's workers' token and every client command its clients' token.
fn check_roles(invocations: &[Invocation], problems: &mut Scoped) {
    let mut roles: Vec<(String, String)> = Vec::new();
    for serve in invocations.iter().filter(|i| i.is_serve()) {
        let client = token(serve);
        let worker = role_token(
            serve,
            "--worker-token-file",
            "--worker-token",
            "HEVO_WORKER_TOKEN",
        );
        match (client, worker) {
            (Some(client), Some(worker)) if client != worker => roles.push((client, worker)),
            (Some(client), Some(_)) => problems.add(
                &serve.origin,
                format!("`hevo serve` gets one token, {client}, for both roles"),
            ),
            (client, worker) => {
                problems.check(
                    client.is_some(),
                    &serve.origin,
                    "`hevo serve` without the clients' token",
                );
                problems.check(
                    worker.is_some(),
                    &serve.origin,
                    "`hevo serve` without the workers' token",
                );
            }
        }
    }
    let Some((client_token, worker_token)) = roles.first() else {
        return;
    };
    for invocation in invocations.iter().filter(|i| !i.is_serve()) {
        let (own, other, role) = match invocation.program {
            Program::Worker => (worker_token, client_token, "workers'"),
            Program::Hevo => (client_token, worker_token, "clients'"),
            _ => continue,
        };
        match token(invocation) {
            None => problems.add(
                &invocation.origin,
                format!("`{}` without the token", invocation.name()),
            ),
            Some(token) if token == *other => problems.add(
                &invocation.origin,
                format!(
                    "`{}` gets {token}, the other role's token, instead of the master's {role}, {own}",
                    invocation.name()
                ),
            ),
            Some(token) => problems.check(
                token == *own,
                &invocation.origin,
                format!(
                    "`{}` gets {token}, not the master's {role} token {own}",
                    invocation.name()
                ),
            ),
        }
    }
}

/// Checks the scripts and records their command lines.
pub fn check(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let problems = &mut problems.scoped(Concern::Scripts);
    let scripts = paths(files);
    for path in RUNS_HEVO {
        problems.check(
            scripts.iter().any(|p| *p == path),
            "deploy/",
            format!("expected {path}, found {scripts:?}"),
        );
    }
    for path in scripts {
        let text = files.get(path);
        let mut lines = text.lines();
        problems.check(
            lines
                .next()
                .is_some_and(|l| l.starts_with("#!") && l.contains("bash")),
            path,
            "the first line is not a bash shebang",
        );
        problems.check(
            lines.next().is_some_and(|l| l.starts_with("# ")),
            path,
            "no comment saying what it is for after the shebang",
        );
        problems.check(
            text.lines().any(|l| l.trim() == "set -euo pipefail"),
            path,
            "no `set -euo pipefail`",
        );
        // On the text under test, which may differ from the file in a drift test.
        if let Err(e) = bash_syntax(text) {
            problems.add(path, format!("bash -n: {e}"));
        }
        if !RUNS_HEVO.contains(&path.as_str()) {
            continue;
        }
        let env: BTreeSet<String> = match exported_names(text) {
            Ok(names) => names.into_iter().collect(),
            Err(e) => {
                problems.add(path, format!("the shell parser fails: {e}"));
                BTreeSet::new()
            }
        };
        let before = facts.invocations.len();
        for error in shell_invocations(text, 1, path, &env, &mut facts.invocations) {
            problems.add(path, error);
        }
        let found: BTreeSet<String> = facts.invocations[before..]
            .iter()
            .map(|i| i.name())
            .collect();
        for expected in [
            "hevo serve",
            "hevo-worker",
            "hevo submit",
            "hevo watch",
            "hevo fetch",
        ] {
            problems.check(
                found.contains(expected),
                path,
                format!("runs no `{expected}` (found {found:?})"),
            );
        }
        check_roles(&facts.invocations[before..], problems);
        if path.ends_with(".sbatch") {
            problems.check(
                text.lines().any(|l| l.starts_with("#SBATCH ")),
                path,
                "no #SBATCH directives",
            );
            // The command line that runs the worker starts with srun.
            let workers_by_srun = facts.invocations[before..].iter().any(|i| {
                let line: Option<usize> = i.origin.rsplit(':').next().and_then(|n| n.parse().ok());
                i.program == Program::Worker
                    && line
                        .and_then(|n| text.lines().nth(n.saturating_sub(1)))
                        .is_some_and(|l| l.trim_start().starts_with("srun "))
            });
            problems.check(
                workers_by_srun,
                path,
                "the workers are not started with srun",
            );
        }
    }
}
