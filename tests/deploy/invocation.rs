//! Command lines that run `hevo`, `hevo-worker` or one of the two scripts, found in shell texts
//! and container commands, and their check against the program's `--help`.

use super::Scoped;
use super::help::{Help, Helps};
use super::shell;
use std::collections::BTreeSet;

/// The programs whose command lines are checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Program {
    /// `hevo`.
    Hevo,
    /// `hevo-worker`.
    Worker,
    /// `deploy/local/one-box.sh`.
    OneBox,
    /// `deploy/slurm/hevo.sbatch`.
    Sbatch,
}

/// The program a command word runs (`hevo`, `target/release/hevo`, `"$hevo"`).
pub fn program_of(word: &str) -> Option<Program> {
    match word {
        "$hevo" | "${hevo}" => return Some(Program::Hevo),
        "$hevo_worker" | "${hevo_worker}" => return Some(Program::Worker),
        _ => {}
    }
    match word.rsplit('/').next().unwrap_or(word) {
        "hevo" => Some(Program::Hevo),
        "hevo-worker" => Some(Program::Worker),
        "one-box.sh" => Some(Program::OneBox),
        "hevo.sbatch" => Some(Program::Sbatch),
        _ => None,
    }
}

/// One command line.
#[derive(Debug, Clone)]
pub struct Invocation {
    /// `file:line`, or `file: what` for a container command.
    pub origin: String,
    /// What it runs.
    pub program: Program,
    /// Its arguments, after the program.
    pub args: Vec<String>,
    /// Environment variables the invocation gets from its surroundings (exports, container env).
    pub env: BTreeSet<String>,
    /// The line of each argument, where known (empty when not).
    pub arg_lines: Vec<Option<usize>>,
}

impl Invocation {
    /// `serve` in `hevo serve ...`.
    pub fn subcommand(&self) -> Option<&str> {
        match self.program {
            Program::Hevo => self
                .args
                .first()
                .filter(|a| !a.starts_with('-'))
                .map(String::as_str),
            _ => None,
        }
    }

    /// The value of a long flag (`--flag value` or `--flag=value`).
    pub fn flag(&self, flag: &str) -> Option<&str> {
        let mut args = self.args.iter();
        while let Some(arg) = args.next() {
            if arg == flag {
                return args.next().map(String::as_str);
            }
            if let Some(value) = arg
                .strip_prefix(flag)
                .and_then(|rest| rest.strip_prefix('='))
            {
                return Some(value);
            }
        }
        None
    }

    /// The origin of the argument at `index`: its own line, where known, instead of the
    /// command's (`deploy/k8s/master.yaml:98: StatefulSet ...`, `deploy/local/one-box.sh:218`).
    pub fn origin_at(&self, index: usize) -> String {
        let Some(line) = self.arg_lines.get(index).copied().flatten() else {
            return self.origin.clone();
        };
        let file = self.origin.split(':').next().unwrap_or_default();
        match self.origin.split_once(": ") {
            Some((_, what)) => format!("{file}:{line}: {what}"),
            None => format!("{file}:{line}"),
        }
    }

    /// `hevo serve`, `hevo-worker`, `one-box.sh`, ...
    pub fn name(&self) -> String {
        match self.program {
            Program::Hevo => format!("hevo {}", self.subcommand().unwrap_or(""))
                .trim_end()
                .to_string(),
            Program::Worker => "hevo-worker".into(),
            Program::OneBox => "one-box.sh".into(),
            Program::Sbatch => "hevo.sbatch".into(),
        }
    }

    /// Whether it is `hevo serve`.
    pub fn is_serve(&self) -> bool {
        self.program == Program::Hevo && self.subcommand() == Some("serve")
    }
}

/// Commands that run another command given as one of their later words.
const PREFIX_COMMANDS: &[&str] = &[
    "exec", "nohup", "setsid", "timeout", "env", "command", "stdbuf", "nice", "srun", "sbatch",
    "mpirun", "sudo", "docker", "kubectl", "xargs", "time",
];

/// Every invocation in a shell text, recursively into command substitutions, `bash -c` and
/// `--wrap` strings. `env` holds the variables exported around it. Returns the texts that did
/// not parse.
pub fn shell_invocations(
    text: &str,
    first_line: usize,
    file: &str,
    env: &BTreeSet<String>,
    out: &mut Vec<Invocation>,
) -> Vec<String> {
    let parsed = match shell::parse(text, first_line) {
        Ok(parsed) => parsed,
        Err(e) => return vec![format!("{file}:{first_line}: the shell parser fails: {e}")],
    };
    let mut errors = Vec::new();
    for (inner, line) in &parsed.substitutions {
        errors.extend(shell_invocations(inner, *line, file, env, out));
    }
    for command in &parsed.commands {
        let words = command.words.as_slice();
        let mut command_env = env.clone();
        command_env.extend(command.assignments.iter().cloned());
        let Some(first) = words.first() else { continue };
        let base = first.rsplit('/').next().unwrap_or(first);
        // Strings that are themselves commands.
        for (at, word) in words.iter().enumerate() {
            let script = if (base == "bash" || base == "sh") && word == "-c" || word == "--wrap" {
                words.get(at + 1).cloned()
            } else {
                word.strip_prefix("--wrap=").map(str::to_string)
            };
            if let Some(script) = script {
                errors.extend(shell_invocations(
                    &script,
                    command.line,
                    file,
                    &command_env,
                    out,
                ));
            }
        }
        let origin = format!("{file}:{}", command.line);
        let found = if let Some(program) = program_of(first) {
            Some((program, 1))
        } else if PREFIX_COMMANDS.contains(&base)
            // `command -v hevo` looks the program up; it does not run it.
            && !(base == "command" && words.get(1).is_some_and(|w| w == "-v" || w == "-V"))
        {
            // kubectl runs a command in a pod only after `--`; elsewhere its words name objects.
            let start = if base == "kubectl" {
                words
                    .iter()
                    .position(|w| w == "--")
                    .map_or(words.len(), |p| p + 1)
            } else {
                1
            };
            words[start..]
                .iter()
                .enumerate()
                .find_map(|(p, w)| program_of(w).map(|program| (program, start + p + 1)))
        } else {
            None
        };
        if let Some((program, args_start)) = found {
            out.push(Invocation {
                origin,
                program,
                args: words[args_start..].to_vec(),
                env: command_env,
                arg_lines: command.word_lines[args_start..]
                    .iter()
                    .map(|l| Some(*l))
                    .collect(),
            });
        }
    }
    errors
}

/// The invocation a container command (`command` + `args`, or the image's `CMD`) makes;
/// `lines` holds the line of each word of `argv`, where known.
pub fn container_invocation(
    origin: String,
    argv: &[String],
    lines: &[Option<usize>],
    env: BTreeSet<String>,
) -> Option<Invocation> {
    let (first, args) = argv.split_first()?;
    let program = program_of(first)?;
    Some(Invocation {
        origin,
        program,
        args: args.to_vec(),
        env,
        arg_lines: lines.iter().skip(1).copied().collect(),
    })
}

fn help_for<'h>(
    helps: &'h Helps,
    invocation: &Invocation,
    problems: &mut Scoped,
) -> Option<(&'h Help, usize)> {
    match invocation.program {
        Program::Hevo => match invocation.subcommand() {
            None => Some((&helps.hevo, 0)),
            Some(sub) => match helps.hevo_subcommands.get(sub) {
                Some(help) => Some((help, 1)),
                None => {
                    problems.add(
                        &invocation.origin_at(0),
                        format!(
                            "`hevo {sub}`: hevo has no subcommand `{sub}` (it has {:?})",
                            helps.hevo.subcommands
                        ),
                    );
                    None
                }
            },
        },
        Program::Worker => Some((&helps.worker, 0)),
        Program::OneBox => Some((&helps.one_box, 0)),
        Program::Sbatch => Some((&helps.sbatch, 0)),
    }
}

/// Checks one invocation against its program's help: every option exists, takes a value when
/// and only when it should, required flags (or their environment variables) and arguments are
/// there.
pub fn check(helps: &Helps, invocation: &Invocation, problems: &mut Scoped) {
    let Some((help, skip)) = help_for(helps, invocation, problems) else {
        return;
    };
    let name = invocation.name();
    let origin = &invocation.origin;
    let mut used = BTreeSet::new();
    let mut positionals = 0;
    let mut asks_help = false;
    let mut args = invocation.args.iter().enumerate().skip(skip);
    while let Some((at, arg)) = args.next() {
        let here = invocation.origin_at(at);
        if arg == "--" {
            positionals += args.len();
            break;
        }
        if arg.starts_with('-') && arg.len() > 1 && !arg.starts_with("-$") {
            let flag = arg.split('=').next().unwrap_or(arg);
            asks_help |= ["--help", "-h", "--version", "-V"].contains(&flag);
            match help.options.get(flag) {
                None => problems.add(&here, format!("`{name}` has no option `{flag}`")),
                Some(option) => {
                    used.insert(flag.to_string());
                    if option.takes_value && !arg.contains('=') {
                        match args.next() {
                            None => problems.add(&here, format!("`{name} {flag}` needs a value")),
                            Some((_, value)) if value.starts_with("--") => problems.add(
                                &here,
                                format!("`{name} {flag}` needs a value, got the option `{value}`"),
                            ),
                            Some(_) => {}
                        }
                    } else if !option.takes_value && arg.contains('=') {
                        problems.add(&here, format!("`{name} {flag}` takes no value"));
                    }
                }
            }
        } else {
            positionals += 1;
        }
    }
    if asks_help {
        return;
    }
    for required in &help.required_flags {
        let from_env = help
            .options
            .get(required)
            .and_then(|o| o.env.as_ref())
            .is_some_and(|env| invocation.env.contains(env));
        problems.check(used.contains(required) || from_env,
            origin,
            format!("`{name}` needs `{required}` (or its environment variable), which this command line does not give"),
        );
    }
    problems.check(
        positionals >= help.required_positionals,
        origin,
        format!(
            "`{name}` needs {} argument(s), this command line gives {positionals}",
            help.required_positionals
        ),
    );
}

/// `host:port` -> port.
pub fn port_of(address: &str) -> Option<u16> {
    address.rsplit(':').next()?.parse().ok()
}

/// `http://host:port/...` -> (host, port).
pub fn url_host_port(url: &str) -> Option<(String, u16)> {
    let rest = url.split_once("://").map_or(url, |(_, rest)| rest);
    let authority = rest.split('/').next()?;
    let (host, port) = authority.rsplit_once(':')?;
    Some((host.to_string(), port.parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invocations_are_found_in_scripts() {
        let script = r#"#!/bin/bash
# comment with hevo serve --bogus
set -euo pipefail
cat <<'EOF'
hevo serve --not-a-command
EOF
job=$("$hevo" submit --master "$url" \
    --token-file "$token" "$file")
HEVO_TOKEN=x exec "$bin/hevo-worker" --master "$(cat "$dir/url")" 2>&1 >"$log" &
srun --ntasks=4 "$hevo_worker" --threads "$cpus" | tee log; echo "hevo watch is not run here"
kubectl -n hevo exec hevo-master-0 -- hevo jobs --master http://x:1
sbatch --wrap 'srun hevo-worker --master "$(cat m)"'
hevo=$(command -v hevo) || die "no hevo"
"#;
        let mut found = Vec::new();
        let errors = shell_invocations(script, 1, "t", &BTreeSet::new(), &mut found);
        assert!(errors.is_empty(), "{errors:?}");
        let lines: Vec<(String, Vec<String>)> = found
            .iter()
            .map(|i| {
                (
                    format!("{}@{}", i.name(), i.origin.rsplit(':').next().unwrap()),
                    i.args.clone(),
                )
            })
            .collect();
        let names: Vec<&str> = lines.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "hevo submit@7",
                "hevo-worker@9",
                "hevo-worker@10",
                "hevo jobs@11",
                "hevo-worker@12"
            ],
            "{lines:#?}"
        );
        assert_eq!(
            found[0].args,
            [
                "submit",
                "--master",
                "$url",
                "--token-file",
                "$token",
                "$file"
            ]
        );
        assert_eq!(found[1].args, ["--master", "$(cat \"$dir/url\")"]);
        assert!(found[1].env.contains("HEVO_TOKEN"));
        assert_eq!(found[2].args, ["--threads", "$cpus"]);
        assert_eq!(found[4].args, ["--master", "$(cat m)"]);
    }

    #[test]
    fn a_script_that_does_not_parse_is_reported() {
        let mut found = Vec::new();
        let errors = shell_invocations(
            "if hevo serve; then\n",
            3,
            "t",
            &BTreeSet::new(),
            &mut found,
        );
        assert_eq!(errors.len(), 1, "{errors:?}");
        assert!(errors[0].starts_with("t:3: "), "{errors:?}");
    }

    #[test]
    fn flag_values_and_urls() {
        let invocation = Invocation {
            origin: "t".into(),
            program: Program::Hevo,
            args: ["serve", "--listen=0.0.0.0:50051", "--state-dir", "/s"]
                .map(String::from)
                .to_vec(),
            env: BTreeSet::new(),
            arg_lines: vec![Some(3), None],
        };
        assert_eq!(invocation.origin_at(0), "t:3");
        assert_eq!(invocation.origin_at(1), "t");
        assert!(invocation.is_serve());
        assert_eq!(invocation.flag("--listen").and_then(port_of), Some(50051));
        assert_eq!(invocation.flag("--state-dir"), Some("/s"));
        assert_eq!(invocation.flag("--state"), None);
        assert_eq!(
            url_host_port("http://hevo-master.hevo.svc:50051"),
            Some(("hevo-master.hevo.svc".into(), 50051))
        );
        assert_eq!(url_host_port("http://master"), None);
    }
}
