//! `hevo report`: writes REPRODUCTION.md from run outputs: per controller the paper's average
//! and best solve rates beside ours, how many runs and generations and post-evaluation samples
//! ours rest on, the rescue controller's stage rates, the baseline comparison (with each maze
//! run's rate per light configuration), what hevo's runs would show under the paper's own
//! "best" protocol (few samples, best of 10 runs), ablations (nodes evolved under another
//! setup, beside the main results), and fitness-curve pictures. Generated, never hand-written:
//! rerun it after more runs finish.

use crate::sampling::{BestOfRuns, wilson_interval};
use hevo_rundir::eval_report::{EVAL_RECORD_FORMAT, EvalRecord, percent, percent_or_dash};
use hevo_rundir::store::{read_json, write_atomic};
use hevo_rundir::{CHECKPOINT, CheckpointHeader, NodeSummary, RunSummary, SUMMARY, run_dirs};

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One row of the paper's results (SPEC section 5).
#[derive(Debug, Clone, Copy)]
pub struct PaperResult {
    pub controller: &'static str,
    pub task: &'static str,
    pub avg: f64,
    pub best: f64,
    pub generations: u32,
    pub runs: u32,
    /// Samples behind each run's post-evaluation: 100, or 100 per light configuration (or
    /// start branch) for the tasks in the maze; the paper's best rescue controller solved
    /// "93% in 400 experiments" (its section 6).
    pub post_eval_samples: u32,
}

const fn paper(
    controller: &'static str,
    task: &'static str,
    avg: f64,
    best: f64,
    generations: u32,
    runs: u32,
    post_eval_samples: u32,
) -> PaperResult {
    PaperResult {
        controller,
        task,
        avg,
        best,
        generations,
        runs,
        post_eval_samples,
    }
}

/// The paper's figures (SPEC section 5), in the order the report lists them.
pub const PAPER: &[PaperResult] = &[
    paper("exit_room", "exit_room", 0.52, 0.96, 500, 10, 100),
    paper("follow_wall", "follow_wall", 0.99, 1.00, 100, 5, 100),
    paper("turn_left", "turn_left", 0.89, 1.00, 100, 5, 100),
    paper("turn_right", "turn_right", 0.69, 1.00, 100, 5, 100),
    paper("solve_maze", "solve_maze", 0.93, 0.995, 1000, 10, 400),
    paper("return_room", "return_room", 0.75, 1.00, 500, 10, 400),
    paper("rescue", "rescue", 0.85, 0.93, 1000, 10, 400),
    paper("maze_single", "solve_maze", 0.40, 0.83, 1000, 10, 400),
];

/// What the report found for one node.
#[derive(Debug, Clone)]
pub(crate) struct NodeResult {
    pub(crate) name: String,
    pub(crate) runs: Vec<RunSummary>,
    complete: bool,
    /// The runs under way, each with the next generation its checkpoint evaluates.
    pub(crate) in_progress: Vec<(u32, u32)>,
    pub(crate) dir: PathBuf,
    /// The setup fingerprints of its finished runs and checkpoints: an ablation's node is one
    /// whose fingerprints the main results' node of the same name does not share.
    fingerprints: Vec<String>,
}

impl NodeResult {
    /// The paper's "avg" and "best": the mean and the highest post-evaluation solve rate over
    /// the finished runs; `None` before any run has finished.
    pub(crate) fn avg_and_best(&self) -> Option<(f64, f64)> {
        if self.runs.is_empty() {
            return None;
        }
        let rates = self.runs.iter().map(|r| r.post_evaluation.solve_rate);
        let avg = rates.clone().sum::<f64>() / self.runs.len() as f64;
        Some((avg, rates.fold(0.0, f64::max)))
    }
}

/// [`read_json`], with an error that names the file.
pub(crate) fn read_named<T: hevo_rundir::store::DeserializeOwned>(
    path: &Path,
) -> Result<Option<T>, ReportError> {
    Ok(read_json(path)?)
}

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A result file exists but cannot be read.
    #[error(transparent)]
    Read(#[from] hevo_rundir::store::ReadJsonError),
    /// A fitness log cannot be read.
    #[error(transparent)]
    RunDir(#[from] hevo_rundir::RunDirError),
    /// A study file or an evaluation record is not one (see [`crate::study::StudyFile`] and
    /// [`EvalRecord`]).
    #[error("{path}: {what}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong in it.
        what: String,
    },
    /// A directory cannot be listed, or the report or a picture cannot be written.
    #[error("{path}: {cause}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        /// Part of the message, not a `source()`, so `{:#}` prints it once.
        cause: std::io::Error,
    },
}

pub(crate) fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
    move |cause| ReportError::Io {
        path: path.to_path_buf(),
        cause,
    }
}

/// A node directory's results: its finished runs (each run's own `summary.json`), the runs
/// still under way (a checkpoint, no summary yet), and whether the node is complete (it has a
/// node summary and no run under way, so a node whose runs are being extended with `--runs`
/// shows its new runs as they finish, and as not complete until they all have).
pub(crate) fn load_node(dir: &Path) -> Result<Option<NodeResult>, ReportError> {
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let node_summary = read_named::<NodeSummary>(&dir.join(SUMMARY))?;
    let mut runs = Vec::new();
    let mut in_progress = Vec::new();
    let mut fingerprints: Vec<String> = node_summary
        .iter()
        .map(|summary| summary.fingerprint.clone())
        .collect();
    let Ok(run_dirs) = run_dirs(dir) else {
        return Ok(None);
    };
    for (run_idx, run_dir) in run_dirs {
        if let Some(run) = read_named::<RunSummary>(&run_dir.join(SUMMARY))? {
            fingerprints.push(run.fingerprint.clone());
            runs.push(run);
        } else if let Some(checkpoint) = read_named::<CheckpointHeader>(&run_dir.join(CHECKPOINT))?
        {
            fingerprints.push(checkpoint.fingerprint);
            in_progress.push((run_idx, checkpoint.generation));
        }
    }
    if runs.is_empty()
        && let Some(summary) = &node_summary
    {
        // A node directory whose run directories were removed still has its summary.
        runs.clone_from(&summary.runs);
    }
    runs.sort_by_key(|r| r.run);
    if runs.is_empty() && in_progress.is_empty() {
        return Ok(None);
    }
    Ok(Some(NodeResult {
        name,
        runs,
        complete: node_summary.is_some() && in_progress.is_empty(),
        in_progress,
        dir: dir.to_path_buf(),
        fingerprints,
    }))
}

/// Every node found in `runs_dir`, in name order.
fn load_nodes(runs_dir: &Path) -> Result<Vec<NodeResult>, ReportError> {
    let entries = std::fs::read_dir(runs_dir).map_err(io_error(runs_dir))?;
    let mut nodes = Vec::new();
    for dir in sorted_subdirectories(entries) {
        if let Some(node) = load_node(&dir)? {
            nodes.push(node);
        }
    }
    Ok(nodes)
}

/// Whether `node` was evolved under the same setup as the main results' node of its name
/// (they share a fingerprint), as a node copied from the main results is.
fn same_setup_as_main(node: &NodeResult, main: &[NodeResult]) -> bool {
    main.iter()
        .filter(|m| m.name == node.name)
        .any(|m| m.fingerprints.iter().any(|f| node.fingerprints.contains(f)))
}

/// The nodes of an ablation directory that were evolved under another setup than the main
/// results' node of the same name (or that the main results lack), and those of the same
/// setup with more finished runs (a node given more runs in a copy, which cannot join the
/// main results without changing the controller their parents were composed over). Nodes
/// copied from the main results unchanged are left out.
fn ablation_nodes(found: Vec<NodeResult>, main: &[NodeResult]) -> Vec<NodeResult> {
    found
        .into_iter()
        .filter(|node| {
            !same_setup_as_main(node, main)
                || main
                    .iter()
                    .filter(|m| m.name == node.name)
                    .all(|m| node.runs.len() > m.runs.len())
        })
        .collect()
}

/// One result per node name when several run directories hold the same node: the first
/// directory (in the order given) in which the node has a finished run, else the first in which
/// it appears. So `hevo report NEW OLD` shows a node's new results as soon as one of its runs
/// finishes, and the old ones until then.
fn preferred_nodes(found: Vec<NodeResult>) -> Vec<NodeResult> {
    let mut nodes: Vec<NodeResult> = Vec::new();
    for node in found {
        match nodes.iter_mut().find(|n| n.name == node.name) {
            None => nodes.push(node),
            Some(kept) if kept.runs.is_empty() && !node.runs.is_empty() => *kept = node,
            Some(_) => {}
        }
    }
    nodes
}

/// The directories among `entries`, in name order, so nodes are reported in a stable order
/// whatever order the file system lists them in.
fn sorted_subdirectories(entries: std::fs::ReadDir) -> Vec<PathBuf> {
    let mut dirs: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    dirs
}

/// The rescue's children, in the order of its phases: the keys of its reports' right choices
/// and the columns of its stage table.
const RESCUE_CHILDREN: [&str; 3] = ["exit_room", "solve_maze", "return_room"];

/// Per rescue run: the stage rates, the training f3 and f3's terms over the post-evaluation
/// (dashes for summaries written before hevo counted them).
fn rescue_stage_table(rescue: &NodeResult) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "The last four columns are what the arbitrator was evolved on: the derived fitness f3 \
         of the run's best genome in its last generation (at most 3, or 4 where the task adds \
         the time bonus of `rescue_time_bonus`), and f3's terms over the post-evaluation, \
         how often the arbitrator chose the child that the sub-task in force asks for. f3 \
         rewards the choice, not the outcome, so a run can solve the rescue with a low term \
         when another child does that sub-task's job. A dash: the run was \
         post-evaluated before hevo counted the choices; `hevo eval` of its `best.json` prints \
         them.\n"
    );
    let _ = writeln!(
        md,
        "| run | exited room | reached teammate | brought back | f3 | right child: room | maze | way back |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    for run in &rescue.runs {
        if let Some(stages) = &run.post_evaluation.stages {
            let [room, maze, back] = RESCUE_CHILDREN
                .map(|child| {
                    stages
                        .right_choice
                        .as_ref()
                        .and_then(|right_choice| right_choice.share(child))
                })
                .map(percent_or_dash);
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {:.3} | {room} | {maze} | {back} |",
                run.run,
                percent(stages.exited_room),
                percent(stages.reached_teammate),
                percent(stages.returned),
                run.final_best_fitness
            );
        }
    }
    md
}

/// The rescue's children bound what its arbitrator can do, so their own solve rates are set
/// beside the best rescue run's stage by stage: the reader sees how much of the gap to the
/// paper is the children's and how much the arbitrator's. Empty when a child or the stage
/// rates are missing.
fn what_the_children_allow(rescue: &NodeResult, nodes: &[NodeResult]) -> String {
    const STAGES: [(&str, &str); 3] = [
        ("leave the room", "exit_room"),
        ("reach the teammate", "solve_maze"),
        ("bring it back", "return_room"),
    ];
    let child_best = |name: &str| {
        nodes
            .iter()
            .find(|n| n.name == name)
            .and_then(NodeResult::avg_and_best)
            .map(|(_, best)| best)
    };
    let Some(child_rates) = STAGES
        .iter()
        .map(|(_, child)| child_best(child))
        .collect::<Option<Vec<f64>>>()
    else {
        return String::new();
    };
    let Some((best_run, stages)) = rescue
        .runs
        .iter()
        .filter_map(|run| Some((run, run.post_evaluation.stages.as_ref()?)))
        .reduce(|best, next| {
            if next.0.post_evaluation.solve_rate > best.0.post_evaluation.solve_rate {
                next
            } else {
                best
            }
        })
    else {
        return String::new();
    };
    // Each stage's pass rate among the samples that reached it, as the children's own rates
    // are among the samples that start where their task starts.
    let reached = [1.0, stages.exited_room, stages.reached_teammate];
    let passed = [stages.exited_room, stages.reached_teammate, stages.returned];
    let mut md = String::from(
        "\n**What the children allow.** The rescue arbitrator can only choose among its children, so \
         their own solve rates (each child's best run, on its own task) limit what it can do. \
         Multiplied, they are about what an arbitrator that always chose the right child would \
         solve if the three sub-tasks failed independently: a reference rather than a strict \
         bound, since in the rescue each child starts where the one before left the robot, not \
         where its own task starts. Beside them, the best rescue run's pass rate at each stage, \
         among the samples that reached the stage.\n\n",
    );
    md.push_str(&format!(
        "| stage | child | the child on its own task | rescue run {}: passed the stage |\n|---|---|---|---|\n",
        best_run.run
    ));
    for (stage_idx, (stage, child)) in STAGES.iter().enumerate() {
        let pass_rate = (reached[stage_idx] > 0.0).then(|| passed[stage_idx] / reached[stage_idx]);
        md.push_str(&format!(
            "| {stage} | {child} | {} | {} |\n",
            percent(child_rates[stage_idx]),
            percent_or_dash(pass_rate)
        ));
    }
    md.push_str(&format!(
        "| the whole rescue | all three | {} (multiplied) | {} |\n",
        percent(child_rates.iter().product()),
        percent(best_run.post_evaluation.solve_rate)
    ));
    md
}

/// Writes `out_file` (REPRODUCTION.md) and its pictures (beside it, in `reproduction/`) from
/// one or more run output directories, and a section per ablation directory. Returns the
/// number of nodes reported.
pub fn write_report(
    runs_dirs: &[PathBuf],
    ablation_dirs: &[PathBuf],
    evaluations: &[PathBuf],
    out_file: &Path,
) -> Result<usize, ReportError> {
    let records = evaluations
        .iter()
        .map(|path| read_record(path))
        .collect::<Result<Vec<_>, _>>()?;
    let mut found: Vec<NodeResult> = Vec::new();
    for runs_dir in runs_dirs {
        found.extend(load_nodes(runs_dir)?);
    }
    let nodes = preferred_nodes(found);
    let mut ablations = Vec::new();
    for ablation_dir in ablation_dirs {
        ablations.push((
            ablation_dir,
            ablation_nodes(load_nodes(ablation_dir)?, &nodes),
        ));
    }
    let base = out_file
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let pictures = base.join("reproduction");
    let mut md = String::new();
    let sources: Vec<String> = runs_dirs
        .iter()
        .map(|d| format!("`{}`", d.display()))
        .collect();
    let _ = writeln!(md, "# Reproduction of the paper's results\n");
    let _ = writeln!(
        md,
        "Generated by `hevo report {}{}{} --out {}` from the run outputs; do not edit by hand. \
         Rerun the command after more runs finish. Solve rates are post-evaluation rates on fresh samples \
         (100 per controller; 100 per light configuration or start branch for maze tasks), as in the paper. \
         \"avg\" is the mean over runs of each run's best controller, \"best\" the best run's controller.\n",
        runs_dirs
            .iter()
            .map(|d| d.display().to_string())
            .collect::<Vec<_>>()
            .join(" "),
        ablation_dirs
            .iter()
            .map(|d| format!(" --ablation {}", d.display()))
            .collect::<String>(),
        evaluations
            .iter()
            .map(|f| format!(" --evaluation {}", f.display()))
            .collect::<String>(),
        out_file.display()
    );
    let _ = writeln!(
        md,
        "Sources: {}. Each node comes from the first of these in which it has a finished run \
         (the `source` column).\n",
        sources.join(", ")
    );
    let _ = writeln!(
        md,
        "What the paper leaves open (sensor model details, the primitives' corridors and fitness, \
         goal tests), and what was changed when a result fell short of the paper and why, is in \
         the decision records in docs/decisions/ (indexed in docs/decisions/README.md).\n"
    );
    let _ = writeln!(
        md,
        "| controller | task | paper avg / best | hevo avg / best | runs (paper) | generations (paper) | post-eval samples | status | source |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    for paper in PAPER {
        let PaperResult {
            controller: name,
            task,
            avg: paper_avg,
            best: paper_best,
            generations: paper_generations,
            runs: paper_runs,
            ..
        } = *paper;
        let Some(node) = nodes.iter().find(|n| n.name == name) else {
            let _ = writeln!(
                md,
                "| {name} | {task} | {} / {} | not run yet | 0 ({paper_runs}) | - ({paper_generations}) | - | not started | - |",
                percent(paper_avg),
                percent(paper_best)
            );
            continue;
        };
        let (ours, samples, generations) = hevo_columns(node);
        let status = status(node);
        let _ = writeln!(
            md,
            "| {name} | {task} | {} / {} | {ours} | {} ({paper_runs}) | {generations} ({paper_generations}) | {samples} | {status} | `{}` |",
            percent(paper_avg),
            percent(paper_best),
            node.runs.len(),
            node.dir.parent().unwrap_or(&node.dir).display()
        );
    }

    let _ = write!(md, "{}", best_under_the_papers_protocol(&nodes));

    if let Some(rescue) = nodes.iter().find(|n| n.name == "rescue")
        && !rescue.runs.is_empty()
    {
        let _ = writeln!(md, "\n## Rescue stages\n");
        let _ = writeln!(
            md,
            "Paper (mean over 10 runs): 91% exit the room, 88% reach the teammate, 85% bring it back.\n"
        );
        let _ = write!(md, "{}", rescue_stage_table(rescue));
        let _ = write!(md, "{}", what_the_children_allow(rescue, &nodes));
    }

    let maze = nodes.iter().find(|n| n.name == "solve_maze");
    let single = nodes.iter().find(|n| n.name == "maze_single");
    let _ = writeln!(md, "\n## Composition versus one network\n");
    let _ = writeln!(md, "{}", composition_paragraph(maze, single));
    let _ = write!(md, "{}", variant_table(maze.into_iter().chain(single)));
    if !ablations.is_empty() {
        let _ = writeln!(
            md,
            "\nThe ablation section(s) below repeat this comparison under other training setups."
        );
    }

    let _ = write!(md, "{}", other_tasks_section(&nodes));

    let node_use = node_use_table(&nodes);
    if !node_use.is_empty() {
        let _ = writeln!(md, "\n## How the arbitrators use their children");
        md.push_str(&node_use);
    }

    // Nodes given more runs under the main setup, from any ablation directory: the widest
    // same-setup base for a comparison in another directory.
    let more_runs: Vec<&NodeResult> = ablations
        .iter()
        .flat_map(|(_, ablation)| ablation.iter())
        .filter(|node| same_setup_as_main(node, &nodes))
        .collect();
    for (ablation_dir, ablation) in &ablations {
        let _ = writeln!(md, "\n## Ablation: `{}`\n", ablation_dir.display());
        let _ = write!(md, "{}", ablation_section(ablation, &nodes, &more_runs));
    }

    let _ = writeln!(md, "\n## Fitness curves\n");
    let _ = writeln!(
        md,
        "Best (solid) and mean (dashed) fitness per generation of every run, with the mean across runs.\n"
    );
    for node in &nodes {
        if let Some(picture) = fitness_picture(node, &node.name, &node.name, &pictures, base)? {
            let _ = writeln!(md, "{picture}\n");
        }
    }
    for (ablation_dir, ablation) in &ablations {
        let dir_name = ablation_dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        for node in ablation {
            let stem = format!("{dir_name}-{}", node.name);
            let title = format!("{} ({dir_name})", node.name);
            if let Some(picture) = fitness_picture(node, &stem, &title, &pictures, base)? {
                let _ = writeln!(md, "{picture}\n");
            }
        }
    }
    md.push_str(&evaluations_section(&records));
    write_atomic(out_file, md.as_bytes()).map_err(io_error(out_file))?;
    Ok(nodes.len() + ablations.iter().map(|(_, a)| a.len()).sum::<usize>())
}

/// An `hevo eval --record` file, checked for its format; errors name the file.
fn read_record(path: &Path) -> Result<EvalRecord, ReportError> {
    let record = read_named::<EvalRecord>(path)?.ok_or_else(|| ReportError::Io {
        path: path.to_path_buf(),
        cause: std::io::Error::new(std::io::ErrorKind::NotFound, "no such evaluation record"),
    })?;
    if record.format != EVAL_RECORD_FORMAT {
        return Err(ReportError::Invalid {
            path: path.to_path_buf(),
            what: format!(
                "format {:?}: an evaluation record is {EVAL_RECORD_FORMAT:?} (`hevo eval --record`)",
                record.format
            ),
        });
    }
    Ok(record)
}

/// Controllers evaluated on tasks they were not evolved for (`hevo eval --record`), one row
/// each with the command that repeats it; empty without records.
fn evaluations_section(records: &[EvalRecord]) -> String {
    if records.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "## Controllers on other tasks\n\n\
         A shipped controller evaluated on a task it was not evolved for, on fresh samples; each \
         row's command writes its record again.\n\n\
         | controller | task | samples | solved | collisions | mean cycles | command |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for record in records {
        let report = &record.report;
        let _ = writeln!(
            md,
            "| `{}` | {} | {} | {} | {} | {:.0} | `{}` |",
            record.controller,
            report.task,
            report.samples,
            percent(report.solve_rate),
            percent(report.collision_rate),
            report.mean_cycles,
            record.command
        );
    }
    md
}

/// Draws `node`'s fitness curves (every run's, and their mean) to `pictures/{stem}-fitness.svg`
/// under `title` and returns the Markdown that shows it, or `None` when no run has logged a
/// generation.
pub(crate) fn fitness_picture(
    node: &NodeResult,
    stem: &str,
    title: &str,
    pictures: &Path,
    base: &Path,
) -> Result<Option<String>, ReportError> {
    let logs = hevo_viz::read_run_logs(&node.dir)?;
    if logs.is_empty() {
        return Ok(None);
    }
    let svg = hevo_viz::fitness_plot_svg(&format!("{title}: fitness per generation"), &logs, None);
    let file = pictures.join(format!("{stem}-fitness.svg"));
    write_atomic(&file, svg.as_bytes()).map_err(io_error(&file))?;
    let relative = file.strip_prefix(base).unwrap_or(&file);
    Ok(Some(format!("![{title} fitness]({})", relative.display())))
}

/// Each finished run's solve rate per variant (light configuration, or start branch), for the
/// nodes whose task has variants: a memory-less or half-remembering maze controller shows as
/// configurations it never solves. Empty when no such run has finished.
/// A node's "hevo avg / best", post-evaluation samples and generations columns.
fn hevo_columns(node: &NodeResult) -> (String, String, String) {
    let Some((avg, best)) = node.avg_and_best() else {
        return ("-".to_string(), "-".to_string(), "-".to_string());
    };
    let mut generations: Vec<u32> = node.runs.iter().map(|r| r.generations).collect();
    generations.dedup();
    let generations: Vec<String> = generations.iter().map(u32::to_string).collect();
    (
        format!("{} / {}", percent(avg), percent(best)),
        node.runs[0].post_evaluation.samples.to_string(),
        generations.join(", "),
    )
}

/// The nodes that are not the paper's (tasks from scenario files of one's own): their solve
/// rates, and per run the rate in each variant under the scenario's names for them. Empty
/// when every node is the paper's.
fn other_tasks_section(nodes: &[NodeResult]) -> String {
    let others: Vec<&NodeResult> = nodes
        .iter()
        .filter(|node| !node.runs.is_empty())
        .filter(|node| !PAPER.iter().any(|paper| paper.controller == node.name))
        .collect();
    if others.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "\n## Tasks not in the paper\n\nNodes evolved on scenario files of tasks the paper does not \
         have: hevo's own figures, to compare with each other.\n\n\
         | controller | task | hevo avg / best | runs | generations | post-eval samples | status | source |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for node in &others {
        let (ours, samples, generations) = hevo_columns(node);
        let _ = writeln!(
            md,
            "| {} | {} | {ours} | {} | {generations} | {samples} | {} | `{}` |",
            node.name,
            node.runs[0].post_evaluation.task,
            node.runs.len(),
            status(node),
            node.dir.parent().unwrap_or(&node.dir).display()
        );
    }
    md.push_str(&per_task_tables(&others));
    md
}

/// Per task of `nodes`, a table per kind of per-run breakdown its runs report, under the
/// scenario's names for the columns: the solve rate in each variant (when there are several),
/// the share of samples that reached each stage, and the share of each phase's cycles in which
/// the arbitrator chose the phase's child (the terms of the derived fitness). The variant
/// tables of every task come first, then the stage and phase tables, task by task.
fn per_task_tables(nodes: &[&NodeResult]) -> String {
    let rows: Vec<(&NodeResult, &RunSummary)> = nodes
        .iter()
        .flat_map(|node| node.runs.iter().map(move |run| (*node, run)))
        .collect();
    let mut tasks: Vec<&str> = rows
        .iter()
        .map(|(_, run)| run.post_evaluation.task.as_str())
        .collect();
    tasks.sort_unstable();
    tasks.dedup();
    let variants: Breakdown = ("the solve rate in each variant", |run| {
        let per_variant = &run.post_evaluation.per_variant;
        if per_variant.len() < 2 {
            return Vec::new();
        }
        per_variant
            .iter()
            .map(|v| {
                let name = v.name.clone().unwrap_or_else(|| v.variant.to_string());
                (name, percent(v.solve_rate))
            })
            .collect()
    });
    let stages: Breakdown = ("the share of samples that reached each stage", |run| {
        run.post_evaluation
            .per_stage
            .iter()
            .map(|s| (s.stage.clone(), percent(s.share)))
            .collect()
    });
    let phases: Breakdown = (
        "the share of each phase's cycles in which the arbitrator chose the phase's child \
         (the terms of the derived fitness; - where no sample reached the phase)",
        |run| {
            run.post_evaluation
                .per_phase
                .iter()
                .map(|p| (p.phase.clone(), percent_or_dash(p.right_choice)))
                .collect()
        },
    );
    let mut md: String = tasks
        .iter()
        .map(|task| task_table(task, variants, &rows))
        .collect();
    for task in &tasks {
        md.push_str(&task_table(task, stages, &rows));
        md.push_str(&task_table(task, phases, &rows));
    }
    md
}

/// A per-run breakdown the report tabulates: what it is, in words, and a run's cells, each a
/// column's name and the run's value (none when the run does not report it).
type Breakdown = (&'static str, fn(&RunSummary) -> Vec<(String, String)>);

/// One table of [`per_task_tables`]: a row for each of `task`'s runs among `rows` that report
/// the breakdown, the columns named by the first such run; empty when none does.
fn task_table(task: &str, (what, cells): Breakdown, rows: &[(&NodeResult, &RunSummary)]) -> String {
    let rows: Vec<_> = rows
        .iter()
        .filter(|(_, run)| run.post_evaluation.task == task)
        .map(|&(node, run)| (node, cells(run), run))
        .filter(|(_, cells, _)| !cells.is_empty())
        .collect();
    let Some((_, first, _)) = rows.first() else {
        return String::new();
    };
    let names: Vec<&str> = first.iter().map(|(name, _)| name.as_str()).collect();
    let mut md = format!(
        "\nIn `{task}`, per run, {what}:\n\n{}",
        run_table_head(&names)
    );
    for (node, cells, run) in &rows {
        let values: Vec<&str> = cells.iter().map(|(_, value)| value.as_str()).collect();
        md.push_str(&run_row(node, run, &values));
    }
    md
}

/// The head of a table with a row per run ([`run_row`]): controller, run, solve rate, then a
/// column per name of `columns`.
fn run_table_head(columns: &[impl AsRef<str>]) -> String {
    format!(
        "| controller | run | solved |{}\n|---|---|---|{}\n",
        trailing_cells(columns),
        "---|".repeat(columns.len())
    )
}

/// One run's row under [`run_table_head`]: its controller, run and solve rate, then `cells`.
fn run_row(node: &NodeResult, run: &RunSummary, cells: &[impl AsRef<str>]) -> String {
    format!(
        "| {} | {} | {} |{}\n",
        node.name,
        run.run,
        percent(run.post_evaluation.solve_rate),
        trailing_cells(cells)
    )
}

/// Cells that follow a row's first ones: ` a | b |`, each closed by its bar.
fn trailing_cells(cells: &[impl AsRef<str>]) -> String {
    cells
        .iter()
        .map(|cell| format!(" {} |", cell.as_ref()))
        .collect()
}

/// One run's row of a per-variant table with `n_variants` columns: controller, run, solve
/// rate, then each variant's rate (`-` where the run has none).
fn variant_row(node: &NodeResult, run: &RunSummary, n_variants: usize) -> String {
    let mut cells = vec!["-".to_string(); n_variants];
    for variant in &run.post_evaluation.per_variant {
        if let Some(cell) = cells.get_mut(variant.variant as usize) {
            *cell = percent(variant.solve_rate);
        }
    }
    run_row(node, run, &cells)
}

fn variant_table<'a>(nodes: impl IntoIterator<Item = &'a NodeResult>) -> String {
    let rows: Vec<(&NodeResult, &RunSummary)> = nodes
        .into_iter()
        .flat_map(|node| node.runs.iter().map(move |run| (node, run)))
        .filter(|(_, run)| !run.post_evaluation.per_variant.is_empty())
        .collect();
    let Some(n_variants) = rows
        .iter()
        .map(|(_, run)| run.post_evaluation.per_variant.len())
        .max()
    else {
        return String::new();
    };
    let mut md = String::from(
        "\nPer run, the solve rate in each light configuration, named by the turns it asks for at the \
         first and second junction: 0 right then left, 1 right then right, 2 left then right, 3 left \
         then left (for return_room, the start branch, in the same order).\n\n",
    );
    let columns: Vec<String> = (0..n_variants).map(|v| v.to_string()).collect();
    md.push_str(&run_table_head(&columns));
    for (node, run) in rows {
        md.push_str(&variant_row(node, run, n_variants));
    }
    md
}

/// How each finished run's best controller used the nodes below its root over its
/// post-evaluation: a table per arbitrator, a cell per node (share of cycles, switch-ons per
/// sample, cycles per switch-on). An arbitrator can compose its children (few long switch-ons)
/// or steer with them (many short ones), and the solve rate alone does not say which. Runs
/// post-evaluated before hevo counted node use are named, not guessed. Empty when no run of
/// these nodes carries the counts.
fn node_use_table<'a>(nodes: impl IntoIterator<Item = &'a NodeResult>) -> String {
    let mut md = String::new();
    for node in nodes {
        let (counted, uncounted): (Vec<&RunSummary>, Vec<&RunSummary>) = node
            .runs
            .iter()
            .partition(|run| !run.post_evaluation.node_use.is_empty());
        let Some(first) = counted.first() else {
            continue;
        };
        if md.is_empty() {
            md.push_str(
                "\nHow each run's best controller used its nodes over its post-evaluation: per node, \
                 the share of cycles it was active, how often it was switched on per sample, and \
                 for how many cycles per switch-on (few long switch-ons compose the children, many \
                 short ones steer with them).\n",
            );
        }
        let root_prefix = format!("{}/", node.name);
        let paths: Vec<&str> = first
            .post_evaluation
            .node_use
            .iter()
            .map(|n| n.node.strip_prefix(&root_prefix).unwrap_or(&n.node))
            .collect();
        md.push('\n');
        md.push_str(&run_table_head(&paths));
        for run in &counted {
            let cells: Vec<String> = run
                .post_evaluation
                .node_use
                .iter()
                .map(|n| {
                    let dwell = n
                        .cycles_per_activation
                        .map_or_else(|| "-".to_string(), |c| format!("{c:.1}"));
                    format!(
                        "{} · {:.1} · {dwell}",
                        percent(n.active_share),
                        n.activations_per_sample
                    )
                })
                .collect();
            md.push_str(&run_row(node, run, &cells));
        }
        if !uncounted.is_empty() {
            let runs: Vec<String> = uncounted.iter().map(|run| run.run.to_string()).collect();
            let _ = writeln!(
                md,
                "\n{} run(s) {} were post-evaluated before hevo counted node use; `hevo eval` of \
                 a run's `best.json` prints it.",
                node.name,
                runs.join(", ")
            );
        }
    }
    md
}

/// An ablation directory's nodes beside the main results' nodes of the same name: avg / best
/// on both sides, the runs behind each, the maze composition comparison when both maze
/// controllers are there, and the per-configuration table. `more_runs` are nodes of other
/// ablation directories given more runs under the main setup.
fn ablation_section(
    ablation: &[NodeResult],
    main: &[NodeResult],
    more_runs: &[&NodeResult],
) -> String {
    if ablation.is_empty() {
        return "No node here was evolved under a setup different from the results above, or \
                given more runs.\n"
            .into();
    }
    let mut md = String::from(
        "Nodes evolved under another setup than the results above (another fingerprint; the \
         experiment file that wrote this directory says what differs), or under the same setup \
         with more runs, beside the same node above.\n\n",
    );
    let _ = writeln!(
        md,
        "| controller | setup | here avg / best | runs | status | above avg / best | runs above |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|");
    let rates = |node: &NodeResult| match node.avg_and_best() {
        Some((avg, best)) => format!("{} / {}", percent(avg), percent(best)),
        None => "-".to_string(),
    };
    for node in ablation {
        let above = main.iter().find(|m| m.name == node.name);
        let setup = if same_setup_as_main(node, main) {
            "same, more runs"
        } else {
            "another"
        };
        let _ = writeln!(
            md,
            "| {} | {setup} | {} | {} | {} | {} | {} |",
            node.name,
            rates(node),
            node.runs.len(),
            status(node),
            above.map_or("-".to_string(), rates),
            above.map_or(0, |m| m.runs.len()),
        );
    }
    // A maze controller given more runs under the main setup is compared with the other maze
    // controller of the main setup when this directory lacks it: the main results' or another
    // directory's, whichever has more runs (the main results' on a tie). Under another setup
    // the comparison needs both sides from here.
    let here = |name: &str| ablation.iter().find(|n| n.name == name);
    let from_main_beside = |name: &str, other: Option<&NodeResult>| {
        other
            .filter(|other| same_setup_as_main(other, main))
            .and_then(|_| {
                // `more_runs` holds same-setup nodes only, and the main results are the setup.
                more_runs
                    .iter()
                    .copied()
                    .chain(main)
                    .filter(|m| m.name == name)
                    .max_by_key(|m| m.runs.len())
            })
    };
    let (maze_here, single_here) = (here("solve_maze"), here("maze_single"));
    let maze = maze_here.or_else(|| from_main_beside("solve_maze", single_here));
    let single = single_here.or_else(|| from_main_beside("maze_single", maze_here));
    if maze_here.is_some() || single_here.is_some() {
        let _ = writeln!(md, "\n{}", composition_paragraph(maze, single));
    }
    // Under a rescue ablation the question is what the arbitrator chose, not only how often
    // it solved: the stage table carries f3's terms.
    if let Some(rescue) = ablation
        .iter()
        .find(|n| n.name == "rescue" && !n.runs.is_empty())
    {
        let _ = write!(
            md,
            "\nThe rescue's stages under this setup, as in \"Rescue stages\" above. {}",
            rescue_stage_table(rescue)
        );
    }
    md.push_str(&variant_table(ablation));
    md.push_str(&node_use_table(ablation));
    md
}

/// "complete", or how many runs have finished and how many are under way.
fn status(node: &NodeResult) -> String {
    if node.complete {
        "complete".to_string()
    } else {
        format!(
            "{} run(s) finished, {} in progress",
            node.runs.len(),
            node.in_progress.len()
        )
    }
}

/// The paper's "best" is the highest of its runs' rates, each measured on few samples, which
/// chance lifts above the runs' true rates; this section puts hevo's runs through the same
/// protocol so that the two "best" figures can be compared like with like.
fn best_under_the_papers_protocol(nodes: &[NodeResult]) -> String {
    let mut md = String::from("\n## The paper's \"best\" under its own protocol\n\n");
    md.push_str(
        "The paper's \"best\" is the highest of its runs' solve rates, each measured on 100 samples \
         (400, 100 per light configuration or start branch, for the tasks in the maze, rescue \
         included). Chance alone lifts such a maximum above the runs' true rates, and hevo has \
         fewer runs per node or more samples per run, so the two \"best\" columns above do not \
         measure the same thing. Here hevo's finished runs go through the paper's protocol: as many runs as the \
         paper had, each one of hevo's runs drawn at random (its post-evaluation rate taken as its true \
         rate), each measured on the paper's number of samples, and the highest kept. The distribution is \
         computed exactly, not simulated. The last column is the range that the paper's own best \
         measurement leaves for its controller's true rate (95 % Wilson interval).\n\n",
    );
    md.push_str(
        "| controller | paper best | hevo best (runs x samples) | hevo by the paper's protocol: median (5-95 %) | chance of reaching the paper's best | paper best's true rate, 95 % |\n\
         |---|---|---|---|---|---|\n",
    );
    for paper in PAPER {
        let Some(node) = nodes.iter().find(|n| n.name == paper.controller) else {
            continue;
        };
        let rates: Vec<f64> = node
            .runs
            .iter()
            .map(|r| r.post_evaluation.solve_rate)
            .collect();
        let (Some((_, best)), Some(best_of_runs)) = (
            node.avg_and_best(),
            BestOfRuns::new(&rates, paper.runs, paper.post_eval_samples),
        ) else {
            continue;
        };
        let (low, high) = wilson_interval(paper.best, paper.post_eval_samples);
        let _ = writeln!(
            md,
            "| {} | {} | {} ({} x {}) | {} ({}-{}) | {:.0}% | {}-{} |",
            paper.controller,
            percent(paper.best),
            percent(best),
            node.runs.len(),
            node.runs[0].post_evaluation.samples,
            percent(best_of_runs.quantile(0.5)),
            percent(best_of_runs.quantile(0.05)),
            percent(best_of_runs.quantile(0.95)),
            100.0 * best_of_runs.chance_of_at_least(paper.best),
            percent(low),
            percent(high),
        );
    }
    md
}

/// The composed maze controller against the single network: both rates, the difference, and
/// the number of runs behind each, since one lucky or unlucky run can carry a difference.
fn composition_paragraph<'a>(
    maze: Option<&'a NodeResult>,
    single: Option<&'a NodeResult>,
) -> String {
    let finished = |node: Option<&'a NodeResult>| node.and_then(|n| Some((n, n.avg_and_best()?)));
    let (Some((maze, (maze_avg, maze_best))), Some((single, (single_avg, single_best)))) =
        (finished(maze), finished(single))
    else {
        return "Not available yet: both `solve_maze` and `maze_single` need finished runs.".into();
    };
    format!(
        "The composed maze controller (arbitrator over three primitives) solves {} on average and {} at best \
         over {} run(s); the single 6-10-2 network {} and {} over {} run(s): {:+.1} and {:+.1} percentage points \
         for composition (paper, 10 runs each: 93% / 99.5% against 40% / 83%).",
        percent(maze_avg),
        percent(maze_best),
        maze.runs.len(),
        percent(single_avg),
        percent(single_best),
        single.runs.len(),
        100.0 * (maze_avg - single_avg),
        100.0 * (maze_best - single_best)
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_rundir::eval_report::{PhaseShare, RightChoice, StageReport};

    fn node(name: &str, source: &str, finished_runs: usize) -> NodeResult {
        let run: RunSummary = serde_json::from_value(serde_json::json!({
            "node": name, "run": 0, "fingerprint": "f", "run_seed": 1, "generations": 10,
            "final_best_fitness": 1.0,
            "post_evaluation": {"task": "follow_wall", "samples": 10, "solve_rate": 1.0,
                "mean_fitness": 1.0, "collision_rate": 0.0, "mean_cycles": 100.0}
        }))
        .unwrap();
        NodeResult {
            name: name.into(),
            runs: vec![run; finished_runs],
            complete: false,
            in_progress: vec![(finished_runs as u32, 5)],
            dir: Path::new(source).join(name),
            fingerprints: vec![format!("{source}-fingerprint")],
        }
    }

    #[test]
    fn evaluation_records_get_a_row_each_and_a_record_of_another_format_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let record = |format: &str| {
            serde_json::json!({
                "format": format, "controller": "controllers/exit_room.json",
                "command": "hevo eval controllers/exit_room.json --task authors.toml --record r.json",
                "report": {"task": "exit_room_authors", "samples": 400, "solve_rate": 0.835,
                    "mean_fitness": 1.2, "collision_rate": 0.065, "mean_cycles": 426.4}
            })
            .to_string()
        };
        let good = dir.path().join("good.json");
        std::fs::write(&good, record(EVAL_RECORD_FORMAT)).unwrap();
        let section = evaluations_section(&[read_record(&good).unwrap()]);
        assert!(
            section.contains("## Controllers on other tasks"),
            "{section}"
        );
        assert!(
            section.contains(
                "| `controllers/exit_room.json` | exit_room_authors | 400 | 83.5% | 6.5% | 426 | \
                 `hevo eval controllers/exit_room.json --task authors.toml --record r.json` |"
            ),
            "{section}"
        );
        assert_eq!(evaluations_section(&[]), "");

        let other = dir.path().join("other.json");
        std::fs::write(&other, record("hevo.evaluation/0")).unwrap();
        let error = read_record(&other).unwrap_err().to_string();
        assert!(
            error.contains("other.json") && error.contains("hevo.evaluation/1"),
            "{error}"
        );
        let missing = read_record(&dir.path().join("missing.json")).unwrap_err();
        assert!(missing.to_string().contains("missing.json"), "{missing}");
    }

    #[test]
    fn tasks_not_in_the_paper_get_their_own_table_with_variant_names() {
        use hevo_rundir::eval_report::VariantReport;
        let variant = |idx: u32, name: &str, rate: f64| VariantReport {
            variant: idx,
            name: Some(name.to_string()),
            samples: 50,
            solve_rate: rate,
        };
        let mut maze = node("my_maze", "mine", 2);
        for (run_idx, run) in maze.runs.iter_mut().enumerate() {
            run.run = run_idx as u32;
            run.post_evaluation.task = "my_maze".into();
            run.post_evaluation.solve_rate = 0.5 + run_idx as f64 / 4.0;
            run.post_evaluation.per_variant = vec![
                variant(0, "left", 1.0),
                variant(1, "right", run_idx as f64 / 2.0),
            ];
        }
        let nodes = [node("follow_wall", "runs", 1), maze];
        let section = other_tasks_section(&nodes);
        assert!(section.contains("## Tasks not in the paper"), "{section}");
        assert!(
            section.contains("| my_maze | my_maze | 62.5% / 75.0% | 2 | 10 | 10 | "),
            "{section}"
        );
        assert!(
            !section.contains("| follow_wall |"),
            "the paper's nodes stay in their table"
        );
        assert!(
            section.contains("| controller | run | solved | left | right |"),
            "{section}"
        );
        assert!(
            section.contains("| my_maze | 1 | 75.0% | 100.0% | 50.0% |"),
            "{section}"
        );
        assert_eq!(other_tasks_section(&nodes[..1]), "");
    }

    #[test]
    fn the_rescue_table_shows_stages_f3_and_its_terms_with_dashes_for_old_summaries() {
        let mut rescue = node("rescue", "new", 2);
        for (run_idx, run) in rescue.runs.iter_mut().enumerate() {
            run.run = run_idx as u32;
            run.final_best_fitness = 2.0 + run_idx as f64 / 2.0;
            run.post_evaluation.stages = Some(StageReport {
                exited_room: 0.99,
                reached_teammate: 0.9,
                returned: 0.855,
                right_choice: None,
            });
        }
        // Run 1 was post-evaluated after hevo counted the choices; it never chose solve maze.
        if let Some(stages) = rescue.runs[1].post_evaluation.stages.as_mut() {
            stages.right_choice = Some(RightChoice {
                phases: [
                    ("exit_room", Some(1.0)),
                    ("solve_maze", Some(0.0)),
                    ("return_room", Some(0.998)),
                ]
                .map(|(phase, right_choice)| PhaseShare {
                    phase: phase.into(),
                    right_choice,
                })
                .to_vec(),
            });
        }
        let table = rescue_stage_table(&rescue);
        let rows: Vec<&str> = table.lines().filter(|l| l.starts_with("| ")).collect();
        assert_eq!(rows.len(), 3, "{table}");
        assert_eq!(rows[1], "| 0 | 99.0% | 90.0% | 85.5% | 2.000 | - | - | - |");
        assert_eq!(
            rows[2],
            "| 1 | 99.0% | 90.0% | 85.5% | 2.500 | 100.0% | 0.0% | 99.8% |"
        );
    }

    #[test]
    fn a_rescue_ablation_shows_its_stages_and_f3_terms() {
        let mut rescue = node("rescue", "ablation", 1);
        rescue.runs[0].post_evaluation.stages = Some(StageReport {
            exited_room: 0.93,
            reached_teammate: 0.89,
            returned: 0.75,
            right_choice: Some(RightChoice {
                phases: [
                    ("exit_room", Some(0.955)),
                    ("solve_maze", Some(0.923)),
                    ("return_room", Some(0.946)),
                ]
                .map(|(phase, right_choice)| PhaseShare {
                    phase: phase.into(),
                    right_choice,
                })
                .to_vec(),
            }),
        });
        let section = ablation_section(&[rescue], &[node("rescue", "main", 3)], &[]);
        assert!(
            section.contains("| 0 | 93.0% | 89.0% | 75.0% | 1.000 | 95.5% | 92.3% | 94.6% |"),
            "{section}"
        );
        let without_rescue = ablation_section(&[node("maze_single", "ablation", 1)], &[], &[]);
        assert!(!without_rescue.contains("right child"), "{without_rescue}");
    }

    #[test]
    fn the_childrens_own_rates_stand_beside_the_best_rescue_runs_stages() {
        let mut rescue = node("rescue", "runs", 2);
        for (run_idx, run) in rescue.runs.iter_mut().enumerate() {
            run.run = run_idx as u32;
            run.post_evaluation.solve_rate = [0.8, 0.9][run_idx];
            run.post_evaluation.stages = Some(StageReport {
                exited_room: 0.96,
                reached_teammate: 0.96 * 0.95,
                returned: 0.9,
                right_choice: None,
            });
        }
        let mut children: Vec<NodeResult> = [
            ("exit_room", 1.0),
            ("solve_maze", 0.995),
            ("return_room", 0.94),
        ]
        .into_iter()
        .map(|(name, rate)| {
            let mut child = node(name, "runs", 1);
            child.runs[0].post_evaluation.solve_rate = rate;
            child
        })
        .collect();
        let section = what_the_children_allow(&rescue, &children);
        let rows: Vec<&str> = section.lines().filter(|l| l.starts_with("| ")).collect();
        assert_eq!(
            rows[1..],
            [
                "| leave the room | exit_room | 100.0% | 96.0% |",
                "| reach the teammate | solve_maze | 99.5% | 95.0% |",
                // 0.9 / (0.96 * 0.95) = 0.98684...
                "| bring it back | return_room | 94.0% | 98.7% |",
                // 1.0 * 0.995 * 0.94 = 0.9353; the best run is run 1 (90 %).
                "| the whole rescue | all three | 93.5% (multiplied) | 90.0% |",
            ],
            "{section}"
        );
        assert!(
            section.contains("rescue run 1: passed the stage"),
            "{section}"
        );
        // Without one of the children there is nothing to set beside the stages.
        children.pop();
        assert_eq!(what_the_children_allow(&rescue, &children), "");
    }

    #[test]
    fn the_papers_best_is_recomputed_for_hevos_runs_under_the_papers_protocol() {
        let mut rescue = node("rescue", "runs", 3);
        for run in &mut rescue.runs {
            run.post_evaluation.solve_rate = 0.85;
        }
        let section = best_under_the_papers_protocol(&[rescue, node("solve_maze", "runs", 0)]);
        // The best of 10 runs that are all truly 85 %, on 400 samples each as the paper's
        // rescue: checked against an independent computation of max-of-binomials (median 351,
        // 5 % 345, 95 % 358 of 400; P(best >= 372) = 7e-6); the paper's 93 % of 400 leaves
        // 90.1-95.1 % for its best controller (Wilson).
        assert!(
            section.contains(
                "| rescue | 93.0% | 85.0% (3 x 10) | 87.8% (86.2%-89.5%) | 0% | 90.1%-95.1% |"
            ),
            "{section}"
        );
        // A node without finished runs has nothing to put through the protocol.
        assert!(!section.contains("| solve_maze |"), "{section}");
    }

    #[test]
    fn composition_is_compared_with_the_runs_behind_each_side() {
        let mut maze = node("solve_maze", "new", 3);
        maze.runs[1].post_evaluation.solve_rate = 0.7;
        let single = node("maze_single", "new", 1);
        assert_eq!(
            composition_paragraph(Some(&maze), Some(&single)),
            "The composed maze controller (arbitrator over three primitives) solves 90.0% on average and 100.0% at best \
             over 3 run(s); the single 6-10-2 network 100.0% and 100.0% over 1 run(s): -10.0 and +0.0 percentage points \
             for composition (paper, 10 runs each: 93% / 99.5% against 40% / 83%)."
        );
        let unfinished = node("maze_single", "new", 0);
        assert!(
            composition_paragraph(Some(&maze), Some(&unfinished)).starts_with("Not available yet")
        );
        assert!(composition_paragraph(Some(&maze), None).starts_with("Not available yet"));
    }

    #[test]
    fn a_node_comes_from_the_first_directory_with_a_finished_run() {
        let nodes = preferred_nodes(vec![
            node("follow_wall", "new", 0),
            node("exit_room", "new", 2),
            node("follow_wall", "old", 3),
            node("exit_room", "old", 3),
            node("turn_left", "old", 0),
        ]);
        let source = |name: &str| {
            let node = nodes.iter().find(|n| n.name == name).unwrap();
            node.dir.parent().unwrap().to_path_buf()
        };
        assert_eq!(nodes.len(), 3);
        assert_eq!(source("follow_wall"), Path::new("old"));
        assert_eq!(source("exit_room"), Path::new("new"));
        assert_eq!(source("turn_left"), Path::new("old"));
    }

    #[test]
    fn ablation_nodes_are_those_evolved_under_another_setup() {
        let main = vec![
            node("follow_wall", "main", 3),
            node("maze_single", "main", 3),
        ];
        let mut copied = node("follow_wall", "ablation", 3);
        copied.fingerprints = main[0].fingerprints.clone();
        // The same setup given more runs in a copy is shown; a plain copy is not.
        let mut extended = node("maze_single", "extended", 5);
        extended.fingerprints = main[1].fingerprints.clone();
        let found = vec![
            copied,
            node("maze_single", "ablation", 1),
            node("solve_maze", "ablation", 0),
            extended,
        ];
        let ablation = ablation_nodes(found, &main);
        let names: Vec<&str> = ablation.iter().map(|n| n.name.as_str()).collect();
        assert_eq!(names, ["maze_single", "solve_maze", "maze_single"]);
        let section = ablation_section(&ablation[2..], &main, &[]);
        assert!(
            section.contains("| maze_single | same, more runs | 100.0% / 100.0% | 5 |"),
            "{section}"
        );
        let section = ablation_section(&ablation[..1], &main, &[]);
        assert!(
            section.contains("| maze_single | another | 100.0% / 100.0% | 1 |"),
            "{section}"
        );
        // Another setup is not compared with the main composition; more runs of the same
        // setup are, when the main results have it.
        assert!(section.contains("Not available yet"), "{section}");
        let main_with_maze = [main.clone(), vec![node("solve_maze", "main", 3)]].concat();
        let section = ablation_section(&ablation[2..], &main_with_maze, &[]);
        assert!(
            section.contains(
                "over 3 run(s); the single 6-10-2 network 100.0% and 100.0% over 5 run(s)"
            ),
            "{section}"
        );
        // A maze controller given more runs in one directory is compared with the other maze
        // controller's largest same-setup set, here the 5 runs of another directory.
        let mut more_mazes = node("solve_maze", "more-mazes", 7);
        more_mazes.fingerprints = main_with_maze[2].fingerprints.clone();
        let section = ablation_section(
            std::slice::from_ref(&more_mazes),
            &main_with_maze,
            &[&ablation[2]],
        );
        assert!(
            section.contains(
                "over 7 run(s); the single 6-10-2 network 100.0% and 100.0% over 5 run(s)"
            ),
            "{section}"
        );
        // Without it, the main results' 3.
        let section = ablation_section(std::slice::from_ref(&more_mazes), &main_with_maze, &[]);
        assert!(
            section.contains("network 100.0% and 100.0% over 3 run(s):"),
            "{section}"
        );
    }

    #[test]
    fn the_variant_table_shows_each_runs_rate_per_light_configuration() {
        let mut single = node("maze_single", "main", 2);
        single.runs[1].run = 1;
        single.runs[1].post_evaluation.solve_rate = 0.75;
        single.runs[1].post_evaluation.per_variant = [0.99, 1.0, 0.0, 1.0]
            .iter()
            .enumerate()
            .map(
                |(variant, &solve_rate)| hevo_rundir::eval_report::VariantReport {
                    variant: variant as u32,
                    name: None,
                    samples: 100,
                    solve_rate,
                },
            )
            .collect();
        let table = variant_table([&single]);
        assert!(
            table.contains("| controller | run | solved | 0 | 1 | 2 | 3 |"),
            "{table}"
        );
        assert!(
            table.contains("| maze_single | 1 | 75.0% | 99.0% | 100.0% | 0.0% | 100.0% |"),
            "{table}"
        );
        // Run 0 has no per-configuration rates (a task without variants): no row.
        assert!(!table.contains("| maze_single | 0 |"), "{table}");
        assert_eq!(variant_table([&node("follow_wall", "main", 2)]), "");
    }

    #[test]
    fn the_stage_and_phase_tables_show_each_runs_shares_under_the_scenarios_names() {
        use hevo_rundir::eval_report::{PhaseShare, StageShare};
        let mut arena = node("forage", "main", 2);
        for (run_idx, run) in arena.runs.iter_mut().enumerate() {
            run.run = run_idx as u32;
            run.post_evaluation.task = "forage".into();
        }
        let evaluation = &mut arena.runs[1].post_evaluation;
        evaluation.solve_rate = 0.5;
        evaluation.per_stage = vec![
            StageShare {
                stage: "left_room".into(),
                share: 0.9,
            },
            StageShare {
                stage: "solved".into(),
                share: 0.5,
            },
        ];
        evaluation.per_phase = vec![
            PhaseShare {
                phase: "in_room".into(),
                right_choice: Some(0.75),
            },
            PhaseShare {
                phase: "outside".into(),
                right_choice: None,
            },
        ];
        let tables = per_task_tables(&[&arena]);
        assert!(
            tables.contains("| controller | run | solved | left_room | solved |"),
            "{tables}"
        );
        assert!(
            tables.contains("| forage | 1 | 50.0% | 90.0% | 50.0% |"),
            "{tables}"
        );
        assert!(
            tables.contains("| controller | run | solved | in_room | outside |"),
            "{tables}"
        );
        assert!(
            tables.contains("| forage | 1 | 50.0% | 75.0% | - |"),
            "{tables}"
        );
        // Run 0 reported neither (written before hevo counted them): no row.
        assert!(!tables.contains("| forage | 0 |"), "{tables}");
        // No scenario with stages or phases: nothing at all.
        assert_eq!(per_task_tables(&[&node("follow_wall", "main", 2)]), "");
    }

    #[test]
    fn the_node_use_table_shows_counted_runs_and_names_the_others() {
        use hevo_rundir::eval_report::NodeUseReport;
        let mut maze = node("solve_maze", "main", 3);
        for (run_idx, run) in maze.runs.iter_mut().enumerate() {
            run.run = run_idx as u32;
        }
        maze.runs[2].post_evaluation.node_use = vec![
            NodeUseReport {
                node: "solve_maze/follow_wall".into(),
                active_share: 0.0,
                activations_per_sample: 0.0,
                cycles_per_activation: None,
            },
            NodeUseReport {
                node: "solve_maze/turn_left".into(),
                active_share: 0.25,
                activations_per_sample: 2.5,
                cycles_per_activation: Some(40.0),
            },
        ];
        let table = node_use_table([&maze]);
        assert!(
            table.contains("| controller | run | solved | follow_wall | turn_left |"),
            "{table}"
        );
        assert!(
            table.contains("| solve_maze | 2 | 100.0% | 0.0% · 0.0 · - | 25.0% · 2.5 · 40.0 |"),
            "{table}"
        );
        assert!(
            table.contains("solve_maze run(s) 0, 1 were post-evaluated before"),
            "{table}"
        );
        // No run counted: nothing at all.
        assert_eq!(node_use_table([&node("solve_maze", "main", 2)]), "");
    }

    #[test]
    fn a_node_being_extended_shows_its_runs_under_way_and_is_not_complete() {
        let dir = tempfile::tempdir().unwrap();
        let node_dir = dir.path().join("maze_single");
        let finished = node("maze_single", "main", 1).runs.remove(0);
        std::fs::create_dir_all(node_dir.join("run-0")).unwrap();
        std::fs::create_dir_all(node_dir.join("run-1")).unwrap();
        let write = |path: PathBuf, value: serde_json::Value| {
            std::fs::write(path, value.to_string()).unwrap();
        };
        write(
            node_dir.join("run-0/summary.json"),
            serde_json::to_value(&finished).unwrap(),
        );
        write(
            node_dir.join(SUMMARY),
            serde_json::json!({
                "node": "maze_single", "task": "solve_maze", "fingerprint": "f",
                "runs": [finished], "best_run": 0, "mean_solve_rate": 1.0, "best_solve_rate": 1.0
            }),
        );
        let loaded = load_node(&node_dir).unwrap().unwrap();
        assert!(loaded.complete);
        assert_eq!((loaded.runs.len(), loaded.in_progress.len()), (1, 0));

        write(
            node_dir.join("run-1/checkpoint.json"),
            serde_json::json!({"format": "hevo.checkpoint/1", "fingerprint": "f", "generation": 3}),
        );
        let loaded = load_node(&node_dir).unwrap().unwrap();
        assert!(!loaded.complete);
        assert_eq!((loaded.runs.len(), loaded.in_progress.len()), (1, 1));
        assert_eq!(status(&loaded), "1 run(s) finished, 1 in progress");
    }
}
