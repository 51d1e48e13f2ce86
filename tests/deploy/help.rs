//! What each program accepts, read from its own `--help`: clap's format, which the scripts'
//! own `--help` follows too (`-h, --help`, `--flag <VALUE>`, `[env: NAME=]`, a `Usage:` line
//! whose unbracketed flags and `<ARG>`s are required, and a `Commands:` section).

use crate::{binaries, repo_root};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;

/// One option.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Opt {
    /// `--flag <VALUE>` rather than `--flag`.
    pub takes_value: bool,
    /// The environment variable that stands in for it, from `[env: NAME=...]`.
    pub env: Option<String>,
}

/// One program's (or subcommand's) help.
#[derive(Debug, Default, Clone)]
pub struct Help {
    /// `--listen`, `-h`, ... with whether each takes a value and its environment variable.
    pub options: BTreeMap<String, Opt>,
    /// Long flags the usage line shows outside brackets.
    pub required_flags: Vec<String>,
    /// `<ARG>`s the usage line shows outside brackets.
    pub required_positionals: usize,
    /// From a `Commands:` section (without `help`).
    pub subcommands: BTreeSet<String>,
}

/// Parses a `--help` text.
pub fn parse_help(text: &str) -> Help {
    let mut help = Help::default();
    let mut current: Vec<String> = Vec::new();
    let mut in_commands = false;
    for line in text.lines() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        if let Some(usage) = line.strip_prefix("Usage:") {
            parse_usage(usage, &mut help);
            continue;
        }
        if trimmed.is_empty() {
            continue;
        }
        if indent == 0 {
            in_commands = trimmed.starts_with("Commands:");
            current.clear();
            continue;
        }
        if in_commands {
            if indent <= 4 {
                let name = trimmed
                    .split_whitespace()
                    .next()
                    .unwrap_or_default()
                    .trim_end_matches(',');
                if name != "help" {
                    help.subcommands.insert(name.to_string());
                }
            }
            continue;
        }
        if indent <= 8 && trimmed.starts_with('-') {
            current = parse_option_line(trimmed, &mut help);
        }
        if let Some(at) = line.find("[env: ") {
            let name: String = line[at + 6..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            for option in &current {
                if let Some(opt) = help.options.get_mut(option) {
                    opt.env = Some(name.clone());
                }
            }
        }
    }
    help
}

fn parse_option_line(trimmed: &str, help: &mut Help) -> Vec<String> {
    let tokens: Vec<&str> = trimmed.split_whitespace().collect();
    let mut names = Vec::new();
    let mut takes_value = false;
    let mut i = 0;
    while i < tokens.len() {
        let token = tokens[i].trim_end_matches(',');
        if !(token.starts_with('-') && token.len() > 1) {
            break;
        }
        let (name, inline_value) = match token.split_once('=') {
            Some((name, _)) => (name, true),
            None => (token, false),
        };
        let next_is_value = tokens
            .get(i + 1)
            .is_some_and(|t| t.starts_with('<') || t.starts_with("[<"));
        takes_value |= inline_value || next_is_value;
        names.push(name.to_string());
        i += if next_is_value { 2 } else { 1 };
    }
    // `-t, --threads <THREADS>`: the placeholder follows the long form only.
    for name in &names {
        help.options.insert(
            name.clone(),
            Opt {
                takes_value,
                env: None,
            },
        );
    }
    names
}

fn parse_usage(usage: &str, help: &mut Help) {
    let mut depth = 0i32;
    let mut program_done = false;
    let mut after_flag = false;
    for token in usage.split_whitespace() {
        let start_depth = depth;
        for c in token.chars() {
            match c {
                '<' | '[' => depth += 1,
                '>' | ']' => depth -= 1,
                _ => {}
            }
        }
        if start_depth != 0 {
            continue;
        }
        if !program_done {
            if !token.starts_with(['-', '<', '[']) {
                continue;
            }
            program_done = true;
        }
        if let Some(flag) = token
            .strip_prefix("--")
            .map(|f| format!("--{}", f.split('=').next().unwrap_or(f)))
        {
            help.required_flags.push(flag);
            after_flag = true;
        } else if token.starts_with('<') && depth == 0 {
            if after_flag {
                after_flag = false;
            } else {
                help.required_positionals += 1;
            }
        } else {
            after_flag = false;
        }
    }
}

/// What each program accepts, from its own `--help`.
#[derive(Debug, Clone)]
pub struct Helps {
    /// `hevo --help`.
    pub hevo: Help,
    /// `hevo SUBCOMMAND --help` for each subcommand `hevo --help` lists.
    pub hevo_subcommands: BTreeMap<String, Help>,
    /// `hevo-worker --help`.
    pub worker: Help,
    /// `deploy/local/one-box.sh --help`.
    pub one_box: Help,
    /// `deploy/slurm/hevo.sbatch --help`.
    pub sbatch: Help,
}

impl Helps {
    /// Every environment variable behind a flag of hevo (any subcommand) or hevo-worker.
    pub fn all_env(&self) -> BTreeSet<String> {
        let mut env = BTreeSet::new();
        for help in std::iter::once(&self.hevo)
            .chain(self.hevo_subcommands.values())
            .chain([&self.worker])
        {
            env.extend(help.options.values().filter_map(|o| o.env.clone()));
        }
        env
    }
}

fn run_help(program: &Path, args: &[&str]) -> String {
    let output = Command::new(program)
        .args(args)
        .env_remove("HEVO_TOKEN")
        .env_remove("HEVO_MASTER")
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", program.display()));
    assert!(
        output.status.success(),
        "{} {} failed: {}",
        program.display(),
        args.join(" "),
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// The helps of the real binaries (built by [`binaries`]) and of the two scripts, read once
/// per test process.
pub fn helps() -> &'static Helps {
    static HELPS: OnceLock<Helps> = OnceLock::new();
    HELPS.get_or_init(|| {
        let bins = binaries();
        let hevo = parse_help(&run_help(&bins.hevo, &["--help"]));
        assert!(
            hevo.subcommands.contains("serve"),
            "`hevo --help` lists no `serve` subcommand:\n{hevo:#?}"
        );
        let hevo_subcommands = hevo
            .subcommands
            .iter()
            .map(|sub| {
                (
                    sub.clone(),
                    parse_help(&run_help(&bins.hevo, &[sub, "--help"])),
                )
            })
            .collect();
        let worker = parse_help(&run_help(&bins.worker, &["--help"]));
        let script_help = |script: &str| {
            let output = Command::new("bash")
                .arg(repo_root().join(script))
                .arg("--help")
                .output()
                .expect("bash");
            assert!(output.status.success(), "{script} --help failed");
            parse_help(&String::from_utf8_lossy(&output.stdout))
        };
        Helps {
            hevo,
            hevo_subcommands,
            worker,
            one_box: script_help("deploy/local/one-box.sh"),
            sbatch: script_help("deploy/slurm/hevo.sbatch"),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn help_parser_reads_clap_output() {
        let text = "\
Start the master

Usage: hevo serve [OPTIONS] --listen <ADDR> --state-dir <DIR> <--token <TOKEN>|--token-file <FILE>>

Options:
      --listen <ADDR>
          Address to listen on

      --token <TOKEN>
          The shared token

          [env: HEVO_TOKEN=]

  -t, --threads <THREADS>  Threads [env: HEVO_THREADS=4]
  -v, --verbose            More logs
  -h, --help
          Print help (see a summary with '-h')
";
        let help = parse_help(text);
        assert_eq!(help.required_flags, ["--listen", "--state-dir"]);
        assert_eq!(help.required_positionals, 0);
        assert_eq!(
            help.options["--token"],
            Opt {
                takes_value: true,
                env: Some("HEVO_TOKEN".into())
            }
        );
        assert_eq!(
            help.options["-t"],
            Opt {
                takes_value: true,
                env: Some("HEVO_THREADS".into())
            }
        );
        assert!(!help.options["--verbose"].takes_value && !help.options["-h"].takes_value);
        assert!(help.options["--listen"].env.is_none());
    }

    #[test]
    fn help_parser_reads_subcommands_and_required_arguments() {
        let top = parse_help(
            "Usage: hevo <COMMAND>\n\nCommands:\n  run    Evolve\n  serve  Serve\n  help   Print this\n\nOptions:\n  -h, --help  Print help\n",
        );
        assert_eq!(
            top.subcommands,
            BTreeSet::from(["run".to_string(), "serve".to_string()])
        );
        assert_eq!(top.required_positionals, 1);
        let fetch = parse_help("Usage: hevo fetch [OPTIONS] --master <URL> --out <DIR> <JOB>\n");
        assert_eq!(
            (fetch.required_flags.len(), fetch.required_positionals),
            (2, 1)
        );
    }

    #[test]
    fn help_parser_reads_the_scripts_usage_text() {
        // The scripts' own format: `--name <VALUE>` lines, grouped flags on one line.
        let help = parse_help(
            "usage: one-box.sh [options] EXPERIMENT\n\noptions:\n  --workers <N>      worker processes\n  --node <N>, --runs <R>\n                     passed on\n  -h, --help         this text\n",
        );
        assert!(help.options["--workers"].takes_value);
        assert!(help.options["--node"].takes_value && help.options["--runs"].takes_value);
        assert!(!help.options["--help"].takes_value);
    }
}
