//! The tutorials (`docs/tutorial-triple-t-maze.md`, `docs/tutorial-swarm.md`) work as written:
//! their file blocks, copied into an empty directory with the shipped controllers a tutorial
//! tells the reader to copy, are the shipped scenario file, and every command of their `sh`
//! blocks succeeds there and writes what it says.

use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use crate::support::{HEVO, repo_root, succeeded};

/// A fenced block: its info string and its lines.
struct Block {
    info: String,
    text: String,
}

fn blocks(markdown: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut open: Option<Block> = None;
    for line in markdown.lines() {
        match (&mut open, line.strip_prefix("```")) {
            (None, Some(info)) => {
                open = Some(Block {
                    info: info.trim().to_string(),
                    text: String::new(),
                })
            }
            (Some(_), Some("")) => blocks.extend(open.take()),
            (Some(block), _) => {
                block.text.push_str(line);
                block.text.push('\n');
            }
            (None, None) => {}
        }
    }
    assert!(open.is_none(), "a fenced block is not closed");
    blocks
}

/// The files the tutorial writes: blocks whose info string is `toml NAME`, joined in order a
/// blank line apart.
fn tutorial_files(blocks: &[Block]) -> BTreeMap<String, String> {
    let mut files: BTreeMap<String, Vec<&str>> = BTreeMap::new();
    for block in blocks {
        if let Some(name) = block.info.strip_prefix("toml ") {
            files
                .entry(name.trim().to_string())
                .or_default()
                .push(block.text.trim_end_matches('\n'));
        }
    }
    files
        .into_iter()
        .map(|(name, parts)| (name, parts.join("\n\n") + "\n"))
        .collect()
}

/// Runs one command line of the tutorial in `dir`: `hevo ...` runs the binary under test,
/// `cp "$HEVO_REPO"/...` copies from this checkout.
fn run_line(dir: &Path, line: &str) {
    let words: Vec<String> = line
        .split_whitespace()
        .map(|word| {
            word.replace("\"$HEVO_REPO\"", &repo_root().to_string_lossy())
                .replace("$HEVO_REPO", &repo_root().to_string_lossy())
        })
        .collect();
    let (program, args) = words.split_first().expect("a command");
    let program = match program.as_str() {
        "hevo" => HEVO,
        "cp" => "cp",
        other => panic!("the tutorial runs `{other}`, which this test does not know: {line}"),
    };
    let output = Command::new(program)
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot run {line}: {e}"));
    succeeded(line, output);
}

/// A tutorial: its page, the files its blocks write, the shipped scenario one of them must
/// equal, and what its commands must write.
struct Tutorial {
    page: &'static str,
    files: &'static [&'static str],
    /// (a file of the tutorial, the shipped scenario it is).
    shipped: (&'static str, &'static str),
    written: &'static [&'static str],
    /// A word the replay must name.
    replay_names: &'static str,
}

const TUTORIALS: &[Tutorial] = &[
    Tutorial {
        page: "docs/tutorial-triple-t-maze.md",
        files: &["experiment.toml", "triple_t_maze.toml"],
        shipped: (
            "triple_t_maze.toml",
            "scenarios/examples/triple_t_maze.toml",
        ),
        written: &[
            "triple_t_maze.svg",
            "try/triple_t_maze/best.json",
            "try/triple_t_maze/summary.json",
            "replay.svg",
        ],
        replay_names: "triple_t_maze",
    },
    Tutorial {
        page: "docs/tutorial-swarm.md",
        files: &["aggregation.toml", "experiment.toml"],
        shipped: ("aggregation.toml", "scenarios/swarm/aggregation.toml"),
        written: &[
            "aggregation.svg",
            "try/aggregation/best.json",
            "try/aggregation/summary.json",
            "replay.svg",
        ],
        replay_names: "9 other robots",
    },
];

fn runs_as_written(tutorial: &Tutorial) {
    let root = repo_root();
    let markdown = std::fs::read_to_string(root.join(tutorial.page)).unwrap();
    let blocks = blocks(&markdown);
    let files = tutorial_files(&blocks);
    assert_eq!(
        files.keys().map(String::as_str).collect::<Vec<_>>(),
        tutorial.files,
        "{}",
        tutorial.page
    );
    let (file, shipped) = tutorial.shipped;
    assert!(
        files[file] == std::fs::read_to_string(root.join(shipped)).unwrap(),
        "the blocks of {} differ from {shipped}",
        tutorial.page
    );

    let dir = tempfile::tempdir().unwrap();
    for (name, text) in &files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let commands: Vec<&str> = blocks
        .iter()
        .filter(|block| block.info == "sh")
        .flat_map(|block| block.text.lines())
        .filter(|line| !line.trim().is_empty())
        .collect();
    assert!(commands.len() >= 5, "the tutorial's commands: {commands:?}");
    for line in commands {
        run_line(dir.path(), line);
    }
    for written in tutorial.written {
        assert!(
            dir.path().join(written).is_file(),
            "the commands of {} wrote no {written}",
            tutorial.page
        );
    }
    let replay = std::fs::read_to_string(dir.path().join("replay.svg")).unwrap();
    assert!(
        replay.contains(tutorial.replay_names),
        "the replay of {} does not say {}",
        tutorial.page,
        tutorial.replay_names
    );
}

#[test]
fn the_triple_t_maze_tutorial_runs_as_written() {
    runs_as_written(&TUTORIALS[0]);
}

#[test]
fn the_swarm_tutorial_runs_as_written() {
    runs_as_written(&TUTORIALS[1]);
}
