//! The algorithm study's report: `hevo report --study FILE` writes a Markdown page (the
//! project's `docs/study-algorithms.md`) from a study file that names, for each question (a
//! task and a decomposition), the run directories where each search algorithm answered it.
//! Each search gets its solve rates on the post-evaluation's held-out samples (average, best,
//! every run), how many runs finished and which are under way (with the generation their
//! checkpoint reached), the command that continues it, and its fitness curves. A study is
//! read while it runs: a search whose runs have not started is listed as such, not refused.

use crate::reproduction::{NodeResult, ReportError, fitness_picture, io_error, load_node};
use hevo_rundir::eval_report::percent;
use hevo_rundir::store::write_atomic;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// A study file: its title, what it asks, and its questions in the order the page shows them.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The page's heading.
    pub title: String,
    /// The paragraph under it: the budget and protocol every search shares.
    pub about: String,
    /// The questions.
    #[serde(rename = "question")]
    pub questions: Vec<Question>,
}

/// One question: a task and a decomposition, searched by several algorithms.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Question {
    /// A short name, for the summary table and the pictures' file names (`[a-z0-9_]+`).
    pub name: String,
    /// What is evolved, in words.
    pub about: String,
    /// The paper's figure for it, where the paper has one.
    #[serde(default)]
    pub paper: Option<String>,
    /// The algorithms that searched it.
    #[serde(rename = "search")]
    pub searches: Vec<Search>,
}

/// One algorithm's runs of a question.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Search {
    /// The algorithm, as the page names it (`GA`, `CMA-ES`, ...).
    pub algorithm: String,
    /// The run output directory (`hevo run --out`), relative to the study file.
    pub runs: PathBuf,
    /// The node, a directory under `runs`.
    pub node: String,
    /// The runs the study plans for it.
    pub planned_runs: u32,
    /// The command that starts or continues it, from the repository root.
    pub command: String,
}

/// [`StudyFile::read`]'s most questions and searches: a study is a page, not a database.
const MAX_QUESTIONS: usize = 64;
const MAX_SEARCHES: usize = 16;

impl StudyFile {
    /// Reads and checks a study file; errors name the file and what is wrong in it.
    pub fn read(path: &Path) -> Result<StudyFile, ReportError> {
        let text = std::fs::read_to_string(path).map_err(io_error(path))?;
        let study: StudyFile = toml::from_str(&text).map_err(|e| ReportError::Invalid {
            path: path.to_path_buf(),
            what: e.to_string(),
        })?;
        study.check().map_err(|what| ReportError::Invalid {
            path: path.to_path_buf(),
            what,
        })?;
        Ok(study)
    }

    fn check(&self) -> Result<(), String> {
        if self.questions.is_empty() || self.questions.len() > MAX_QUESTIONS {
            return Err(format!(
                "{} questions: a study has 1 to {MAX_QUESTIONS}",
                self.questions.len()
            ));
        }
        for (question_idx, question) in self.questions.iter().enumerate() {
            let at = format!("question {} ({:?})", question_idx + 1, question.name);
            let valid_name = !question.name.is_empty()
                && question
                    .name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_');
            if !valid_name {
                return Err(format!(
                    "{at}: name must be lower-case letters, digits and _"
                ));
            }
            if self.questions[..question_idx]
                .iter()
                .any(|q| q.name == question.name)
            {
                return Err(format!("{at}: a second question of that name"));
            }
            if question.searches.is_empty() || question.searches.len() > MAX_SEARCHES {
                return Err(format!(
                    "{at}: {} searches, a question has 1 to {MAX_SEARCHES}",
                    question.searches.len()
                ));
            }
            for search in &question.searches {
                if search.node.is_empty() || search.node.contains(['/', '\\']) {
                    return Err(format!(
                        "{at}, {}: node {:?} is not a node name",
                        search.algorithm, search.node
                    ));
                }
                if !(1..=100).contains(&search.planned_runs) {
                    return Err(format!(
                        "{at}, {}: planned_runs {} is outside 1 to 100",
                        search.algorithm, search.planned_runs
                    ));
                }
            }
        }
        Ok(())
    }
}

/// One search as found on disk: `None` before its node directory holds a run.
struct Found<'a> {
    search: &'a Search,
    node_dir: PathBuf,
    node: Option<NodeResult>,
}

/// Writes the study page for `study_file` to `out_file`, its pictures to a folder named after
/// the page beside it (`study-algorithms/` for `study-algorithms.md`), and returns how many
/// searches have at least one finished run.
pub fn write_study_report(study_file: &Path, out_file: &Path) -> Result<usize, ReportError> {
    let study = StudyFile::read(study_file)?;
    let base = study_file.parent().unwrap_or(Path::new("."));
    let out_base = out_file.parent().unwrap_or(Path::new("."));
    let stem = out_file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "study".into());
    let pictures = out_base.join(&stem);
    std::fs::create_dir_all(&pictures).map_err(io_error(&pictures))?;

    let mut found: Vec<Vec<Found<'_>>> = Vec::new();
    for question in &study.questions {
        let mut searches = Vec::new();
        for search in &question.searches {
            let node_dir = lexically_normal(&base.join(&search.runs).join(&search.node));
            let node = load_node(&node_dir)?;
            searches.push(Found {
                search,
                node_dir,
                node,
            });
        }
        found.push(searches);
    }

    let mut md = String::new();
    let _ = writeln!(md, "# {}\n", study.title);
    let _ = writeln!(
        md,
        "Generated by `hevo report --study {} --out {}` from the run directories the study file \
         names; do not edit by hand. Rerun the command as runs finish.\n",
        study_file.display(),
        out_file.display()
    );
    let _ = writeln!(md, "{}\n", study.about.trim());
    md.push_str(&summary_table(&study, &found));
    let mut n_with_results = 0;
    for (question, searches) in study.questions.iter().zip(&found) {
        let _ = writeln!(md, "\n## {}\n", question.about);
        if let Some(paper) = &question.paper {
            let _ = writeln!(md, "The paper: {paper}.\n");
        }
        md.push_str(&search_table(searches));
        for found in searches {
            let Some(node) = &found.node else { continue };
            if !node.runs.is_empty() {
                n_with_results += 1;
            }
            let picture_stem = format!("{}-{}", question.name, slug(&found.search.algorithm));
            let title = format!("{}, {}", question.name, found.search.algorithm);
            if let Some(picture) =
                fitness_picture(node, &picture_stem, &title, &pictures, out_base)?
            {
                let _ = writeln!(md, "\n{picture}");
            }
        }
    }
    write_atomic(out_file, md.as_bytes()).map_err(io_error(out_file))?;
    Ok(n_with_results)
}

/// The questions down, the algorithms across: each cell the average and best solve rate and
/// how many of the planned runs finished.
fn summary_table(study: &StudyFile, found: &[Vec<Found<'_>>]) -> String {
    let mut algorithms: Vec<&str> = Vec::new();
    for search in study.questions.iter().flat_map(|q| &q.searches) {
        if !algorithms.contains(&search.algorithm.as_str()) {
            algorithms.push(&search.algorithm);
        }
    }
    let mut md = format!("| question | {} |\n", algorithms.join(" | "));
    let _ = writeln!(md, "|---|{}", "---|".repeat(algorithms.len()));
    for (question, searches) in study.questions.iter().zip(found) {
        let cells: Vec<String> = algorithms
            .iter()
            .map(|algorithm| {
                searches
                    .iter()
                    .filter(|f| f.search.algorithm == *algorithm)
                    .map(summary_cell)
                    .collect::<Vec<_>>()
                    .join("; ")
            })
            .collect();
        let _ = writeln!(md, "| {} | {} |", question.name, cells.join(" | "));
    }
    md.push_str(
        "\nEach cell: average / best post-evaluation solve rate over the finished runs (finished \
         of planned runs); \"-\" where none has finished yet.\n",
    );
    md
}

fn summary_cell(found: &Found<'_>) -> String {
    let planned = found.search.planned_runs;
    match found
        .node
        .as_ref()
        .and_then(|n| n.avg_and_best().map(|ab| (n, ab)))
    {
        Some((node, (avg, best))) => format!(
            "{} / {} ({} of {planned})",
            percent(avg),
            percent(best),
            node.runs.len()
        ),
        None => format!("- (0 of {planned})"),
    }
}

/// A question's searches, one row each.
fn search_table(searches: &[Found<'_>]) -> String {
    let mut md = String::from(
        "| algorithm | node | average / best | runs finished | each run | runs that never solve a variant | post-evaluation samples | under way | continue with |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for found in searches {
        let search = found.search;
        let node_path = &found.node_dir;
        let (rates, finished, each, stuck, samples, under_way) = match &found.node {
            None => (
                "-".to_string(),
                format!("0 of {}", search.planned_runs),
                "-".to_string(),
                "-".to_string(),
                "-".to_string(),
                format!("not started (no runs in `{}`)", node_path.display()),
            ),
            Some(node) => {
                let rates = node.avg_and_best().map_or_else(
                    || "-".into(),
                    |(a, b)| format!("{} / {}", percent(a), percent(b)),
                );
                let each: Vec<String> = node
                    .runs
                    .iter()
                    .map(|r| percent(r.post_evaluation.solve_rate))
                    .collect();
                let mut samples: Vec<String> = node
                    .runs
                    .iter()
                    .map(|r| r.post_evaluation.samples.to_string())
                    .collect();
                samples.dedup();
                let under_way: Vec<String> = node
                    .in_progress
                    .iter()
                    .map(|(run, generation)| format!("run {run} at generation {generation}"))
                    .collect();
                (
                    rates,
                    format!("{} of {}", node.runs.len(), search.planned_runs),
                    if each.is_empty() {
                        "-".into()
                    } else {
                        each.join(", ")
                    },
                    never_solved(&node.runs),
                    if samples.is_empty() {
                        "-".into()
                    } else {
                        samples.join(", ")
                    },
                    if under_way.is_empty() {
                        "-".into()
                    } else {
                        under_way.join(", ")
                    },
                )
            }
        };
        let _ = writeln!(
            md,
            "| {} | `{}` | {rates} | {finished} | {each} | {stuck} | {samples} | {under_way} | `{}` |",
            search.algorithm,
            node_path.display(),
            search.command
        );
    }
    md
}

/// How many finished runs solve none of a variant's post-evaluation samples (a light
/// configuration of the maze, say): a search stuck on part of its task, not merely weaker on
/// all of it. "-" when the task has no variants or no run has finished.
fn never_solved(runs: &[hevo_rundir::RunSummary]) -> String {
    let with_variants: Vec<_> = runs
        .iter()
        .filter(|r| !r.post_evaluation.per_variant.is_empty())
        .collect();
    if with_variants.is_empty() {
        return "-".into();
    }
    let stuck = with_variants
        .iter()
        .filter(|r| {
            r.post_evaluation
                .per_variant
                .iter()
                .any(|v| v.samples > 0 && v.solve_rate == 0.0)
        })
        .count();
    format!("{stuck} of {}", with_variants.len())
}

/// `path` with `a/../` and `./` taken out, without asking the file system, so a node named
/// relative to the study file reads as a path from where the command ran.
fn lexically_normal(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for component in path.components() {
        match component {
            Component::CurDir => {}
            Component::ParentDir
                if matches!(out.components().next_back(), Some(Component::Normal(_))) =>
            {
                out.pop();
            }
            other => out.push(other),
        }
    }
    out
}

/// An algorithm's name as a file name: lower case, runs of anything else as one `-`.
fn slug(name: &str) -> String {
    let mut out = String::new();
    for c in name.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') && !out.is_empty() {
            out.push('-');
        }
    }
    out.trim_end_matches('-').to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(path: &Path, text: &str) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }

    fn run_summary(node: &str, run: u32, solve_rate: f64) -> String {
        // Two variants: the second never solved when the run solves at most half.
        let second = if solve_rate <= 0.5 { 0.0 } else { solve_rate };
        serde_json::json!({
            "node": node, "run": run, "fingerprint": "f", "run_seed": 1, "generations": 3,
            "final_best_fitness": 1.0,
            "post_evaluation": {"task": "solve_maze", "samples": 400, "solve_rate": solve_rate,
                "mean_fitness": 1.0, "collision_rate": 0.0, "mean_cycles": 100.0,
                "per_variant": [
                    {"variant": 0, "samples": 200, "solve_rate": 1.0},
                    {"variant": 1, "samples": 200, "solve_rate": second}
                ]}
        })
        .to_string()
    }

    const STUDY: &str = r#"
title = "The study"
about = "Every search at the paper's budget."

[[question]]
name = "maze_single"
about = "The double T-maze as one network"
paper = "GA 40 % average, 83 % best"

[[question.search]]
algorithm = "GA"
runs = "runs-ga"
node = "maze_single"
planned_runs = 2
command = "hevo run ga.toml"

[[question.search]]
algorithm = "CMA-ES"
runs = "runs-cmaes"
node = "maze_single_cmaes"
planned_runs = 3
command = "hevo run cmaes.toml"

[[question.search]]
algorithm = "MAP-Elites"
runs = "runs-map-elites"
node = "maze_single"
planned_runs = 5
command = "hevo run me.toml"
"#;

    #[test]
    fn finished_runs_under_way_runs_and_searches_not_started_are_each_reported() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        write(&root.join("study.toml"), STUDY);
        let ga = root.join("runs-ga/maze_single");
        write(
            &ga.join("run-0/summary.json"),
            &run_summary("maze_single", 0, 0.5),
        );
        write(
            &ga.join("run-1/summary.json"),
            &run_summary("maze_single", 1, 0.75),
        );
        write(
            &ga.join("run-0/fitness.csv"),
            "generation,best,mean,min,max,std\n0,0.5,0.2,0,0.5,0.1\n1,0.7,0.3,0,0.7,0.1\n",
        );
        let cmaes = root.join("runs-cmaes/maze_single_cmaes");
        write(
            &cmaes.join("run-0/summary.json"),
            &run_summary("maze_single_cmaes", 0, 1.0),
        );
        write(
            &cmaes.join("run-1/checkpoint.json"),
            r#"{"fingerprint": "f", "generation": 42}"#,
        );

        let out = root.join("docs/study.md");
        let n = write_study_report(&root.join("study.toml"), &out).unwrap();
        assert_eq!(n, 2, "two searches have finished runs");
        let md = std::fs::read_to_string(&out).unwrap();
        assert!(
            md.contains("| question | GA | CMA-ES | MAP-Elites |"),
            "{md}"
        );
        assert!(
            md.contains(
                "| maze_single | 62.5% / 75.0% (2 of 2) | 100.0% / 100.0% (1 of 3) | - (0 of 5) |"
            ),
            "{md}"
        );
        assert!(
            md.contains("The paper: GA 40 % average, 83 % best."),
            "{md}"
        );
        assert!(
            md.contains("| 50.0%, 75.0% | 1 of 2 | 400 | - | `hevo run ga.toml` |"),
            "{md}"
        );
        assert!(md.contains("| run 1 at generation 42 |"), "{md}");
        assert!(
            md.contains(&format!(
                "not started (no runs in `{}`)",
                root.join("runs-map-elites/maze_single").display()
            )),
            "{md}"
        );
        assert!(root.join("docs/study/maze_single-ga-fitness.svg").is_file());
        assert!(md.contains("](study/maze_single-ga-fitness.svg)"), "{md}");
    }

    #[test]
    fn a_broken_study_file_is_refused_naming_the_file_and_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("study.toml");
        let out = dir.path().join("out.md");
        for (text, expected) in [
            (
                STUDY.replace("planned_runs = 3", "planned_runs = 0"),
                "planned_runs 0 is outside 1 to 100",
            ),
            (
                STUDY.replace("name = \"maze_single\"", "name = \"Maze Single\""),
                "name must be lower-case",
            ),
            (
                STUDY.replace("node = \"maze_single_cmaes\"", "node = \"../x\""),
                "is not a node name",
            ),
            (
                STUDY.replace("command = \"hevo run me.toml\"", "comand = \"x\""),
                "unknown field `comand`",
            ),
        ] {
            std::fs::write(&path, &text).unwrap();
            let error = write_study_report(&path, &out).unwrap_err().to_string();
            assert!(error.contains("study.toml"), "{error}");
            assert!(error.contains(expected), "{expected}: {error}");
        }
        assert!(!out.exists(), "no page is written from a broken study file");
    }

    #[test]
    fn paths_lose_their_dots_but_not_what_they_name() {
        assert_eq!(
            lexically_normal(Path::new("experiments/study/../runs/maze")),
            Path::new("experiments/runs/maze")
        );
        assert_eq!(lexically_normal(Path::new("./a/./b")), Path::new("a/b"));
        assert_eq!(
            lexically_normal(Path::new("../a/../../b")),
            Path::new("../../b")
        );
    }

    #[test]
    fn slugs_are_file_names() {
        assert_eq!(slug("CMA-ES"), "cma-es");
        assert_eq!(slug("novelty (blend 0.5)"), "novelty-blend-0-5");
        assert_eq!(slug("GA"), "ga");
    }
}
