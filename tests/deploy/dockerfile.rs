//! deploy/Dockerfile: a multi-stage build of the workspace's `hevo` and `hevo-worker`, a
//! runtime stage that runs them as a numeric non-root user with the exec form of `CMD`, the
//! state directory created for that user, and the facts the other files rely on (`CMD`,
//! `ENV`, `EXPOSE`, `USER`).

use super::invocation::container_invocation;
use super::yaml::Lines;
use super::{Concern, DeployFiles, Facts, Problems};
use crate::repo_root;
use std::collections::{BTreeMap, BTreeSet};

/// The Dockerfile's path.
pub const PATH: &str = "deploy/Dockerfile";

/// Its instructions, continuation lines joined and comments dropped: (`RUN`, the rest).
pub fn instructions(text: &str) -> Vec<(String, String)> {
    let mut instructions: Vec<(String, String)> = Vec::new();
    let mut pending = String::new();
    for line in text.lines() {
        let trimmed = line.trim();
        if trimmed.starts_with('#') || (pending.is_empty() && trimmed.is_empty()) {
            continue;
        }
        if let Some(stripped) = trimmed.strip_suffix('\\') {
            pending.push_str(stripped);
            pending.push(' ');
            continue;
        }
        pending.push_str(trimmed);
        let full = std::mem::take(&mut pending);
        let (keyword, rest) = full.split_once(char::is_whitespace).unwrap_or((&full, ""));
        instructions.push((keyword.to_ascii_uppercase(), rest.trim().to_string()));
    }
    instructions
}

/// Checks the Dockerfile and records its facts.
pub fn check(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let problems = &mut problems.scoped(Concern::Dockerfile);
    let path = PATH;
    let text = files.get(path);
    problems.check(
        text.lines()
            .any(|l| l.starts_with("# ") && !l.starts_with("# syntax")),
        path,
        "starts with no comment saying what it is for",
    );
    let instructions = instructions(text);
    let stages = instructions.iter().filter(|(k, _)| k == "FROM").count();
    problems.check(
        stages >= 2,
        path,
        format!("a multi-stage build needs at least two FROM, found {stages}"),
    );
    let last_from = instructions
        .iter()
        .rposition(|(k, _)| k == "FROM")
        .unwrap_or(0);
    let runtime = instructions.get(last_from..).unwrap_or_default();

    match runtime.iter().rev().find(|(k, _)| k == "USER") {
        None => problems.add(
            path,
            "the runtime stage sets no USER (it would run as root)",
        ),
        Some((_, user)) => match user.split(':').next().unwrap_or(user).parse::<i64>() {
            Ok(0) => problems.add(path, "the runtime stage runs as root"),
            Ok(uid) => facts.dockerfile_user = Some(uid),
            Err(_) => problems.add(
                path,
                format!("USER {user}: use a numeric uid so that runAsNonRoot can verify it"),
            ),
        },
    }
    for (keyword, rest) in runtime {
        match keyword.as_str() {
            "CMD" | "ENTRYPOINT" => match serde_json::from_str::<Vec<String>>(rest) {
                Ok(argv) => {
                    if keyword == "ENTRYPOINT" {
                        problems.add(path, "an ENTRYPOINT would prefix every service's command; the deploy files name the binary");
                    }
                    facts.dockerfile_cmd = argv.clone();
                    // The last CMD/ENTRYPOINT line, since the last one counts.
                    let lines = Lines::new(text);
                    let line = lines
                        .find(1, |l| l.starts_with(keyword.as_str()))
                        .map(|first| {
                            let mut last = first;
                            while let Some(next) =
                                lines.find(last + 1, |l| l.starts_with(keyword.as_str()))
                            {
                                last = next;
                            }
                            last
                        });
                    let origin = match line {
                        Some(line) => format!("{path}:{line}: {keyword}"),
                        None => format!("{path}: {keyword}"),
                    };
                    let argv_lines = vec![line; argv.len()];
                    if let Some(invocation) =
                        container_invocation(origin, &argv, &argv_lines, BTreeSet::new())
                    {
                        facts.invocations.push(invocation);
                    }
                }
                Err(_) => problems.add(path, format!("{keyword} {rest}: use the exec (JSON) form, so that SIGTERM reaches the binary and not a shell")),
            },
            "ENV" => {
                let words: Vec<&str> = rest.split_whitespace().collect();
                if words.first().is_some_and(|w| w.contains('=')) {
                    facts.dockerfile_env.extend(
                        words
                            .iter()
                            .filter_map(|w| w.split_once('=').map(|(k, _)| k.to_string())),
                    );
                } else if let Some(name) = words.first() {
                    facts.dockerfile_env.insert(name.to_string());
                }
            }
            "EXPOSE" => {
                for port in rest.split_whitespace() {
                    match port.split('/').next().unwrap_or(port).parse::<u16>() {
                        Ok(port) => facts.exposed.push(port),
                        Err(_) => {
                            problems.add(path, format!("EXPOSE {port}: not a port number"))
                        }
                    }
                }
            }
            _ => {}
        }
    }
    // The binaries built are the workspace's: `-p` names real packages that own `hevo` and
    // `hevo-worker`, and both land in the image.
    let packages = workspace_packages();
    let build = instructions
        .iter()
        .filter(|(k, _)| k == "RUN")
        .map(|(_, r)| r.as_str())
        .find(|r| r.contains("cargo build"));
    match build {
        None => problems.add(path, "no RUN with `cargo build`"),
        Some(run) => {
            // The words of the cargo command itself, up to the next `&&`, `;` or `|`.
            let command = &run[run.find("cargo build").unwrap_or(0)..];
            let command = command.split(['&', ';', '|']).next().unwrap_or(command);
            let words: Vec<&str> = command.split_whitespace().collect();
            let mut built_bins = BTreeSet::new();
            for pair in words.windows(2) {
                if pair[0] == "-p" || pair[0] == "--package" {
                    match packages.get(pair[1]) {
                        None => problems.add(
                            path,
                            format!(
                                "`cargo build -p {}`: no such workspace package (have {:?})",
                                pair[1],
                                packages.keys()
                            ),
                        ),
                        Some(bins) => built_bins.extend(bins.iter().cloned()),
                    }
                }
            }
            for bin in ["hevo", "hevo-worker"] {
                problems.check(
                    built_bins.contains(bin),
                    path,
                    format!(
                        "the cargo build does not build `{bin}` (packages build {built_bins:?})"
                    ),
                );
                problems.check(
                    run.split_whitespace()
                        .any(|w| w == format!("target/release/{bin}")),
                    path,
                    format!("target/release/{bin} is not copied out of the build"),
                );
            }
        }
    }
    // The state directory exists in the image, owned by the runtime user (a fresh volume
    // mounted there copies that ownership).
    let chowned = runtime
        .iter()
        .find(|(k, r)| k == "COPY" && r.contains("--chown="));
    match (chowned, facts.dockerfile_user) {
        (Some((_, copy)), Some(uid)) => {
            problems.check(
                copy.contains(&format!("--chown={uid}")),
                path,
                format!("`COPY {copy}` is not owned by the runtime user {uid}"),
            );
            let destination = copy
                .split_whitespace()
                .last()
                .unwrap_or_default()
                .trim_end_matches('/');
            facts
                .state_dirs
                .push((format!("{path}: COPY --chown"), destination.to_string()));
        }
        _ => problems.add(
            path,
            "no `COPY --chown=UID:GID` creating the master's state directory for the runtime user",
        ),
    }
}

/// Workspace package name -> the binaries it builds.
pub fn workspace_packages() -> BTreeMap<String, Vec<String>> {
    let root = repo_root();
    let read = |path: &std::path::Path| -> Option<toml::Table> {
        std::fs::read_to_string(path).ok()?.parse().ok()
    };
    let manifest = read(&root.join("Cargo.toml")).expect("the workspace's Cargo.toml parses");
    let members: Vec<String> = manifest
        .get("workspace")
        .and_then(|w| w.get("members"))
        .and_then(|m| m.as_array())
        .expect("workspace members")
        .iter()
        .filter_map(|m| m.as_str().map(str::to_string))
        .collect();
    let mut packages = BTreeMap::new();
    for member in members {
        let dir = root.join(member);
        let Some(manifest) = read(&dir.join("Cargo.toml")) else {
            continue;
        };
        let Some(name) = manifest
            .get("package")
            .and_then(|p| p.get("name"))
            .and_then(|n| n.as_str())
        else {
            continue;
        };
        let mut bins: Vec<String> = manifest
            .get("bin")
            .and_then(|b| b.as_array())
            .map(|bins| {
                bins.iter()
                    .filter_map(|b| b.get("name")?.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        if bins.is_empty() && dir.join("src/main.rs").exists() {
            bins.push(name.to_string());
        }
        packages.insert(name.to_string(), bins);
    }
    packages
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instructions_join_continuations_and_drop_comments() {
        let text = "# syntax=docker/dockerfile:1\n# about\nFROM a AS b\nRUN x \\\n    # inside\n    && y\n\nrun z\n";
        assert_eq!(
            instructions(text),
            [
                ("FROM".to_string(), "a AS b".to_string()),
                ("RUN".to_string(), "x  && y".to_string()),
                ("RUN".to_string(), "z".to_string())
            ]
        );
    }

    #[test]
    fn the_workspace_builds_both_binaries() {
        let packages = workspace_packages();
        let bins: BTreeSet<&String> = packages.values().flatten().collect();
        assert!(
            bins.contains(&"hevo".to_string()) && bins.contains(&"hevo-worker".to_string()),
            "{packages:?}"
        );
    }
}
