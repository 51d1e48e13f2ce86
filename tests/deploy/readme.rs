//! deploy/README.md: its shell blocks show the one-box and SLURM scripts and the submit, watch
//! and fetch commands (their command lines are recorded for the flag checks), and every
//! `deploy/...` path it names and every relative link exists.

use super::invocation::shell_invocations;
use super::shell::exported_names;
use super::{Concern, DeployFiles, Facts, Problems};
use crate::repo_root;
use std::collections::BTreeSet;

/// The README's path.
pub const PATH: &str = "deploy/README.md";

/// The shell blocks (```` ```sh ````, `bash`, `shell`, and `console` with its `$ ` prompts
/// stripped and output lines left out) of a Markdown text: (body, line of its first line).
pub fn shell_blocks(text: &str) -> Vec<(String, usize)> {
    let mut blocks: Vec<(String, usize)> = Vec::new();
    // (body, console, first line), or None for a block in another language.
    let mut current: Option<Option<(String, bool, usize)>> = None;
    for (number, line) in text.lines().enumerate() {
        let number = number + 1;
        if let Some(fence) = line.trim_start().strip_prefix("```") {
            match current.take() {
                Some(Some((body, _, start))) => blocks.push((body, start)),
                Some(None) => {}
                None => {
                    let language = fence.trim();
                    current = Some(
                        ["sh", "bash", "shell", "console"]
                            .contains(&language)
                            .then(|| (String::new(), language == "console", number + 1)),
                    );
                }
            }
            continue;
        }
        if let Some(Some((body, console, _))) = current.as_mut() {
            let command = if *console {
                line.strip_prefix("$ ").unwrap_or("# output")
            } else {
                line
            };
            body.push_str(command);
            body.push('\n');
        }
    }
    blocks
}

/// Checks the README and records the command lines of its shell blocks.
pub fn check(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let problems = &mut problems.scoped(Concern::Readme);
    let path = PATH;
    let text = files.get(path);
    // An export in one block applies to the later ones.
    let blocks = shell_blocks(text);
    let mut env = BTreeSet::new();
    for (body, start) in &blocks {
        match exported_names(body) {
            Ok(names) => env.extend(names),
            Err(e) => problems.add(
                &format!("{path}:{start}"),
                format!("the shell parser fails: {e}"),
            ),
        }
    }
    let before = facts.invocations.len();
    for (body, start) in &blocks {
        for error in shell_invocations(body, *start, path, &env, &mut facts.invocations) {
            problems.add(path, error);
        }
    }
    let found: BTreeSet<String> = facts.invocations[before..]
        .iter()
        .map(|i| i.name())
        .collect();
    for expected in [
        "one-box.sh",
        "hevo.sbatch",
        "hevo submit",
        "hevo watch",
        "hevo fetch",
    ] {
        problems.check(
            found.contains(expected),
            path,
            format!("shows no `{expected}` command (found {found:?})"),
        );
    }
    // Files the user creates (the token files) are git-ignored in deploy/.
    let user_files: BTreeSet<String> = files
        .files
        .iter()
        .filter(|(p, _)| p.ends_with("/.gitignore"))
        .flat_map(|(p, text)| {
            let dir = p.trim_end_matches(".gitignore").to_string();
            text.lines()
                .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
                .map(move |l| format!("{dir}{}", l.trim()))
                .collect::<Vec<_>>()
        })
        .collect();
    for (number, line) in text.lines().enumerate() {
        let origin = format!("{path}:{}", number + 1);
        for (at, _) in line.match_indices("deploy/") {
            let reference: String = line[at..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || "/._-".contains(*c))
                .collect();
            let reference = reference.trim_end_matches(['.', '/']);
            if reference == "deploy" || user_files.contains(reference) {
                continue;
            }
            problems.check(
                repo_root().join(reference).exists(),
                &origin,
                format!("refers to {reference}, which does not exist"),
            );
        }
        for (at, _) in line.match_indices("](") {
            let target: String = line[at + 2..].chars().take_while(|c| *c != ')').collect();
            if !target.contains("://") && !target.starts_with('#') {
                problems.check(
                    repo_root().join("deploy").join(&target).exists(),
                    &origin,
                    format!("links to {target}, which does not exist"),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shell_blocks_are_extracted() {
        let text =
            "# T\n\n```sh\na --b\n```\n\n```toml\nx = 1\n```\n\n```console\n$ c d\noutput\n```\n";
        assert_eq!(
            shell_blocks(text),
            [
                ("a --b\n".to_string(), 4),
                ("c d\n# output\n".to_string(), 12)
            ]
        );
    }
}
