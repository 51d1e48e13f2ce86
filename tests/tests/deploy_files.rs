//! Drift check for deploy/: the files users start hevo with on Docker, Kubernetes and SLURM must
//! not silently fall out of step with the binaries. This test parses every file there (the
//! Dockerfile, the compose file, each Kubernetes manifest and kustomization, the SLURM and
//! one-box scripts, and the shell blocks of deploy/README.md), extracts every `hevo` and
//! `hevo-worker` command line, environment variable, port and health probe they use, and checks
//! them against what the binaries really accept: their own `--help` (subcommands, flags, which
//! flags take a value, required flags and arguments, the environment variables behind flags), and,
//! for the things `--help` cannot show, a live `hevo serve` started with the deploy files' own
//! arguments (health services answering SERVING without a token, the metrics path, the compose
//! health check, the token being enforced).
//!
//! The binaries come from `cargo build -p hevo-cli -p hevo-worker` in the tests' profile
//! (see `hevo_tests::binaries`), or from the directory in `HEVO_TEST_BIN_DIR` when it is set. `shellcheck` is used when installed.

use hevo_tests::{Proc, Scratch, binaries, http_get, lines_of, repo_root};
use serde_norway::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Display;
use std::io::Write;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::sync::mpsc;
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------
// The binaries and their help

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

/// What each program accepts, from its own `--help`.
#[derive(Debug, Clone)]
struct Helps {
    hevo: Help,
    hevo_subcommands: BTreeMap<String, Help>,
    worker: Help,
    one_box: Help,
    sbatch: Help,
}

impl Helps {
    fn all_env(&self) -> BTreeSet<String> {
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

fn helps() -> &'static Helps {
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

// ---------------------------------------------------------------------------------------------
// Help parsing (clap's format, which the scripts' own --help follows too)

#[derive(Debug, Default, Clone, PartialEq)]
struct Opt {
    takes_value: bool,
    env: Option<String>,
}

#[derive(Debug, Default, Clone)]
struct Help {
    /// `--listen`, `-h`, ... with whether each takes a value and its environment variable.
    options: BTreeMap<String, Opt>,
    /// Long flags the usage line shows outside brackets.
    required_flags: Vec<String>,
    /// `<ARG>`s the usage line shows outside brackets.
    required_positionals: usize,
    /// From a `Commands:` section (without `help`).
    subcommands: BTreeSet<String>,
}

fn parse_help(text: &str) -> Help {
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
                help.options
                    .get_mut(option)
                    .expect("current option recorded")
                    .env = Some(name.clone());
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

// ---------------------------------------------------------------------------------------------
// A small shell lexer: enough of bash to find the simple commands of the scripts and of the
// README's shell blocks, with quotes removed, command substitutions, `bash -c` and `--wrap`
// strings looked into, redirections and heredoc bodies left out.

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String),
    Op(String),
}

#[derive(Debug, Default)]
struct Lexed {
    tokens: Vec<(Tok, usize)>,
    /// Texts of `$(...)`, backticks and `<(...)`, with the line they start on.
    nested: Vec<(String, usize)>,
}

struct Lexer {
    chars: Vec<char>,
    i: usize,
    line: usize,
    word: String,
    in_word: bool,
    word_line: usize,
    out: Lexed,
    heredoc_expected: Option<bool>,
    heredocs: Vec<(String, bool)>,
}

fn lex(text: &str, first_line: usize) -> Lexed {
    let mut lexer = Lexer {
        chars: text.chars().collect(),
        i: 0,
        line: first_line,
        word: String::new(),
        in_word: false,
        word_line: first_line,
        out: Lexed::default(),
        heredoc_expected: None,
        heredocs: Vec::new(),
    };
    lexer.run();
    lexer.out
}

impl Lexer {
    fn peek(&self, offset: usize) -> Option<char> {
        self.chars.get(self.i + offset).copied()
    }

    fn start_word(&mut self) {
        if !self.in_word {
            self.in_word = true;
            self.word_line = self.line;
        }
    }

    fn finish_word(&mut self) {
        if self.in_word {
            let word = std::mem::take(&mut self.word);
            if let Some(strip_tabs) = self.heredoc_expected.take() {
                self.heredocs.push((word.clone(), strip_tabs));
            }
            self.out.tokens.push((Tok::Word(word), self.word_line));
            self.in_word = false;
        }
    }

    /// Raw text up to the bracket closing one already consumed; quotes are skipped over.
    fn read_balanced(&mut self, open: char, close: char) -> String {
        let mut depth = 1;
        let mut raw = String::new();
        while let Some(c) = self.peek(0) {
            self.i += 1;
            match c {
                '\n' => self.line += 1,
                '\\' => {
                    raw.push(c);
                    if let Some(next) = self.peek(0) {
                        if next == '\n' {
                            self.line += 1;
                        }
                        raw.push(next);
                        self.i += 1;
                    }
                    continue;
                }
                '\'' | '"' => {
                    raw.push(c);
                    while let Some(q) = self.peek(0) {
                        self.i += 1;
                        raw.push(q);
                        if q == '\n' {
                            self.line += 1;
                        }
                        if q == '\\' && c == '"' {
                            if let Some(next) = self.peek(0) {
                                raw.push(next);
                                self.i += 1;
                            }
                        } else if q == c {
                            break;
                        }
                    }
                    continue;
                }
                _ if c == open => depth += 1,
                _ if c == close => {
                    depth -= 1;
                    if depth == 0 {
                        return raw;
                    }
                }
                _ => {}
            }
            raw.push(c);
        }
        raw
    }

    fn read_backticks(&mut self) -> String {
        let mut raw = String::new();
        while let Some(c) = self.peek(0) {
            self.i += 1;
            match c {
                '`' => break,
                '\\' => {
                    if let Some(next) = self.peek(0) {
                        raw.push(next);
                        self.i += 1;
                    }
                }
                '\n' => {
                    self.line += 1;
                    raw.push(c);
                }
                _ => raw.push(c),
            }
        }
        raw
    }

    /// After a `$`: command substitution, `${...}`, or a plain dollar.
    fn dollar(&mut self) {
        self.start_word();
        match self.peek(0) {
            Some('(') => {
                self.i += 1;
                let line = self.line;
                let inner = self.read_balanced('(', ')');
                self.word.push_str(&format!("$({inner})"));
                self.out.nested.push((inner, line));
            }
            Some('{') => {
                self.i += 1;
                let inner = self.read_balanced('{', '}');
                self.word.push_str(&format!("${{{inner}}}"));
            }
            _ => self.word.push('$'),
        }
    }

    fn skip_heredoc_bodies(&mut self) {
        for (delimiter, strip_tabs) in std::mem::take(&mut self.heredocs) {
            while self.i < self.chars.len() {
                let start = self.i;
                while self.i < self.chars.len() && self.chars[self.i] != '\n' {
                    self.i += 1;
                }
                let text: String = self.chars[start..self.i].iter().collect();
                self.i += 1;
                self.line += 1;
                let text = if strip_tabs {
                    text.trim_start_matches('\t')
                } else {
                    text.as_str()
                };
                if text == delimiter {
                    break;
                }
            }
        }
    }

    fn run(&mut self) {
        while let Some(c) = self.peek(0) {
            match c {
                ' ' | '\t' | '\r' => {
                    self.finish_word();
                    self.i += 1;
                }
                '\n' => {
                    self.finish_word();
                    self.out.tokens.push((Tok::Op("\n".into()), self.line));
                    self.i += 1;
                    self.line += 1;
                    self.skip_heredoc_bodies();
                }
                '#' if !self.in_word => {
                    while self.peek(0).is_some_and(|c| c != '\n') {
                        self.i += 1;
                    }
                }
                '\\' => {
                    if self.peek(1) == Some('\n') {
                        self.i += 2;
                        self.line += 1;
                    } else {
                        self.start_word();
                        if let Some(next) = self.peek(1) {
                            self.word.push(next);
                        }
                        self.i += 2;
                    }
                }
                '\'' => {
                    self.start_word();
                    self.i += 1;
                    while let Some(q) = self.peek(0) {
                        self.i += 1;
                        if q == '\'' {
                            break;
                        }
                        if q == '\n' {
                            self.line += 1;
                        }
                        self.word.push(q);
                    }
                }
                '"' => {
                    self.start_word();
                    self.i += 1;
                    while let Some(q) = self.peek(0) {
                        self.i += 1;
                        match q {
                            '"' => break,
                            '\\' => match self.peek(0) {
                                Some(next @ ('"' | '\\' | '$' | '`')) => {
                                    self.word.push(next);
                                    self.i += 1;
                                }
                                Some('\n') => {
                                    self.i += 1;
                                    self.line += 1;
                                }
                                _ => self.word.push('\\'),
                            },
                            '$' => self.dollar(),
                            '`' => {
                                let line = self.line;
                                let inner = self.read_backticks();
                                self.word.push_str(&format!("`{inner}`"));
                                self.out.nested.push((inner, line));
                            }
                            '\n' => {
                                self.line += 1;
                                self.word.push(q);
                            }
                            _ => self.word.push(q),
                        }
                    }
                }
                '$' => {
                    self.i += 1;
                    self.dollar();
                }
                '`' => {
                    self.start_word();
                    self.i += 1;
                    let line = self.line;
                    let inner = self.read_backticks();
                    self.word.push_str(&format!("`{inner}`"));
                    self.out.nested.push((inner, line));
                }
                ';' | '&' | '|' | '(' | ')' | '<' | '>' => {
                    // `<(...)`: process substitution, a word.
                    if (c == '<' || c == '>') && self.peek(1) == Some('(') {
                        self.start_word();
                        self.i += 2;
                        let line = self.line;
                        let inner = self.read_balanced('(', ')');
                        self.word.push_str(&format!("{c}({inner})"));
                        self.out.nested.push((inner, line));
                        continue;
                    }
                    // `2>&1`: the digits are a file descriptor, not a word.
                    if (c == '<' || c == '>')
                        && self.in_word
                        && self.word.chars().all(|d| d.is_ascii_digit())
                    {
                        self.word.clear();
                        self.in_word = false;
                    }
                    self.finish_word();
                    let rest: String = self.chars[self.i..].iter().take(3).collect();
                    let op = [
                        "<<<", "&>>", "<<-", "&&", "||", ";;", ">>", "<<", ">&", "<&", "&>", ">|",
                        "|&",
                    ]
                    .into_iter()
                    .find(|op| rest.starts_with(op))
                    .map_or_else(|| c.to_string(), str::to_string);
                    self.i += op.chars().count();
                    if op == "<<" || op == "<<-" {
                        self.heredoc_expected = Some(op == "<<-");
                    }
                    self.out.tokens.push((Tok::Op(op), self.line));
                }
                _ => {
                    self.start_word();
                    self.word.push(c);
                    self.i += 1;
                }
            }
        }
        self.finish_word();
    }
}

#[derive(Debug, Clone)]
struct SimpleCommand {
    words: Vec<String>,
    line: usize,
}

fn simple_commands(tokens: &[(Tok, usize)]) -> Vec<SimpleCommand> {
    let mut commands = Vec::new();
    let mut current: Vec<String> = Vec::new();
    let mut line = 0;
    let mut skip_word = false;
    let mut flush = |current: &mut Vec<String>, line: usize| {
        if !current.is_empty() {
            commands.push(SimpleCommand {
                words: std::mem::take(current),
                line,
            });
        }
    };
    for (token, token_line) in tokens {
        match token {
            Tok::Word(word) => {
                if std::mem::take(&mut skip_word) {
                    continue;
                }
                if current.is_empty() {
                    if [
                        "if", "then", "else", "elif", "fi", "do", "done", "while", "until", "!",
                        "{", "}", "time", "esac",
                    ]
                    .contains(&word.as_str())
                    {
                        continue;
                    }
                    line = *token_line;
                }
                current.push(word.clone());
            }
            Tok::Op(op) => match op.as_str() {
                "<" | ">" | ">>" | ">&" | "<&" | "&>" | "&>>" | "<<" | "<<-" | "<<<" | ">|" => {
                    skip_word = true
                }
                _ => flush(&mut current, line),
            },
        }
    }
    flush(&mut current, line);
    commands
}

// ---------------------------------------------------------------------------------------------
// Invocations of the programs

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Program {
    Hevo,
    Worker,
    OneBox,
    Sbatch,
}

fn program_of(word: &str) -> Option<Program> {
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

#[derive(Debug, Clone)]
struct Invocation {
    origin: String,
    program: Program,
    args: Vec<String>,
    /// Environment variables the invocation gets from its surroundings (exports, container env).
    env: BTreeSet<String>,
}

impl Invocation {
    fn subcommand(&self) -> Option<&str> {
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
    fn flag(&self, flag: &str) -> Option<&str> {
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
}

/// Commands that run another command given as one of their later words.
const PREFIX_COMMANDS: &[&str] = &[
    "exec", "nohup", "setsid", "timeout", "env", "command", "stdbuf", "nice", "srun", "sbatch",
    "mpirun", "sudo", "docker", "kubectl", "xargs", "time",
];

fn is_assignment(word: &str) -> bool {
    word.split_once('=').is_some_and(|(name, _)| {
        !name.is_empty()
            && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !name.starts_with(|c: char| c.is_ascii_digit())
    })
}

/// Every invocation in a shell text (recursively into substitutions, `bash -c` and `--wrap`).
fn shell_invocations(
    text: &str,
    first_line: usize,
    file: &str,
    env: &BTreeSet<String>,
    out: &mut Vec<Invocation>,
) {
    let lexed = lex(text, first_line);
    for (inner, line) in &lexed.nested {
        shell_invocations(inner, *line, file, env, out);
    }
    for command in simple_commands(&lexed.tokens) {
        let mut words = command.words.as_slice();
        let mut command_env = env.clone();
        while let Some((first, rest)) = words.split_first() {
            if !is_assignment(first) {
                break;
            }
            command_env.insert(first.split('=').next().unwrap().to_string());
            words = rest;
        }
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
                shell_invocations(&script, command.line, file, &command_env, out);
            }
        }
        let origin = format!("{file}:{}", command.line);
        let found = if let Some(program) = program_of(first) {
            Some((program, &words[1..]))
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
                .position(|w| program_of(w).is_some())
                .map(|p| {
                    (
                        program_of(&words[start + p]).unwrap(),
                        &words[start + p + 1..],
                    )
                })
        } else {
            None
        };
        if let Some((program, args)) = found {
            out.push(Invocation {
                origin,
                program,
                args: args.to_vec(),
                env: command_env,
            });
        }
    }
}

/// Names a shell text exports (`export A B=1`).
fn exported_names(text: &str) -> BTreeSet<String> {
    let lexed = lex(text, 1);
    let mut names = BTreeSet::new();
    for command in simple_commands(&lexed.tokens) {
        if command.words.first().is_some_and(|w| w == "export") {
            for word in &command.words[1..] {
                if !word.starts_with('-') {
                    names.insert(word.split('=').next().unwrap().to_string());
                }
            }
        }
    }
    names
}

// ---------------------------------------------------------------------------------------------
// Checking

#[derive(Debug, Default)]
struct Problems(Vec<String>);

impl Problems {
    fn add(&mut self, origin: &str, message: impl Display) {
        self.0.push(format!("{origin}: {message}"));
    }

    fn check(&mut self, ok: bool, origin: &str, message: impl Display) {
        if !ok {
            self.add(origin, message);
        }
    }

    fn mention(&self, needle: &str) -> bool {
        self.0.iter().any(|p| p.contains(needle))
    }
}

fn help_for<'h>(
    helps: &'h Helps,
    invocation: &Invocation,
    problems: &mut Problems,
) -> Option<(&'h Help, usize)> {
    match invocation.program {
        Program::Hevo => match invocation.subcommand() {
            None => Some((&helps.hevo, 0)),
            Some(sub) => match helps.hevo_subcommands.get(sub) {
                Some(help) => Some((help, 1)),
                None => {
                    problems.add(
                        &invocation.origin,
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

fn program_name(invocation: &Invocation) -> String {
    match invocation.program {
        Program::Hevo => format!("hevo {}", invocation.subcommand().unwrap_or(""))
            .trim_end()
            .to_string(),
        Program::Worker => "hevo-worker".into(),
        Program::OneBox => "one-box.sh".into(),
        Program::Sbatch => "hevo.sbatch".into(),
    }
}

fn check_invocation(helps: &Helps, invocation: &Invocation, problems: &mut Problems) {
    let Some((help, skip)) = help_for(helps, invocation, problems) else {
        return;
    };
    let name = program_name(invocation);
    let origin = &invocation.origin;
    let mut used = BTreeSet::new();
    let mut positionals = 0;
    let mut asks_help = false;
    let mut args = invocation.args[skip..].iter();
    while let Some(arg) = args.next() {
        if arg == "--" {
            positionals += args.len();
            break;
        }
        if arg.starts_with('-') && arg.len() > 1 && !arg.starts_with("-$") {
            let flag = arg.split('=').next().unwrap();
            asks_help |= ["--help", "-h", "--version", "-V"].contains(&flag);
            match help.options.get(flag) {
                None => problems.add(origin, format!("`{name}` has no option `{flag}`")),
                Some(option) => {
                    used.insert(flag.to_string());
                    if option.takes_value && !arg.contains('=') {
                        match args.next() {
                            None => problems.add(origin, format!("`{name} {flag}` needs a value")),
                            Some(value) if value.starts_with("--") => problems.add(
                                origin,
                                format!("`{name} {flag}` needs a value, got the option `{value}`"),
                            ),
                            Some(_) => {}
                        }
                    } else if !option.takes_value && arg.contains('=') {
                        problems.add(origin, format!("`{name} {flag}` takes no value"));
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
        problems.check(
            used.contains(required) || from_env,
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
fn port_of(address: &str) -> Option<u16> {
    address.rsplit(':').next()?.parse().ok()
}

/// `http://host:port/...` -> (host, port).
fn url_host_port(url: &str) -> Option<(String, u16)> {
    let rest = url.split_once("://").map_or(url, |(_, rest)| rest);
    let authority = rest.split('/').next()?;
    let (host, port) = authority.rsplit_once(':')?;
    Some((host.to_string(), port.parse().ok()?))
}

/// Compose durations (`90s`, `1m30s`, `2m`) in seconds.
fn duration_seconds(text: &str) -> Option<f64> {
    let mut total = 0.0;
    let mut number = String::new();
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_ascii_digit() || c == '.' {
            number.push(c);
            continue;
        }
        let value: f64 = std::mem::take(&mut number).parse().ok()?;
        total += value
            * match c {
                'h' => 3600.0,
                'm' if chars.peek() == Some(&'s') => {
                    chars.next();
                    0.001
                }
                'm' => 60.0,
                's' => 1.0,
                _ => return None,
            };
    }
    if !number.is_empty() {
        return None;
    }
    Some(total)
}

fn scalar(value: &Value) -> Option<String> {
    match value {
        Value::String(s) => Some(s.clone()),
        Value::Number(n) => Some(n.to_string()),
        Value::Bool(b) => Some(b.to_string()),
        _ => None,
    }
}

fn strings(value: Option<&Value>) -> Vec<String> {
    match value {
        Some(Value::Sequence(items)) => items.iter().filter_map(scalar).collect(),
        Some(other) => scalar(other).into_iter().collect(),
        None => Vec::new(),
    }
}

fn at<'v>(value: &'v Value, path: &[&str]) -> Option<&'v Value> {
    path.iter().try_fold(value, |v, key| v.get(*key))
}

fn str_at(value: &Value, path: &[&str]) -> Option<String> {
    at(value, path).and_then(scalar)
}

fn seq(value: Option<&Value>) -> &[Value] {
    match value {
        Some(Value::Sequence(items)) => items,
        _ => &[],
    }
}

fn parse_yaml_docs(origin: &str, text: &str, problems: &mut Problems) -> Vec<Value> {
    use serde::Deserialize;
    let mut docs = Vec::new();
    for document in serde_norway::Deserializer::from_str(text) {
        match Value::deserialize(document) {
            Ok(Value::Null) => {}
            Ok(value) => docs.push(value),
            Err(e) => problems.add(origin, format!("invalid YAML: {e}")),
        }
    }
    docs
}

/// The files of deploy/, by path relative to the repository root.
#[derive(Debug, Clone)]
struct DeployFiles {
    files: BTreeMap<String, String>,
}

impl DeployFiles {
    fn load() -> DeployFiles {
        let root = repo_root();
        let mut files = BTreeMap::new();
        let mut stack = vec![root.join("deploy")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).expect("read deploy/") {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else if let Ok(text) = std::fs::read_to_string(&path) {
                    let relative = path
                        .strip_prefix(&root)
                        .unwrap()
                        .to_string_lossy()
                        .replace('\\', "/");
                    files.insert(relative, text);
                }
            }
        }
        DeployFiles { files }
    }

    fn get(&self, path: &str) -> &str {
        self.files
            .get(path)
            .map_or_else(|| panic!("{path} is missing"), String::as_str)
    }

    fn replace(&mut self, path: &str, from: &str, to: &str) {
        let text = self.files.get_mut(path).unwrap();
        assert!(text.contains(from), "{path} does not contain {from:?}");
        *text = text.replacen(from, to, 1);
    }
}

/// Facts gathered from all files, compared across them at the end.
#[derive(Debug, Default)]
struct Facts {
    invocations: Vec<Invocation>,
    /// (origin, port) of every `hevo serve --listen` and `--metrics-listen` in a container.
    grpc_ports: Vec<(String, u16)>,
    metrics_ports: Vec<(String, u16)>,
    state_dirs: Vec<(String, String)>,
    /// Health service names used by probes.
    probe_services: BTreeSet<String>,
    metrics_paths: BTreeSet<String>,
    run_as_users: Vec<(String, i64)>,
    dockerfile_user: Option<i64>,
    dockerfile_cmd: Vec<String>,
    dockerfile_env: BTreeSet<String>,
    exposed: Vec<u16>,
    compose_healthcheck: Option<Vec<String>>,
    compose_master_argv: Option<(Vec<String>, BTreeSet<String>)>,
    k8s_master_argv: Option<Vec<String>>,
}

fn check_all(files: &DeployFiles, helps: &Helps) -> (Problems, Facts) {
    let mut problems = Problems::default();
    let mut facts = Facts::default();
    check_dockerfile(files, &mut problems, &mut facts);
    check_compose(files, &mut problems, &mut facts);
    check_kubernetes(files, &mut problems, &mut facts);
    check_scripts(files, &mut problems, &mut facts);
    check_readme(files, &mut problems, &mut facts);

    for invocation in &facts.invocations {
        check_invocation(helps, invocation, &mut problems);
    }

    // Every HEVO_ variable anywhere in deploy/ is one the binaries read: the prefix is theirs.
    let accepted = helps.all_env();
    for (path, text) in &files.files {
        let mut rest = text.as_str();
        while let Some(at) = rest.find("HEVO_") {
            let name: String = rest[at..]
                .chars()
                .take_while(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || *c == '_')
                .collect();
            problems.check(
                accepted.contains(&name),
                path,
                format!("`{name}` is not an environment variable hevo or hevo-worker reads (they read {accepted:?})"),
            );
            rest = &rest[at + name.len()..];
        }
    }

    // One port and one state directory everywhere.
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
        "deploy/Dockerfile",
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
    (problems, facts)
}

fn container_invocation(
    origin: String,
    argv: &[String],
    env: BTreeSet<String>,
) -> Option<Invocation> {
    let (first, args) = argv.split_first()?;
    let program = program_of(first)?;
    Some(Invocation {
        origin,
        program,
        args: args.to_vec(),
        env,
    })
}

/// Records the master's ports and state directory from a `hevo serve` command line.
fn record_serve(invocation: &Invocation, problems: &mut Problems, facts: &mut Facts) {
    match invocation.flag("--listen").and_then(port_of) {
        Some(port) => facts.grpc_ports.push((invocation.origin.clone(), port)),
        None => problems.add(
            &invocation.origin,
            "`hevo serve` without a literal --listen HOST:PORT",
        ),
    }
    if let Some(port) = invocation.flag("--metrics-listen").and_then(port_of) {
        facts.metrics_ports.push((invocation.origin.clone(), port));
    }
    match invocation.flag("--state-dir") {
        Some(dir) => facts
            .state_dirs
            .push((invocation.origin.clone(), dir.to_string())),
        None => problems.add(&invocation.origin, "`hevo serve` without --state-dir"),
    }
}

fn is_serve(invocation: &Invocation) -> bool {
    invocation.program == Program::Hevo && invocation.subcommand() == Some("serve")
}

// ---- Dockerfile

fn check_dockerfile(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let path = "deploy/Dockerfile";
    let text = files.get(path);
    problems.check(
        text.lines()
            .any(|l| l.starts_with("# ") && !l.starts_with("# syntax")),
        path,
        "starts with no comment saying what it is for",
    );
    // Instructions, continuation lines joined, comments dropped.
    let mut instructions: Vec<(String, String)> = Vec::new();
    let mut pending = String::new();
    for line in text.lines() {
        let trimmed = line.trim();
        if pending.is_empty() && (trimmed.is_empty() || trimmed.starts_with('#')) {
            continue;
        }
        if trimmed.starts_with('#') {
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
    let runtime = &instructions[last_from..];

    match runtime.iter().rev().find(|(k, _)| k == "USER") {
        None => problems.add(
            path,
            "the runtime stage sets no USER (it would run as root)",
        ),
        Some((_, user)) => match user.split(':').next().unwrap().parse::<i64>() {
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
                    if let Some(invocation) = container_invocation(format!("{path}: {keyword}"), &argv, BTreeSet::new()) {
                        facts.invocations.push(invocation);
                    }
                }
                Err(_) => problems.add(path, format!("{keyword} {rest}: use the exec (JSON) form, so that SIGTERM reaches the binary and not a shell")),
            },
            "ENV" => {
                let words: Vec<&str> = rest.split_whitespace().collect();
                if words.first().is_some_and(|w| w.contains('=')) {
                    facts.dockerfile_env.extend(words.iter().filter_map(|w| w.split_once('=').map(|(k, _)| k.to_string())));
                } else if let Some(name) = words.first() {
                    facts.dockerfile_env.insert(name.to_string());
                }
            }
            "EXPOSE" => {
                for port in rest.split_whitespace() {
                    match port.split('/').next().unwrap().parse::<u16>() {
                        Ok(port) => facts.exposed.push(port),
                        Err(_) => problems.add(path, format!("EXPOSE {port}: not a port number")),
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
            let command = &run[run.find("cargo build").unwrap()..];
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
fn workspace_packages() -> BTreeMap<String, Vec<String>> {
    let root = repo_root();
    let manifest: toml::Table = std::fs::read_to_string(root.join("Cargo.toml"))
        .unwrap()
        .parse()
        .unwrap();
    let members = manifest["workspace"]["members"]
        .as_array()
        .expect("workspace members")
        .clone();
    let mut packages = BTreeMap::new();
    for member in members {
        let dir = root.join(member.as_str().unwrap());
        let Ok(text) = std::fs::read_to_string(dir.join("Cargo.toml")) else {
            continue;
        };
        let manifest: toml::Table = text.parse().unwrap();
        let name = manifest["package"]["name"].as_str().unwrap().to_string();
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
            bins.push(name.clone());
        }
        packages.insert(name, bins);
    }
    packages
}

// ---- compose

fn check_compose(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let path = "deploy/compose.yaml";
    let text = files.get(path);
    problems.check(
        text.starts_with('#'),
        path,
        "starts with no comment saying what it is for",
    );
    let docs = parse_yaml_docs(path, text, problems);
    let Some(compose) = docs.first() else { return };
    let Some(Value::Mapping(services)) = compose.get("services") else {
        problems.add(path, "no services");
        return;
    };
    let top_volumes: BTreeSet<String> = match compose.get("volumes") {
        Some(Value::Mapping(m)) => m.keys().filter_map(scalar).collect(),
        _ => BTreeSet::new(),
    };
    let argv_of = |value: Option<&Value>| -> Option<Vec<String>> {
        match value? {
            Value::String(s) => simple_commands(&lex(s, 1).tokens)
                .into_iter()
                .next()
                .map(|c| c.words),
            other => Some(strings(Some(other))),
        }
    };
    let mut serve_services: BTreeMap<String, u16> = BTreeMap::new();
    let mut worker_masters: Vec<(String, String)> = Vec::new();
    let mut tokens: BTreeMap<String, String> = BTreeMap::new();
    for (name, service) in services {
        let name = scalar(name).unwrap_or_default();
        let origin = format!("{path}: services.{name}");
        if let Some(build) = service.get("build") {
            let context = str_at(build, &["context"]).unwrap_or_else(|| ".".into());
            let dockerfile = str_at(build, &["dockerfile"]).unwrap_or_else(|| "Dockerfile".into());
            let file = repo_root().join("deploy").join(&context).join(&dockerfile);
            problems.check(
                file.exists(),
                &origin,
                format!("build: {} does not exist", file.display()),
            );
        }
        let mut env: BTreeSet<String> = facts.dockerfile_env.clone();
        let mut env_values: BTreeMap<String, String> = BTreeMap::new();
        match service.get("environment") {
            Some(Value::Mapping(m)) => {
                for (k, v) in m {
                    let k = scalar(k).unwrap_or_default();
                    env_values.insert(k.clone(), scalar(v).unwrap_or_default());
                    env.insert(k);
                }
            }
            Some(Value::Sequence(items)) => {
                for item in items.iter().filter_map(scalar) {
                    let (k, v) = item.split_once('=').unwrap_or((&item, ""));
                    env_values.insert(k.to_string(), v.to_string());
                    env.insert(k.to_string());
                }
            }
            _ => {}
        }
        let mut argv = argv_of(service.get("entrypoint")).unwrap_or_default();
        argv.extend(
            argv_of(service.get("command")).unwrap_or_else(|| facts.dockerfile_cmd.clone()),
        );
        let Some(invocation) = container_invocation(origin.clone(), &argv, env.clone()) else {
            continue;
        };
        if let Some(token) = env_values.get("HEVO_TOKEN") {
            tokens.insert(name.clone(), token.clone());
        } else if invocation.flag("--token-file").is_none() && invocation.flag("--token").is_none()
        {
            problems.add(
                &origin,
                "runs hevo without the shared token (HEVO_TOKEN, --token or --token-file)",
            );
        }
        if is_serve(&invocation) {
            record_serve(&invocation, problems, facts);
            let grpc = invocation.flag("--listen").and_then(port_of).unwrap_or(0);
            let metrics = invocation.flag("--metrics-listen").and_then(port_of);
            serve_services.insert(name.clone(), grpc);
            facts.compose_master_argv = Some((argv.clone(), env.clone()));
            for port in strings(service.get("ports")) {
                let container = port
                    .rsplit(':')
                    .next()
                    .and_then(|p| p.split('/').next()?.parse::<u16>().ok());
                problems.check(
                    container == Some(grpc) || container == metrics,
                    &origin,
                    format!("publishes {port}, but the master listens on {grpc} and {metrics:?}"),
                );
            }
            let state_dir = invocation
                .flag("--state-dir")
                .unwrap_or_default()
                .to_string();
            let mounted = strings(service.get("volumes")).iter().any(|v| {
                let mut parts = v.split(':');
                let (source, target) = (
                    parts.next().unwrap_or_default(),
                    parts.next().unwrap_or_default(),
                );
                target == state_dir && top_volumes.contains(source)
            });
            problems.check(
                mounted,
                &origin,
                format!("the state directory {state_dir} is not on a named volume"),
            );
            match service.get("healthcheck").and_then(|h| h.get("test")) {
                None => problems.add(
                    &origin,
                    "the master has no healthcheck (workers wait for it to be healthy)",
                ),
                Some(test) => {
                    let test = strings(Some(test));
                    let argv: Vec<String> = match test.first().map(String::as_str) {
                        Some("CMD") => test[1..].to_vec(),
                        Some("CMD-SHELL") => simple_commands(&lex(&test[1..].join(" "), 1).tokens)
                            .into_iter()
                            .next()
                            .map(|c| c.words)
                            .unwrap_or_default(),
                        _ => test.clone(),
                    };
                    match container_invocation(format!("{origin}.healthcheck"), &argv, env.clone()) {
                        None => problems.add(&origin, format!("healthcheck {test:?} does not run hevo (the image has no shell or curl)")),
                        Some(check) => {
                            let port = check.flag("--master").and_then(url_host_port).map(|(_, p)| p);
                            problems.check(port == Some(grpc), &origin, format!("healthcheck dials port {port:?}, the master listens on {grpc}"));
                            facts.compose_healthcheck = Some(argv.clone());
                            facts.invocations.push(check);
                        }
                    }
                }
            }
        }
        if invocation.program == Program::Worker {
            let master = invocation
                .flag("--master")
                .map(str::to_string)
                .or_else(|| env_values.get("HEVO_MASTER").cloned());
            match master {
                Some(url) => worker_masters.push((origin.clone(), url)),
                None => problems.add(
                    &origin,
                    "the worker is not told where the master is (--master or HEVO_MASTER)",
                ),
            }
            let grace = service
                .get("stop_grace_period")
                .and_then(scalar)
                .and_then(|d| duration_seconds(&d));
            problems.check(
                grace.is_some_and(|g| g >= 60.0),
                &origin,
                format!("stop_grace_period {grace:?} s is less than the minute a worker needs to hand back its batch"),
            );
            let waits = at(service, &["depends_on"])
                .is_some_and(|d| serve_services.keys().any(|m| d.get(m.as_str()).is_some()));
            problems.check(waits, &origin, "the worker does not depend_on the master");
        }
        facts.invocations.push(invocation);
    }
    for (origin, url) in worker_masters {
        match url_host_port(&url) {
            Some((host, port)) => problems.check(
                serve_services.get(&host) == Some(&port),
                &origin,
                format!("the worker dials {url}, but the master service(s) are {serve_services:?}"),
            ),
            None => problems.add(&origin, format!("{url} is not a URL with a port")),
        }
    }
    let distinct: BTreeSet<&String> = tokens.values().collect();
    problems.check(
        distinct.len() <= 1,
        path,
        format!("the services do not share one token: {tokens:?}"),
    );
}

// ---- Kubernetes

#[derive(Debug, Clone)]
struct K8sObject {
    origin: String,
    value: Value,
}

impl K8sObject {
    fn kind(&self) -> String {
        str_at(&self.value, &["kind"]).unwrap_or_default()
    }

    fn name(&self) -> String {
        str_at(&self.value, &["metadata", "name"]).unwrap_or_default()
    }
}

fn labels_match(selector: Option<&Value>, labels: Option<&Value>) -> bool {
    let (Some(Value::Mapping(selector)), Some(Value::Mapping(labels))) = (selector, labels) else {
        return false;
    };
    !selector.is_empty() && selector.iter().all(|(k, v)| labels.get(k) == Some(v))
}

fn check_kubernetes(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let base = "deploy/k8s/";
    // Every kustomization and what it pulls in.
    let mut objects: Vec<K8sObject> = Vec::new();
    let mut referenced: BTreeSet<String> = BTreeSet::new();
    let mut secret_keys: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut patch_targets: Vec<(String, Option<String>, Option<String>)> = Vec::new();
    let kustomizations: Vec<&String> = files
        .files
        .keys()
        .filter(|p| p.starts_with(base) && p.ends_with("/kustomization.yaml"))
        .collect();
    problems.check(
        kustomizations.contains(&&format!("{base}kustomization.yaml")),
        base,
        "no kustomization.yaml",
    );
    for path in &kustomizations {
        let text = files.get(path);
        problems.check(
            text.starts_with('#'),
            path,
            "starts with no comment saying what it is for",
        );
        let dir = path.trim_end_matches("kustomization.yaml");
        let docs = parse_yaml_docs(path, text, problems);
        let Some(kustomization) = docs.first() else {
            continue;
        };
        for resource in strings(kustomization.get("resources")) {
            let target = normalize(&format!("{dir}{resource}"));
            if files.files.contains_key(&target) {
                referenced.insert(target.clone());
                for value in parse_yaml_docs(&target, files.get(&target), problems) {
                    objects.push(K8sObject {
                        origin: target.clone(),
                        value,
                    });
                }
            } else {
                problems.check(
                    files.files.contains_key(&format!(
                        "{}/kustomization.yaml",
                        target.trim_end_matches('/')
                    )),
                    path,
                    format!("resource {resource} does not exist"),
                );
            }
        }
        for component in strings(kustomization.get("components")) {
            let target = normalize(&format!("{dir}{component}/kustomization.yaml"));
            problems.check(
                files.files.contains_key(&target),
                path,
                format!("component {component} does not exist"),
            );
        }
        if str_at(kustomization, &["kind"]).as_deref() == Some("Component") {
            // A component must be reachable from the base, if only by a commented-out line.
            let name = dir
                .trim_end_matches('/')
                .rsplit('/')
                .next()
                .unwrap_or_default();
            problems.check(
                files
                    .get(&format!("{base}kustomization.yaml"))
                    .contains(name),
                path,
                format!("the component {name} is not mentioned in {base}kustomization.yaml"),
            );
        }
        for generator in seq(kustomization.get("secretGenerator")) {
            let name = str_at(generator, &["name"]).unwrap_or_default();
            let keys = secret_keys.entry(name).or_default();
            for file in strings(generator.get("files")) {
                keys.insert(file.split_once('=').map_or_else(
                    || file.rsplit('/').next().unwrap().to_string(),
                    |(k, _)| k.to_string(),
                ));
            }
            for literal in strings(generator.get("literals")) {
                keys.insert(literal.split('=').next().unwrap().to_string());
            }
        }
        for patch in seq(kustomization.get("patches")) {
            patch_targets.push((
                path.to_string(),
                str_at(patch, &["target", "kind"]),
                str_at(patch, &["target", "name"]),
            ));
        }
    }
    for path in files.files.keys().filter(|p| {
        p.starts_with(base) && p.ends_with(".yaml") && !p.ends_with("/kustomization.yaml")
    }) {
        problems.check(
            referenced.contains(path),
            path,
            "no kustomization lists this manifest",
        );
        problems.check(
            files.get(path).starts_with('#'),
            path,
            "starts with no comment saying what it is for",
        );
    }
    for object in &objects {
        if object.kind() == "Secret" {
            let keys = secret_keys.entry(object.name()).or_default();
            for field in ["data", "stringData"] {
                if let Some(Value::Mapping(m)) = object.value.get(field) {
                    keys.extend(m.keys().filter_map(scalar));
                }
            }
        }
    }
    // Patch targets exist.
    for (origin, kind, name) in patch_targets {
        problems.check(
            objects
                .iter()
                .any(|o| Some(o.kind()) == kind && Some(o.name()) == name),
            &origin,
            format!("patch target {kind:?} {name:?} does not exist"),
        );
    }

    let workloads: Vec<&K8sObject> = objects
        .iter()
        .filter(|o| ["Deployment", "StatefulSet"].contains(&o.kind().as_str()))
        .collect();
    // (service name, port, target container port) for Services in front of `hevo serve`.
    let mut master_endpoints: Vec<(String, u16, u16)> = Vec::new();
    let mut worker_urls: Vec<(String, String)> = Vec::new();
    let mut serve_pod_labels: Vec<Value> = Vec::new();
    let mut worker_pod_labels: Vec<Value> = Vec::new();
    let mut container_ports: Vec<(Value, BTreeMap<String, u16>)> = Vec::new();
    let mut has_serve = false;
    let mut has_worker = false;
    for workload in &workloads {
        let origin = format!(
            "{}: {} {}",
            workload.origin,
            workload.kind(),
            workload.name()
        );
        let template = at(&workload.value, &["spec", "template"])
            .cloned()
            .unwrap_or(Value::Null);
        let labels = at(&template, &["metadata", "labels"]).cloned();
        problems.check(
            labels_match(
                at(&workload.value, &["spec", "selector", "matchLabels"]),
                labels.as_ref(),
            ),
            &origin,
            "spec.selector.matchLabels does not match the pod template's labels",
        );
        let pod = at(&template, &["spec"]).cloned().unwrap_or(Value::Null);
        let pod_security = pod.get("securityContext").cloned().unwrap_or(Value::Null);
        let mut volumes: BTreeMap<String, Value> = seq(pod.get("volumes"))
            .iter()
            .map(|v| (str_at(v, &["name"]).unwrap_or_default(), v.clone()))
            .collect();
        let claims: BTreeSet<String> = seq(at(&workload.value, &["spec", "volumeClaimTemplates"]))
            .iter()
            .filter_map(|c| str_at(c, &["metadata", "name"]))
            .collect();
        for claim in &claims {
            volumes.insert(claim.clone(), Value::String("persistentVolumeClaim".into()));
        }
        let grace = at(&pod, &["terminationGracePeriodSeconds"])
            .and_then(Value::as_i64)
            .unwrap_or(30);
        for container in seq(pod.get("containers")) {
            let container_name = str_at(container, &["name"]).unwrap_or_default();
            let origin = format!("{origin} container {container_name}");
            let env_names: BTreeSet<String> = seq(container.get("env"))
                .iter()
                .filter_map(|e| str_at(e, &["name"]))
                .collect();
            let env_value = |name: &str| {
                seq(container.get("env"))
                    .iter()
                    .find(|e| str_at(e, &["name"]).as_deref() == Some(name))
                    .and_then(|e| str_at(e, &["value"]))
            };
            let mut argv = strings(container.get("command"));
            let args = strings(container.get("args"));
            if argv.is_empty() && args.is_empty() {
                argv = facts.dockerfile_cmd.clone();
            } else {
                argv.extend(args);
            }
            // $(VAR) in a command line is expanded by the kubelet only when VAR is in env.
            for arg in &argv {
                let mut rest = arg.as_str();
                while let Some(start) = rest.find("$(") {
                    let Some(len) = rest[start..].find(')') else {
                        break;
                    };
                    let var = &rest[start + 2..start + len];
                    problems.check(
                        env_names.contains(var),
                        &origin,
                        format!("$({var}) is not an env variable of the container"),
                    );
                    rest = &rest[start + len..];
                }
            }
            let mut env = env_names.clone();
            env.extend(facts.dockerfile_env.iter().cloned());
            let ports: BTreeMap<String, u16> = seq(container.get("ports"))
                .iter()
                .filter_map(|p| {
                    Some((
                        str_at(p, &["name"]).unwrap_or_default(),
                        at(p, &["containerPort"])?.as_u64()? as u16,
                    ))
                })
                .collect();
            container_ports.push((labels.clone().unwrap_or(Value::Null), ports.clone()));
            let mounts: Vec<(String, String)> = seq(container.get("volumeMounts"))
                .iter()
                .map(|m| {
                    (
                        str_at(m, &["name"]).unwrap_or_default(),
                        str_at(m, &["mountPath"]).unwrap_or_default(),
                    )
                })
                .collect();
            for (volume, _) in &mounts {
                problems.check(
                    volumes.contains_key(volume),
                    &origin,
                    format!("mounts the volume {volume}, which the pod does not have"),
                );
            }
            // Requests, so the scheduler can place it; a non-root identity matching the image.
            for resource in ["cpu", "memory"] {
                problems.check(
                    at(container, &["resources", "requests", resource]).is_some(),
                    &origin,
                    format!("no resources.requests.{resource}"),
                );
            }
            let security = container
                .get("securityContext")
                .cloned()
                .unwrap_or(Value::Null);
            let non_root = [&security, &pod_security]
                .iter()
                .any(|s| at(s, &["runAsNonRoot"]).and_then(Value::as_bool) == Some(true));
            problems.check(non_root, &origin, "runAsNonRoot is not set");
            match [&security, &pod_security]
                .iter()
                .find_map(|s| at(s, &["runAsUser"]).and_then(Value::as_i64))
            {
                Some(uid) => facts.run_as_users.push((origin.clone(), uid)),
                None => problems.add(&origin, "runAsUser is not set"),
            }
            let Some(invocation) = container_invocation(origin.clone(), &argv, env) else {
                continue;
            };
            // The token: a file from a mounted Secret that has that key, or HEVO_TOKEN from one.
            if let Some(token_file) = invocation.flag("--token-file") {
                let (dir, key) = token_file.rsplit_once('/').unwrap_or(("", token_file));
                let secret = mounts
                    .iter()
                    .find(|(_, path)| path.trim_end_matches('/') == dir)
                    .and_then(|(volume, _)| volumes.get(volume))
                    .and_then(|v| str_at(v, &["secret", "secretName"]));
                match secret {
                    None => problems.add(&origin, format!("--token-file {token_file} is not in a mounted Secret")),
                    Some(secret) => problems.check(
                        secret_keys.get(&secret).is_some_and(|keys| keys.contains(key)),
                        &origin,
                        format!("--token-file {token_file}: the Secret {secret} has no key {key} (has {:?})", secret_keys.get(&secret)),
                    ),
                }
            } else {
                let from_secret = seq(container.get("env")).iter().any(|e| {
                    str_at(e, &["name"]).as_deref() == Some("HEVO_TOKEN")
                        && str_at(e, &["valueFrom", "secretKeyRef", "name"])
                            .is_some_and(|s| secret_keys.contains_key(&s))
                });
                problems.check(
                    from_secret,
                    &origin,
                    "no token: neither --token-file from a Secret nor HEVO_TOKEN from one",
                );
            }
            if is_serve(&invocation) {
                has_serve = true;
                record_serve(&invocation, problems, facts);
                facts.k8s_master_argv = Some(argv.clone());
                serve_pod_labels.extend(labels.clone());
                let grpc = invocation.flag("--listen").and_then(port_of).unwrap_or(0);
                let metrics = invocation.flag("--metrics-listen").and_then(port_of);
                problems.check(
                    ports.values().any(|p| *p == grpc),
                    &origin,
                    format!("no containerPort {grpc} (the --listen port)"),
                );
                if let Some(metrics) = metrics {
                    problems.check(
                        ports.values().any(|p| *p == metrics),
                        &origin,
                        format!("no containerPort {metrics} (the --metrics-listen port)"),
                    );
                    let annotations = at(&template, &["metadata", "annotations"]);
                    if let Some(port) = annotations
                        .and_then(|a| a.get("prometheus.io/port"))
                        .and_then(scalar)
                    {
                        problems.check(
                            port == metrics.to_string(),
                            &origin,
                            format!("prometheus.io/port {port} is not the metrics port {metrics}"),
                        );
                    }
                    if let Some(path) = annotations
                        .and_then(|a| a.get("prometheus.io/path"))
                        .and_then(scalar)
                    {
                        facts.metrics_paths.insert(path);
                    }
                }
                for probe in ["readinessProbe", "livenessProbe"] {
                    problems.check(
                        at(container, &[probe, "grpc"]).is_some(),
                        &origin,
                        format!("the master has no gRPC {probe}"),
                    );
                }
                for probe in ["startupProbe", "readinessProbe", "livenessProbe"] {
                    let Some(probe_value) = container.get(probe) else {
                        continue;
                    };
                    match probe_value.get("grpc") {
                        None => {
                            problems.add(&origin, format!("{probe} is not a gRPC health probe"))
                        }
                        Some(grpc_probe) => {
                            let port = at(grpc_probe, &["port"]).and_then(Value::as_u64);
                            problems.check(
                                port == Some(grpc as u64),
                                &origin,
                                format!(
                                    "{probe} probes port {port:?}, the master listens on {grpc}"
                                ),
                            );
                            facts
                                .probe_services
                                .insert(str_at(grpc_probe, &["service"]).unwrap_or_default());
                        }
                    }
                }
                problems.check(
                    invocation.flag("--tls-cert").is_none(),
                    &origin,
                    "the kubelet's gRPC probes are plaintext: with --tls-cert they would fail",
                );
                let state_dir = invocation.flag("--state-dir").unwrap_or_default();
                let persistent = mounts
                    .iter()
                    .any(|(volume, path)| path == state_dir && claims.contains(volume));
                problems.check(
                    persistent,
                    &origin,
                    format!("the state directory {state_dir} is not on a volumeClaimTemplate"),
                );
                problems.check(grace >= 30, &origin, format!("terminationGracePeriodSeconds {grace} leaves the master no time to save its state"));
            }
            if invocation.program == Program::Worker {
                has_worker = true;
                worker_pod_labels.extend(labels.clone());
                match invocation
                    .flag("--master")
                    .map(str::to_string)
                    .or_else(|| env_value("HEVO_MASTER"))
                {
                    Some(url) => worker_urls.push((origin.clone(), url)),
                    None => problems.add(
                        &origin,
                        "the worker is not told where the master is (--master or HEVO_MASTER)",
                    ),
                }
                problems.check(
                    grace >= 60,
                    &origin,
                    format!("terminationGracePeriodSeconds {grace} is less than the minute a worker needs to hand back its batch"),
                );
                problems.check(
                    workload.kind() == "Deployment",
                    &origin,
                    "workers should be a Deployment, scaled by its replica count",
                );
            }
            facts.invocations.push(invocation);
        }
    }
    problems.check(has_serve, base, "no container runs `hevo serve`");
    problems.check(has_worker, base, "no container runs `hevo-worker`");
    problems.check(
        workloads.iter().any(|w| {
            w.kind() == "StatefulSet"
                && serve_pod_labels.iter().any(|l| {
                    labels_match(at(&w.value, &["spec", "selector", "matchLabels"]), Some(l))
                })
        }),
        base,
        "the master is not a StatefulSet",
    );

    for object in &objects {
        let origin = format!("{}: {} {}", object.origin, object.kind(), object.name());
        match object.kind().as_str() {
            "Service" => {
                let selector = at(&object.value, &["spec", "selector"]);
                let selected: Vec<&BTreeMap<String, u16>> = container_ports
                    .iter()
                    .filter(|(labels, _)| labels_match(selector, Some(labels)))
                    .map(|(_, p)| p)
                    .collect();
                problems.check(
                    !selected.is_empty(),
                    &origin,
                    "its selector matches no pod template",
                );
                for port in seq(at(&object.value, &["spec", "ports"])) {
                    let service_port =
                        at(port, &["port"]).and_then(Value::as_u64).unwrap_or(0) as u16;
                    let target = at(port, &["targetPort"])
                        .and_then(scalar)
                        .unwrap_or_else(|| service_port.to_string());
                    let resolved = selected
                        .iter()
                        .find_map(|ports| match target.parse::<u16>() {
                            Ok(number) => ports.values().find(|p| **p == number).copied(),
                            Err(_) => ports.get(&target).copied(),
                        });
                    match resolved {
                        None => problems.add(
                            &origin,
                            format!(
                                "targetPort {target} is no container port of the selected pods"
                            ),
                        ),
                        Some(container_port) => {
                            if serve_pod_labels
                                .iter()
                                .any(|l| labels_match(selector, Some(l)))
                            {
                                master_endpoints.push((
                                    object.name(),
                                    service_port,
                                    container_port,
                                ));
                            }
                        }
                    }
                }
            }
            "PodDisruptionBudget" => {
                let selector = at(&object.value, &["spec", "selector", "matchLabels"]);
                problems.check(
                    container_ports
                        .iter()
                        .any(|(labels, _)| labels_match(selector, Some(labels))),
                    &origin,
                    "its selector matches no pod template",
                );
            }
            "HorizontalPodAutoscaler" => {
                let (kind, name) = (
                    str_at(&object.value, &["spec", "scaleTargetRef", "kind"]),
                    str_at(&object.value, &["spec", "scaleTargetRef", "name"]),
                );
                problems.check(
                    workloads
                        .iter()
                        .any(|w| Some(w.kind()) == kind && Some(w.name()) == name),
                    &origin,
                    format!("scaleTargetRef {kind:?} {name:?} does not exist"),
                );
            }
            _ => {}
        }
    }
    problems.check(
        objects.iter().any(|o| o.kind() == "PodDisruptionBudget"),
        base,
        "no PodDisruptionBudget",
    );
    problems.check(
        objects
            .iter()
            .any(|o| o.kind() == "HorizontalPodAutoscaler"),
        base,
        "no HorizontalPodAutoscaler example",
    );
    problems.check(!secret_keys.is_empty(), base, "the token is not a Secret");
    let grpc = facts
        .grpc_ports
        .iter()
        .find(|(o, _)| o.starts_with(base))
        .map(|(_, p)| *p);
    for (origin, url) in worker_urls {
        let ok = url_host_port(&url).is_some_and(|(host, port)| {
            let service = host.split('.').next().unwrap_or_default().to_string();
            master_endpoints.iter().any(|(name, service_port, target)| {
                *name == service && *service_port == port && Some(*target) == grpc
            })
        });
        problems.check(ok, &origin, format!("the worker dials {url}, which is no Service port in front of the master's gRPC port ({master_endpoints:?})"));
    }
}

/// `deploy/k8s/autoscale/../master.yaml` -> `deploy/k8s/master.yaml`.
fn normalize(path: &str) -> String {
    let mut parts: Vec<&str> = Vec::new();
    for part in path.split('/') {
        match part {
            "." => {}
            ".." => {
                parts.pop();
            }
            _ => parts.push(part),
        }
    }
    parts.join("/")
}

// ---- scripts and README

fn check_scripts(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let scripts: Vec<&String> = files
        .files
        .keys()
        .filter(|p| p.ends_with(".sh") || p.ends_with(".sbatch"))
        .collect();
    problems.check(
        scripts.len() >= 2,
        "deploy/",
        format!("expected the one-box and SLURM scripts, found {scripts:?}"),
    );
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
        // bash -n on the text under test (which may differ from the file in the negative test).
        let mut child = Command::new("bash")
            .arg("-n")
            .stdin(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("bash");
        child
            .stdin
            .take()
            .unwrap()
            .write_all(text.as_bytes())
            .unwrap();
        let output = child.wait_with_output().unwrap();
        problems.check(
            output.status.success(),
            path,
            format!("bash -n: {}", String::from_utf8_lossy(&output.stderr)),
        );
        let env = exported_names(text);
        let before = facts.invocations.len();
        shell_invocations(text, 1, path, &env, &mut facts.invocations);
        let found: BTreeSet<String> = facts.invocations[before..]
            .iter()
            .map(program_name)
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
        for invocation in &facts.invocations[before..] {
            if invocation.program == Program::Worker || invocation.program == Program::Hevo {
                problems.check(
                    invocation.flag("--token-file").is_some()
                        || invocation.flag("--token").is_some()
                        || invocation.env.contains("HEVO_TOKEN"),
                    &invocation.origin,
                    format!("`{}` without the token", program_name(invocation)),
                );
            }
        }
        if path.ends_with(".sbatch") {
            problems.check(
                text.lines().any(|l| l.starts_with("#SBATCH ")),
                path,
                "no #SBATCH directives",
            );
            let worker_lines: Vec<&str> = text
                .lines()
                .filter(|l| l.contains("$hevo_worker"))
                .collect();
            problems.check(
                text.lines().any(|l| l.trim_start().starts_with("srun "))
                    && !worker_lines.is_empty(),
                path,
                "the workers are not started with srun",
            );
        }
    }
}

fn check_readme(files: &DeployFiles, problems: &mut Problems, facts: &mut Facts) {
    let path = "deploy/README.md";
    let text = files.get(path);
    // Shell blocks: collect them first, since an export in one applies to the later ones.
    let mut blocks: Vec<(String, usize)> = Vec::new();
    let mut current: Option<(String, bool, usize)> = None;
    for (number, line) in text.lines().enumerate() {
        let number = number + 1;
        if let Some(fence) = line.trim_start().strip_prefix("```") {
            match current.take() {
                Some((body, _, start)) => blocks.push((body, start)),
                None => {
                    let language = fence.trim();
                    if ["sh", "bash", "shell", "console"].contains(&language) {
                        current = Some((String::new(), language == "console", number + 1));
                    } else {
                        current = Some((String::from("\u{0}"), false, number + 1));
                    }
                }
            }
            continue;
        }
        if let Some((body, console, _)) = current.as_mut() {
            if body.starts_with('\u{0}') {
                continue;
            }
            let command = if *console {
                line.strip_prefix("$ ").unwrap_or("# output")
            } else {
                line
            };
            body.push_str(command);
            body.push('\n');
        }
    }
    let blocks: Vec<(String, usize)> = blocks
        .into_iter()
        .filter(|(b, _)| !b.starts_with('\u{0}'))
        .collect();
    let env: BTreeSet<String> = blocks.iter().flat_map(|(b, _)| exported_names(b)).collect();
    let before = facts.invocations.len();
    for (body, start) in &blocks {
        shell_invocations(body, *start, path, &env, &mut facts.invocations);
    }
    let found: BTreeSet<String> = facts.invocations[before..]
        .iter()
        .map(program_name)
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
    // Files it points to exist.
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
    for (at, _) in text.match_indices("deploy/") {
        let reference: String = text[at..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || "/._-".contains(*c))
            .collect();
        let reference = reference.trim_end_matches(['.', '/']);
        // Files the user creates (the token files) are git-ignored in deploy/.
        if reference == "deploy" || user_files.contains(reference) {
            continue;
        }
        problems.check(
            repo_root().join(reference).exists(),
            path,
            format!("refers to {reference}, which does not exist"),
        );
    }
    for (at, _) in text.match_indices("](") {
        let target: String = text[at + 2..].chars().take_while(|c| *c != ')').collect();
        if !target.contains("://") && !target.starts_with('#') {
            problems.check(
                repo_root().join("deploy").join(&target).exists(),
                path,
                format!("links to {target}, which does not exist"),
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The tests

#[test]
fn deploy_files_use_only_what_the_binaries_accept() {
    let helps = helps();
    let files = DeployFiles::load();
    let (problems, facts) = check_all(&files, helps);
    let mut summary: BTreeMap<String, usize> = BTreeMap::new();
    for invocation in &facts.invocations {
        *summary.entry(program_name(invocation)).or_default() += 1;
    }
    eprintln!(
        "checked {} command lines: {summary:?}",
        facts.invocations.len()
    );
    eprintln!(
        "gRPC ports {:?}, metrics ports {:?}, probe services {:?}",
        facts.grpc_ports, facts.metrics_ports, facts.probe_services
    );
    assert!(
        problems.0.is_empty(),
        "deploy/ has drifted from the binaries:\n  {}",
        problems.0.join("\n  ")
    );
    assert!(
        facts.invocations.len() >= 20,
        "suspiciously few command lines found: {:#?}",
        facts.invocations
    );
}

/// The checker itself: each kind of drift it is meant to catch, injected into a copy of the
/// files, is reported.
#[test]
fn drift_is_detected() {
    let helps = helps();
    let pristine = DeployFiles::load();
    let cases: &[(&str, &str, &str, &str)] = &[
        (
            "deploy/k8s/master.yaml",
            "- --state-dir",
            "- --state-directory",
            "--state-directory",
        ),
        (
            "deploy/compose.yaml",
            "HEVO_MASTER: http://master:50051",
            "HEVO_MASTERS: http://master:50051",
            "HEVO_MASTERS",
        ),
        (
            "deploy/compose.yaml",
            "HEVO_MASTER: http://master:50051",
            "HEVO_MASTER: http://master:50052",
            "dials http://master:50052",
        ),
        (
            "deploy/k8s/master.yaml",
            "              port: 50051\n              service: hevo.v1.WorkerService",
            "              port: 50052\n              service: hevo.v1.WorkerService",
            "probes port Some(50052)",
        ),
        (
            "deploy/k8s/worker.yaml",
            "terminationGracePeriodSeconds: 90",
            "terminationGracePeriodSeconds: 10",
            "terminationGracePeriodSeconds 10",
        ),
        (
            "deploy/k8s/worker.yaml",
            "value: http://hevo-master:50051",
            "value: http://hevo-masters:50051",
            "hevo-masters",
        ),
        (
            "deploy/k8s/worker.yaml",
            "- $(POD_NAME)",
            "- $(POD)",
            "$(POD)",
        ),
        (
            "deploy/k8s/master.yaml",
            "- /etc/hevo/token/token",
            "- /etc/hevo/token/secret",
            "no key secret",
        ),
        (
            "deploy/local/one-box.sh",
            "\"$hevo\" watch --master",
            "\"$hevo\" wait --master",
            "no subcommand `wait`",
        ),
        (
            "deploy/local/one-box.sh",
            "--token-file \"$token_file\" --threads",
            "--token-file \"$token_file\" --thread",
            "no option `--thread`",
        ),
        (
            "deploy/slurm/hevo.sbatch",
            "\"$hevo_worker\" --token-file \"$token_file\" --threads \"$cpus\"",
            "\"$hevo_worker\" --token-file \"$token_file\" --threads",
            "needs a value",
        ),
        (
            "deploy/slurm/hevo.sbatch",
            "export HEVO_MASTER\n",
            "\n",
            "needs `--master`",
        ),
        (
            "deploy/README.md",
            "hevo fetch --master http://127.0.0.1:50051 \"$job\" --out results/",
            "hevo fetch --master http://127.0.0.1:50051 \"$job\" --output results/",
            "no option `--output`",
        ),
        (
            "deploy/README.md",
            "--workers 3 deploy/local/tiny.toml",
            "--worker 3 deploy/local/tiny.toml",
            "`one-box.sh` has no option `--worker`",
        ),
        (
            "deploy/Dockerfile",
            "USER 10001:10001",
            "USER 10002:10001",
            "the image's user is 10002",
        ),
        (
            "deploy/Dockerfile",
            "-p hevo-worker",
            "-p hevo-wrker",
            "hevo-wrker",
        ),
        (
            "deploy/Dockerfile",
            "EXPOSE 50051 9090",
            "EXPOSE 50052 9090",
            "EXPOSE {9090, 50052}",
        ),
    ];
    for (path, from, to, expected) in cases {
        let mut files = pristine.clone();
        files.replace(path, from, to);
        let (problems, _) = check_all(&files, helps);
        assert!(
            problems.mention(expected),
            "changing {from:?} to {to:?} in {path} was not reported as {expected:?}; reported:\n  {}",
            problems.0.join("\n  ")
        );
    }
}

/// Every shell script passes shellcheck, when it is installed (it is not needed for CI).
#[test]
fn scripts_pass_shellcheck_when_available() {
    if Command::new("shellcheck")
        .arg("--version")
        .output()
        .is_err()
    {
        eprintln!("shellcheck is not installed; skipped (apt-get install shellcheck)");
        return;
    }
    for script in ["deploy/local/one-box.sh", "deploy/slurm/hevo.sbatch"] {
        let output = Command::new("shellcheck")
            .arg(repo_root().join(script))
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "shellcheck {script}:\n{}",
            String::from_utf8_lossy(&output.stdout)
        );
    }
}

/// A running master, started with the deploy files' own arguments (addresses and paths made
/// local), stopped with SIGTERM by [`Master::stop`] and killed when dropped.
struct Master {
    proc: Proc,
    grpc: String,
    metrics: Option<String>,
    /// Its stdout after the address lines, kept open so the master never writes to a closed
    /// pipe.
    _stdout: mpsc::Receiver<String>,
}

impl Master {
    fn start(argv: &[String], dir: &Path, token: &str, env_token: bool) -> Master {
        std::fs::create_dir_all(dir).unwrap();
        let token_file = dir.join("token");
        std::fs::write(&token_file, token).unwrap();
        let mut args = Vec::new();
        let mut previous = String::new();
        for arg in &argv[1..] {
            let arg = match previous.as_str() {
                "--listen" | "--metrics-listen" => "127.0.0.1:0".to_string(),
                "--state-dir" => dir.join("state").to_string_lossy().into_owned(),
                "--token-file" => token_file.to_string_lossy().into_owned(),
                _ => arg.clone(),
            };
            previous = arg.clone();
            args.push(arg);
        }
        let mut command = Command::new(&binaries().hevo);
        command
            .args(&args)
            .env_remove("HEVO_TOKEN")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit());
        if env_token {
            command.env("HEVO_TOKEN", token);
        }
        let mut proc = Proc::spawn("hevo serve", &mut command);
        let lines = lines_of(proc.child().stdout.take().expect("piped stdout"));
        let next_line = || {
            lines
                .recv_timeout(Duration::from_secs(20))
                .unwrap_or_default()
        };
        let first = next_line();
        let grpc = first
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("hevo {args:?} printed {first:?} first"))
            .to_string();
        let metrics = if args.iter().any(|a| a == "--metrics-listen") {
            let second = next_line();
            Some(
                second
                    .strip_prefix("metrics on ")
                    .unwrap_or_else(|| panic!("expected `metrics on ADDR`, got {second:?}"))
                    .to_string(),
            )
        } else {
            None
        };
        Master {
            proc,
            grpc,
            metrics,
            _stdout: lines,
        }
    }

    fn stop(mut self) -> std::process::ExitStatus {
        self.proc.signal("TERM");
        self.proc
            .wait_timeout(Duration::from_secs(30))
            .expect("hevo serve did not exit within 30 s of SIGTERM")
    }
}

fn health_status(
    runtime: &tokio::runtime::Runtime,
    address: &str,
    service: &str,
) -> Result<i32, String> {
    runtime.block_on(async {
        let channel = tonic::transport::Endpoint::from_shared(format!("http://{address}"))
            .map_err(|e| e.to_string())?
            .connect_timeout(Duration::from_secs(5))
            .timeout(Duration::from_secs(5))
            .connect()
            .await
            .map_err(|e| e.to_string())?;
        let mut client = tonic_health::pb::health_client::HealthClient::new(channel);
        let response = client
            .check(tonic_health::pb::HealthCheckRequest {
                service: service.to_string(),
            })
            .await
            .map_err(|status| format!("{}: {}", status.code(), status.message()))?;
        Ok(response.into_inner().status)
    })
}

/// What `--help` cannot show: the health services the probes ask for answer SERVING without a
/// token, the metrics path answers, the compose health check passes, clients without the token
/// are refused, and SIGTERM stops the master. Started once with the compose master's command
/// line and once with the Kubernetes one.
#[test]
fn the_master_answers_the_probes_the_deploy_files_use() {
    let helps = helps();
    let files = DeployFiles::load();
    let (_, facts) = check_all(&files, helps);
    let scratch = Scratch::new("deploy-files");
    let token = "deploy-files-test-token";
    let mut services = facts.probe_services.clone();
    services.insert(String::new());

    let (compose_argv, compose_env) = facts
        .compose_master_argv
        .clone()
        .expect("the compose file runs hevo serve");
    let k8s_argv = facts
        .k8s_master_argv
        .clone()
        .expect("the manifests run hevo serve");
    for (name, argv, env_token) in [
        ("compose", compose_argv, compose_env.contains("HEVO_TOKEN")),
        ("k8s", k8s_argv, false),
    ] {
        let master = Master::start(&argv, &scratch.join(name), token, env_token);
        // One runtime per master, dropped before the master is stopped so that no gRPC
        // connection of ours holds its shutdown up.
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        for service in &services {
            let deadline = Instant::now() + Duration::from_secs(15);
            loop {
                let status = health_status(&runtime, &master.grpc, service);
                if status
                    == Ok(tonic_health::pb::health_check_response::ServingStatus::Serving as i32)
                {
                    break;
                }
                assert!(
                    Instant::now() < deadline,
                    "{name}: health check of {service:?} without a token: {status:?}, not SERVING"
                );
                std::thread::sleep(Duration::from_millis(200));
            }
        }
        if let Some(metrics) = &master.metrics {
            for path in facts
                .metrics_paths
                .iter()
                .chain(std::iter::once(&"/metrics".to_string()))
            {
                let response = http_get(metrics, path);
                let status = response.lines().next().unwrap_or_default();
                assert!(
                    status.contains(" 200"),
                    "{name}: GET {path} on the metrics port answered {status:?}"
                );
            }
        }
        if name == "compose" {
            let healthcheck = facts
                .compose_healthcheck
                .clone()
                .expect("compose healthcheck");
            let mut args: Vec<String> = healthcheck[1..].to_vec();
            if let Some(at) = args.iter().position(|a| a == "--master") {
                args[at + 1] = format!("http://{}", master.grpc);
            }
            let status = Command::new(&binaries().hevo)
                .args(&args)
                .env("HEVO_TOKEN", token)
                .output()
                .unwrap();
            assert!(
                status.status.success(),
                "the compose healthcheck {args:?} fails: {}",
                String::from_utf8_lossy(&status.stderr)
            );
            let refused = Command::new(&binaries().hevo)
                .args(&args)
                .env_remove("HEVO_TOKEN")
                .output()
                .unwrap();
            assert!(
                !refused.status.success(),
                "the master answered `hevo {}` without the token",
                args.join(" ")
            );
        }
        drop(runtime);
        let status = master.stop();
        eprintln!("{name}: hevo serve exited with {status} after SIGTERM");
    }
}

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
fn shell_lexer_finds_commands() {
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
"#;
    let mut found = Vec::new();
    shell_invocations(script, 1, "t", &BTreeSet::new(), &mut found);
    let lines: Vec<(String, Vec<String>)> = found
        .iter()
        .map(|i| {
            (
                format!(
                    "{}@{}",
                    program_name(i),
                    i.origin.rsplit(':').next().unwrap()
                ),
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
    assert_eq!(duration_seconds("1m30s"), Some(90.0));
    assert_eq!(
        url_host_port("http://hevo-master.hevo.svc:50051"),
        Some(("hevo-master.hevo.svc".into(), 50051))
    );
}
