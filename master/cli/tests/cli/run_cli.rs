//! End-to-end tests of `hevo run` as a user runs it: the real binary on a small experiment.
//! They prove the properties a long evolution depends on: a run killed at any moment resumes
//! to exactly the result an uninterrupted run gives, the thread count never changes results,
//! a changed experiment under existing checkpoints is refused, and bad files get clear errors.

use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

use crate::support::{SMALL, hevo, hevo_command, hevo_ok, repo_root, write_experiment};

/// Every file under `dir`, relative path -> bytes.
fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(current) = stack.pop() {
        for entry in std::fs::read_dir(&current).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let relative = path
                    .strip_prefix(dir)
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                files.push((relative, std::fs::read(&path).unwrap()));
            }
        }
    }
    files.sort();
    files
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let target = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_dir(&path, &target);
        } else {
            std::fs::copy(&path, &target).unwrap();
        }
    }
}

fn assert_same_tree(a: &Path, b: &Path) {
    let (ta, tb) = (tree(a), tree(b));
    let names = |t: &[(String, Vec<u8>)]| t.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&ta), names(&tb), "same files");
    for ((name, bytes_a), (_, bytes_b)) in ta.iter().zip(&tb) {
        assert!(
            bytes_a == bytes_b,
            "{name} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

#[test]
fn a_killed_run_resumes_to_the_identical_result_and_threads_do_not_matter() {
    let dir = tempfile::tempdir().unwrap();
    // 2 runs of 30 generations: a run takes a second or two, long enough to be killed in.
    let long = SMALL.replace("generations = 10", "generations = 30");
    assert_ne!(long, SMALL, "the fixture sets generations = 10");
    let experiment = write_experiment(dir.path(), &long);
    let experiment = experiment.to_str().unwrap();

    let straight = dir.path().join("straight");
    hevo_ok(&[
        "run",
        experiment,
        "--out",
        straight.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    let summary = std::fs::read_to_string(straight.join("exit_room/summary.json")).unwrap();
    assert!(summary.contains("\"best_run\""));

    // One thread: the same bytes.
    let single = dir.path().join("single");
    hevo_ok(&[
        "run",
        experiment,
        "--out",
        single.to_str().unwrap(),
        "--threads",
        "1",
    ]);
    assert_same_tree(&straight, &single);

    // Kill -9 in the middle of the run, then run the same command again.
    let killed = dir.path().join("killed");
    kill_mid_run(experiment, &killed, "exit_room");
    hevo_ok(&[
        "run",
        experiment,
        "--out",
        killed.to_str().unwrap(),
        "--threads",
        "2",
    ]);
    assert_same_tree(&straight, &killed);

    // A rerun of a finished experiment does nothing and changes nothing.
    hevo_ok(&["run", experiment, "--out", straight.to_str().unwrap()]);
    assert_same_tree(&straight, &single);

    // Changing the experiment under existing results is refused.
    let changed = write_experiment(dir.path(), &long.replace("hidden = 4", "hidden = 5"));
    let out = hevo(&[
        "run",
        changed.to_str().unwrap(),
        "--out",
        killed.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    let message = String::from_utf8_lossy(&out.stderr);
    assert!(
        message.contains("different experiment setup") && message.contains("exit_room"),
        "{message}"
    );
}

/// Starts `hevo run EXPERIMENT --out OUT` and kills it (-9) at the first checkpoint of either
/// of its node's two runs, with most of their generations still to do; the exit status shows
/// that the kill landed before the end.
fn kill_mid_run(experiment: &str, out: &Path, node: &str) {
    let mut child = hevo_command(&[
        "run",
        experiment,
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "2",
    ])
    .stdout(Stdio::null())
    .stderr(Stdio::null())
    .spawn()
    .unwrap();
    let checkpoints = [0, 1].map(|run| out.join(format!("{node}/run-{run}/checkpoint.json")));
    let started = Instant::now();
    let killed_at = loop {
        let generation = checkpoints.iter().find_map(|checkpoint| {
            std::fs::read_to_string(checkpoint)
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .and_then(|v| v["generation"].as_u64())
        });
        if let Some(generation) = generation.filter(|&g| g >= 1) {
            break generation;
        }
        assert!(
            started.elapsed() < Duration::from_secs(120),
            "no checkpoint appeared"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run finished before it could be killed; give it more generations"
        );
        std::thread::sleep(Duration::from_millis(5));
    };
    child.kill().unwrap();
    let status = child.wait().unwrap();
    {
        use std::os::unix::process::ExitStatusExt;
        assert_eq!(
            status.signal(),
            Some(9),
            "the run ended before the kill (checkpoint at generation {killed_at}): {status}"
        );
    }
    assert!(
        !out.join(format!("{node}/summary.json")).exists(),
        "killed before the end"
    );
}

/// Every search algorithm, killed with -9 mid-run and resumed by the same command, ends with
/// the files of a run never interrupted, byte for byte: its whole state (CMA-ES's mean,
/// covariance and step size, IPOP's restart count, novelty search's archive, MAP-Elites' grid)
/// is in the checkpoint.
#[test]
fn every_algorithm_resumes_from_a_kill_to_the_identical_result() {
    let algorithms = [
        ("cmaes", "algorithm = \"cmaes\""),
        (
            "sep-cmaes-ipop",
            "algorithm = \"cmaes\"\ncmaes_variant = \"separable\"\nrestarts = 3",
        ),
        (
            "novelty",
            "algorithm = \"novelty\"\nelites = 3\nnovelty_neighbours = 4\nnovelty_fitness_weight = 0.25",
        ),
        (
            "map-elites",
            "algorithm = \"map_elites\"\nmap_elites_bins = [4, 4]\nmap_elites_ranges = [[-2.0, 2.0], [-2.0, 2.0]]",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (name, evolution) in algorithms {
        let text = SMALL
            .replace("generations = 10", "generations = 30")
            .replace(
                "population = 12\nelites = 3",
                &format!("population = 12\n{evolution}"),
            );
        assert!(
            text.contains(evolution),
            "the fixture's [evolution] changed"
        );
        let experiment = dir.path().join(format!("{name}.toml"));
        std::fs::write(&experiment, text).unwrap();
        let experiment = experiment.to_str().unwrap();
        let straight = dir.path().join(format!("{name}-straight"));
        hevo_ok(&["run", experiment, "--out", straight.to_str().unwrap()]);
        let killed = dir.path().join(format!("{name}-killed"));
        kill_mid_run(experiment, &killed, "exit_room");
        hevo_ok(&["run", experiment, "--out", killed.to_str().unwrap()]);
        assert_same_tree(&straight, &killed);
    }
}

/// Two levels: a maze arbitrator over one primitive, small enough to run in seconds.
const TWO_LEVELS: &str = include_str!("../../../../tests/fixtures/two_levels.toml");

#[test]
fn more_runs_of_one_node_keep_its_children_and_are_never_thrown_away() {
    let dir = tempfile::tempdir().unwrap();
    let experiment = write_experiment(dir.path(), TWO_LEVELS);
    let experiment = experiment.to_str().unwrap();
    let out_dir = dir.path().join("o");
    let out = out_dir.to_str().unwrap();
    let n_runs = |node: &str| {
        let text = std::fs::read_to_string(out_dir.join(node).join("summary.json")).unwrap();
        let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
        summary["runs"].as_array().unwrap().len()
    };
    hevo_ok(&["run", experiment, "--out", out]);
    assert_eq!((n_runs("follow_wall"), n_runs("solve_maze")), (1, 1));
    let child_before = tree(&out_dir.join("follow_wall"));

    // Two more runs of the arbitrator alone: the finished child is reused as it is.
    hevo_ok(&[
        "run",
        experiment,
        "--node",
        "solve_maze",
        "--runs",
        "3",
        "--out",
        out,
    ]);
    assert_eq!((n_runs("follow_wall"), n_runs("solve_maze")), (1, 3));
    assert!(out_dir.join("solve_maze/run-2/best.json").exists());
    assert!(tree(&out_dir.join("follow_wall")) == child_before);

    // Fewer generations for the arbitrator alone: the child evolved for its own 2 is reused.
    let short = dir.path().join("short");
    std::fs::create_dir_all(&short).unwrap();
    copy_dir(&out_dir.join("follow_wall"), &short.join("follow_wall"));
    hevo_ok(&[
        "run",
        experiment,
        "--node",
        "solve_maze",
        "--generations",
        "1",
        "--out",
        short.to_str().unwrap(),
    ]);
    assert!(tree(&short.join("follow_wall")) == child_before);
    let log = std::fs::read_to_string(short.join("solve_maze/run-0/fitness.csv")).unwrap();
    assert_eq!(log.lines().count(), 2, "a header and one generation: {log}");

    // Asking for fewer runs than are finished keeps them all.
    let before = tree(&out_dir);
    hevo_ok(&["run", experiment, "--out", out]);
    assert!(tree(&out_dir) == before, "a rerun changed finished results");
}

/// `hevo run --node N --runs K` writes the node summary only when all K runs are done. When it is
/// stopped after a run finished, that run must still count: the next command folds it into the
/// summary and `best.json` before any parent is composed from them.
#[test]
fn finished_runs_of_an_interrupted_extension_are_folded_into_the_node() {
    let dir = tempfile::tempdir().unwrap();
    let experiment = write_experiment(dir.path(), TWO_LEVELS);
    let experiment = experiment.to_str().unwrap();
    let out_dir = dir.path().join("o");
    let out = out_dir.to_str().unwrap();
    hevo_ok(&[
        "run",
        experiment,
        "--node",
        "follow_wall",
        "--runs",
        "2",
        "--out",
        out,
    ]);

    // The state an extension stopped after its run 1 leaves: the summary lists run 0 only.
    let summary_path = out_dir.join("follow_wall/summary.json");
    let complete: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary_path).unwrap()).unwrap();
    let mut stale = complete.clone();
    stale["runs"].as_array_mut().unwrap().truncate(1);
    stale["best_run"] = 0.into();
    std::fs::write(&summary_path, serde_json::to_string_pretty(&stale).unwrap()).unwrap();
    std::fs::copy(
        out_dir.join("follow_wall/run-0/best.json"),
        out_dir.join("follow_wall/best.json"),
    )
    .unwrap();

    let output = hevo_ok(&["run", experiment, "--out", out]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let refreshed: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary_path).unwrap()).unwrap();
    assert_eq!(refreshed, complete, "{stderr}");
    let best_run = complete["best_run"].as_u64().unwrap();
    assert_eq!(
        std::fs::read(out_dir.join("follow_wall/best.json")).unwrap(),
        std::fs::read(out_dir.join(format!("follow_wall/run-{best_run}/best.json"))).unwrap()
    );
    // The parent is composed from the refreshed best controller.
    let parent = std::fs::read_to_string(out_dir.join("solve_maze/best.json")).unwrap();
    let child = std::fs::read_to_string(out_dir.join("follow_wall/best.json")).unwrap();
    let genome_of = |text: &str, path: &[&str]| {
        let mut value: serde_json::Value = serde_json::from_str(text).unwrap();
        for key in path {
            value = value[key].clone();
        }
        value
    };
    assert_eq!(
        genome_of(&parent, &["root", "children"])[0]["genome"],
        genome_of(&child, &["root", "genome"])
    );
}

#[test]
fn bad_experiment_files_are_rejected_with_the_key_path() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (SMALL.replace("hidden = 4", "hiden = 4"), "node[0]"),
        (
            SMALL.replace("task = \"exit_room\"", "task = \"exit_rom\""),
            "node[0].task",
        ),
        (
            SMALL.replace("samples = 6\n", "samples = 0\n"),
            "node[0].samples",
        ),
        (
            SMALL.replace("[evolution]", "[evolution]\nmutation_rate = 0.2"),
            "evolution",
        ),
    ];
    for (text, key) in cases {
        let path = write_experiment(dir.path(), &text);
        let out = hevo(&[
            "run",
            path.to_str().unwrap(),
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ]);
        assert!(!out.status.success());
        let message = String::from_utf8_lossy(&out.stderr);
        assert!(
            message.contains("small.toml") && message.contains(key),
            "expected {key} in: {message}"
        );
        assert!(!message.contains("panicked"), "{message}");
    }
    let out = hevo(&["run", dir.path().join("missing.toml").to_str().unwrap()]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    // The reason is said once, not again by the error chain.
    assert!(
        stderr.contains("missing.toml: cannot read: ") && stderr.matches("os error").count() == 1,
        "{stderr}"
    );
}

#[test]
fn eval_and_bench_report_what_they_measured() {
    let dir = tempfile::tempdir().unwrap();
    // A controller file from a tiny run.
    let experiment = write_experiment(
        dir.path(),
        &SMALL
            .replace("generations = 10", "generations = 1")
            .replace("runs = 2", "runs = 1"),
    );
    let out_dir = dir.path().join("o");
    hevo_ok(&[
        "run",
        experiment.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    let controller = out_dir.join("exit_room/best.json");
    let out = hevo_ok(&[
        "eval",
        controller.to_str().unwrap(),
        "--task",
        "exit_room",
        "--samples",
        "5",
        "--json",
    ]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // What the fixed-seed run and eval's default samples give: a one-generation controller
    // leaves the room on none of the 5 samples, touches a wall on 1, and runs out the 1000
    // cycles on all but one (which ends at its collision at cycle 968).
    assert_eq!(report["samples"], 5);
    assert_eq!(report["solve_rate"].as_f64(), Some(0.0), "{report}");
    assert_eq!(report["collision_rate"].as_f64(), Some(0.2), "{report}");
    assert_eq!(report["mean_cycles"].as_f64(), Some(993.6), "{report}");

    // A 4-input primitive runs in the maze too (it just ignores the lights): 2 per light configuration.
    let eval_maze = |extra: &[&str]| {
        let mut args = vec![
            "eval",
            controller.to_str().unwrap(),
            "--task",
            "solve_maze",
            "--samples",
            "2",
        ];
        args.extend_from_slice(extra);
        hevo_ok(&args)
    };
    let out = eval_maze(&["--json"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["samples"], 8);
    assert_eq!(report["per_variant"].as_array().unwrap().len(), 4);
    assert!(report.get("failures").is_none(), "only listed when asked");

    // --failures lists every unsolved sample with what replays it, and the replay agrees.
    let out = eval_maze(&["--json", "--failures"]);
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let failures = report["failures"].as_array().unwrap();
    let solve_rate = report["solve_rate"].as_f64().unwrap();
    assert_eq!(failures.len(), (8.0 * (1.0 - solve_rate)).round() as usize);
    assert!(
        !failures.is_empty(),
        "a 1-generation room primitive fails the maze"
    );
    let failure = &failures[0];
    let replay = dir.path().join("failure.svg");
    let out = hevo_ok(&[
        "replay",
        controller.to_str().unwrap(),
        "--task",
        "solve_maze",
        "--seed",
        &failure["seed"].as_u64().unwrap().to_string(),
        "--light-config",
        &failure["variant"].as_u64().unwrap().to_string(),
        "--out",
        replay.to_str().unwrap(),
    ]);
    let replay_line = String::from_utf8_lossy(&out.stdout);
    let cycles = failure["cycles"].as_u64().unwrap();
    assert!(
        replay_line.contains(&format!(" after {cycles} cycles")),
        "{replay_line} vs {failure}"
    );
    let text = eval_maze(&["--failures"]);
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains(&format!("unsolved samples: {} (", failures.len()))
            && text.contains("hevo replay")
            && text.contains("--light-config"),
        "{text}"
    );

    // Pictures are SVG; another name is refused before anything runs, not written as SVG.
    let png = dir.path().join("trace.png");
    let out = hevo(&[
        "replay",
        controller.to_str().unwrap(),
        "--task",
        "exit_room",
        "--out",
        png.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("trace.png") && stderr.contains("*.svg"),
        "{stderr}"
    );
    assert!(!png.exists());

    let out = hevo(&["eval", controller.to_str().unwrap(), "--task", "teleport"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("unknown task 'teleport'")
            && stderr.contains("scenario file")
            && stderr.contains("solve_maze"),
        "{stderr}"
    );

    // The reproduction report is generated from the outputs, with the paper's figures beside.
    let report_file = dir.path().join("doc/REPRODUCTION.md");
    hevo_ok(&[
        "report",
        out_dir.to_str().unwrap(),
        "--out",
        report_file.to_str().unwrap(),
    ]);
    let markdown = std::fs::read_to_string(&report_file).unwrap();
    assert!(
        markdown.contains("| exit_room | exit_room | 52.0% / 96.0% |"),
        "{markdown}"
    );
    assert!(
        markdown.contains("| solve_maze | solve_maze | 93.0% / 99.5% | not run yet"),
        "{markdown}"
    );
    assert!(markdown.contains("reproduction/exit_room-fitness.svg"));
    assert!(
        dir.path()
            .join("doc/reproduction/exit_room-fitness.svg")
            .exists()
    );

    // A controller evaluated on another task, recorded, gets a row with the command that
    // writes its record again.
    let record = dir.path().join("exit_room-on-maze.json");
    hevo_ok(&[
        "eval",
        controller.to_str().unwrap(),
        "--task",
        "solve_maze",
        "--samples",
        "2",
        "--record",
        record.to_str().unwrap(),
    ]);
    let recorded: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&record).unwrap()).unwrap();
    assert_eq!(recorded["format"], "hevo.evaluation/1");
    assert_eq!(recorded["report"]["task"], "solve_maze");
    assert_eq!(
        recorded["command"],
        format!(
            "hevo eval {} --task solve_maze --samples 2 --record {}",
            controller.display(),
            record.display()
        )
    );
    hevo_ok(&[
        "report",
        out_dir.to_str().unwrap(),
        "--evaluation",
        record.to_str().unwrap(),
        "--out",
        report_file.to_str().unwrap(),
    ]);
    let markdown = std::fs::read_to_string(&report_file).unwrap();
    assert!(
        markdown.contains("## Controllers on other tasks")
            && markdown.contains("| solve_maze | 8 | "),
        "{markdown}"
    );

    // An ablation directory: its node evolved under another setup (here another seed) gets a
    // section beside the main results; a node copied from the main results does not.
    let ablation_dir = dir.path().join("ablation");
    hevo_ok(&[
        "run",
        experiment.to_str().unwrap(),
        "--seed",
        "8",
        "--out",
        ablation_dir.to_str().unwrap(),
    ]);
    let copied_dir = dir.path().join("copied");
    copy_dir(&out_dir, &copied_dir);
    hevo_ok(&[
        "report",
        out_dir.to_str().unwrap(),
        "--ablation",
        ablation_dir.to_str().unwrap(),
        "--ablation",
        copied_dir.to_str().unwrap(),
        "--out",
        report_file.to_str().unwrap(),
    ]);
    let markdown = std::fs::read_to_string(&report_file).unwrap();
    let ablation_section = markdown
        .split("## Ablation: ")
        .nth(1)
        .expect("an ablation section");
    assert!(
        ablation_section.contains("| exit_room | ")
            && ablation_section.contains(" | 1 | complete | "),
        "{markdown}"
    );
    let copied_section = markdown.split("## Ablation: ").nth(2).unwrap();
    assert!(
        copied_section.contains("No node here was evolved under a setup different"),
        "{markdown}"
    );
    assert!(markdown.contains("--ablation"), "{markdown}");
    assert!(
        dir.path()
            .join("doc/reproduction/ablation-exit_room-fitness.svg")
            .exists()
    );

    let out = hevo_ok(&[
        "bench",
        "--task",
        "follow_wall",
        "--seconds",
        "0.3",
        "--threads",
        "1",
        "--json",
    ]);
    // One JSON object per line, one per evaluator: the scalar reference, then lockstep.
    let stdout = String::from_utf8(out.stdout).unwrap();
    let reports: Vec<serde_json::Value> = stdout
        .lines()
        .map(|line| serde_json::from_str(line).unwrap())
        .collect();
    let evaluators: Vec<&str> = reports
        .iter()
        .map(|report| report["evaluator"].as_str().unwrap_or_default())
        .collect();
    assert_eq!(evaluators, ["scalar", "lockstep"], "{stdout}");
    for report in &reports {
        check_bench_report(report);
    }
}

/// One evaluator's `hevo bench --json` figures agree with each other.
fn check_bench_report(report: &serde_json::Value) {
    assert_eq!(report["task"], "follow_wall");
    assert_eq!(report["threads"], 1);
    assert_eq!(report["mode"], "simulator");
    // The rates are the counts the command printed over the time it printed: at least the
    // 0.3 s asked for, and at most that plus the sample in hand when the time was up.
    let number = |key: &str| {
        report[key]
            .as_f64()
            .unwrap_or_else(|| panic!("{key}: {report}"))
    };
    let (cycles, evaluations, seconds) =
        (number("cycles"), number("evaluations"), number("seconds"));
    assert!((0.3..5.0).contains(&seconds), "{report}");
    let close = |rate: f64, expected: f64| (rate - expected).abs() <= 1e-9 * expected;
    assert!(
        close(number("cycles_per_second"), cycles / seconds),
        "{report}"
    );
    assert!(
        close(number("cycles_per_second_per_thread"), cycles / seconds),
        "{report}"
    );
    assert!(
        close(number("evaluations_per_second"), evaluations / seconds),
        "{report}"
    );
    // Every sample ran at least one cycle and at most follow_wall's 400.
    assert!(
        evaluations >= 1.0 && evaluations <= cycles && cycles <= 400.0 * evaluations,
        "{report}"
    );
}

/// `hevo eval ... | head` closes the pipe before hevo has printed everything: hevo stops
/// quietly and successfully instead of panicking on the failed write.
#[test]
fn a_closed_stdout_ends_a_command_quietly() {
    let controller = repo_root().join("controllers/exit_room.json");
    let mut child = hevo_command(&["eval", controller.to_str().unwrap(), "--task", "exit_room"])
        .args(["--samples", "20", "--threads", "1", "--failures"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("hevo starts");
    // The reader goes away before the evaluation has printed anything.
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("hevo ends");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{:?}: {stderr}", output.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}

/// `hevo eval --experiment FILE --node NAME` judges a controller by the task that node trains
/// on, its overrides and cycle limit included (how an ablation's controllers are judged by its
/// own rules), and the replay commands it prints name the same task.
#[test]
fn eval_and_replay_take_a_nodes_task_from_an_experiment_file() {
    let dir = tempfile::tempdir().unwrap();
    // The shipped exit room controller needs a few hundred cycles to leave a room; this node
    // gives it 60.
    let experiment = write_experiment(
        dir.path(),
        &SMALL.replace("generations = 10", "cycles = 60\ngenerations = 10"),
    );
    let experiment = experiment.to_str().unwrap();
    let controller = repo_root().join("controllers/exit_room.json");
    let controller = controller.to_str().unwrap();
    let eval = |task_flags: &[&str]| {
        let mut args = vec!["eval", controller, "--samples", "4", "--threads", "1"];
        args.extend_from_slice(task_flags);
        hevo_ok(&args)
    };
    let json = |task_flags: &[&str]| -> serde_json::Value {
        let mut flags = task_flags.to_vec();
        flags.extend_from_slice(&["--json", "--failures"]);
        serde_json::from_slice(&eval(&flags).stdout).unwrap()
    };
    let node_flags = ["--experiment", experiment, "--node", "exit_room"];

    // Under the paper's task it leaves the room on all 4 samples, after 280.5 cycles on
    // average (eval's default samples).
    let paper = json(&["--task", "exit_room"]);
    assert_eq!(paper["solve_rate"].as_f64(), Some(1.0), "{paper}");
    assert_eq!(paper["mean_cycles"].as_f64(), Some(280.5), "{paper}");
    let short = json(&node_flags);
    assert_eq!(short["solve_rate"].as_f64(), Some(0.0), "{short}");
    let failures = short["failures"].as_array().unwrap();
    assert_eq!(failures.len(), 4);
    assert!(
        failures.iter().all(|f| f["cycles"].as_u64().unwrap() <= 60),
        "{short}"
    );

    let text = eval(&[&node_flags[..], &["--failures"]].concat());
    let text = String::from_utf8_lossy(&text.stdout);
    assert!(
        text.contains(&format!(
            "--experiment {experiment} --node exit_room --seed"
        )),
        "{text}"
    );
    let failure = &failures[0];
    let replay = dir.path().join("short.svg");
    let seed = failure["seed"].as_u64().unwrap().to_string();
    let mut args = vec!["replay", controller, "--seed", &seed];
    args.extend_from_slice(&node_flags);
    args.extend_from_slice(&["--out", replay.to_str().unwrap()]);
    let replay_line = String::from_utf8_lossy(&hevo_ok(&args).stdout).into_owned();
    assert!(
        replay_line.contains(&format!(" after {} cycles", failure["cycles"])),
        "{replay_line} vs {failure}"
    );

    let out = hevo(&[
        "eval",
        controller,
        "--experiment",
        experiment,
        "--node",
        "exit_rom",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && stderr.contains(&format!("no node named 'exit_rom' in {experiment}"))
            && stderr.contains("; nodes: exit_room"),
        "{stderr}"
    );
    let out = hevo(&["eval", controller, "--experiment", experiment]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--node"));
}
