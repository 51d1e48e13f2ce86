//! Every controller shipped in `controllers/` exported as C, compiled with the system C
//! compiler and checked against sim-core on recorded cycles (`make check`): the float target
//! bit for bit (every network input from the raw readings, every node's output, the active
//! path, the wheels), the fixed target within its reported errors. And the closed loop: the
//! exported C driving the simulator in place of sim-core's controller solves the same samples
//! with identical outcomes (float).
//!
//! They need `make` and a C compiler (`cc`): without them these tests fail when the
//! environment variable `CI` is set and are skipped loudly otherwise, as the repository's
//! tests that need tools do (`tests/tools.rs`).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use hevo_export::{ExportOptions, Target, closed_loop, vectors};
use hevo_sim_core::Scenario;
use hevo_sim_core::{ControllerFile, InputGroup, NodeSpec};
use hevo_sim_core::{Sample, TaskConfig};

fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && !v.eq_ignore_ascii_case("false"))
}

/// Whether `make` and `cc` run; under CI their absence is a failure.
fn c_toolchain(test: &str) -> bool {
    let runs = |tool: &str| {
        Command::new(tool)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if runs("make") && runs("cc") {
        return true;
    }
    assert!(
        !in_ci(),
        "{test}: `make` or `cc` is missing, and CI is set: CI must be able to run it"
    );
    let bar = "!".repeat(100);
    eprintln!("\n{bar}\n!!! SKIPPED {test}: `make` or `cc` is missing.\n{bar}\n");
    false
}

/// The task of a shipped controller: its file's stem, a shipped scenario or an example
/// scenario file; `NAME_single` is the single network evolved for the task `NAME`.
fn task_of(stem: &str) -> TaskConfig {
    if let Some(task) = TaskConfig::shipped(stem) {
        return task;
    }
    let path = [stem, stem.trim_end_matches("_single")]
        .iter()
        .flat_map(|name| {
            ["scenarios/examples", "scenarios/swarm"]
                .map(|folder| repo_root().join(folder).join(format!("{name}.toml")))
        })
        .find(|path| path.exists())
        .unwrap_or_else(|| panic!("no task for controllers/{stem}.json"));
    let text = std::fs::read_to_string(&path).unwrap();
    let scenario = Scenario::parse(&text, &path.display().to_string()).unwrap();
    TaskConfig::from_scenario(Arc::new(scenario))
}

fn shipped_controllers() -> Vec<(String, ControllerFile)> {
    let mut found: Vec<(String, ControllerFile)> =
        std::fs::read_dir(repo_root().join("controllers"))
            .unwrap()
            .map(|entry| entry.unwrap().path())
            .filter(|path| path.extension().is_some_and(|e| e == "json"))
            .map(|path| {
                let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
                let text = std::fs::read_to_string(&path).unwrap();
                (stem, ControllerFile::from_json_str(&text).unwrap())
            })
            .collect();
    found.sort_by(|a, b| a.0.cmp(&b.0));
    assert!(found.len() >= 11, "the shipped controllers are there");
    found
}

/// Whether `node` or a node below it reads `group`.
fn reads(node: &NodeSpec, group: InputGroup) -> bool {
    node.inputs.contains(&group) || node.children.iter().any(|child| reads(child, group))
}

/// Exports into `dir` and runs `make -C dir TARGET`; returns its output.
fn export_and_make(
    file: &ControllerFile,
    task: &TaskConfig,
    target: Target,
    per_variant: u32,
    dir: &Path,
    make_target: &str,
) -> String {
    let options = ExportOptions {
        target,
        vector_samples: vectors::default_samples(task, per_variant),
        source_note: None,
    };
    let bundle = hevo_export::export(file, task, &options).unwrap();
    assert!(bundle.vectors.n_cycles > 0);
    bundle.write(dir).unwrap();
    let output = Command::new("make")
        .arg("-s")
        .arg("-C")
        .arg(dir)
        .arg(make_target)
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        output.status.success(),
        "make {make_target} failed:\n{text}"
    );
    text
}

#[test]
fn every_shipped_controller_exports_bit_identical_to_sim_core() {
    if !c_toolchain("every_shipped_controller_exports_bit_identical_to_sim_core") {
        return;
    }
    for (stem, file) in shipped_controllers() {
        let task = task_of(&stem);
        if let Some(group) = [InputGroup::RAB, InputGroup::ITEMS]
            .into_iter()
            .find(|&group| reads(&file.root, group))
        {
            // The range-and-bearing board and the item sensor have no C side yet
            // (docs/export.md): refused, by name.
            let options = ExportOptions {
                target: Target::Float,
                vector_samples: vectors::default_samples(&task, 1),
                source_note: None,
            };
            let error = hevo_export::export(&file, &task, &options)
                .err()
                .unwrap_or_else(|| panic!("{stem} reads {group} and was exported"));
            assert!(
                error.to_string().contains(&format!("'{group}'")),
                "{stem}: {error}"
            );
            continue;
        }
        let dir = tempfile::tempdir().unwrap();
        let output = export_and_make(&file, &task, Target::Float, 1, dir.path(), "check");
        assert!(
            output.contains("bit-identical to sim-core") && output.contains("check passed"),
            "{stem}: {output}"
        );
        eprintln!("{stem}: {}", output.lines().next().unwrap_or_default());
    }
}

#[test]
fn a_changed_weight_fails_the_check() {
    if !c_toolchain("a_changed_weight_fails_the_check") {
        return;
    }
    let task = task_of("follow_wall");
    let text = std::fs::read_to_string(repo_root().join("controllers/follow_wall.json")).unwrap();
    let file = ControllerFile::from_json_str(&text).unwrap();
    let dir = tempfile::tempdir().unwrap();
    export_and_make(&file, &task, Target::Float, 1, dir.path(), "check");
    // The root's first weight changed by a thousandth in the generated model: the check must
    // notice.
    let model_path = dir.path().join("hevo_model.c");
    let model = std::fs::read_to_string(&model_path).unwrap();
    let genome = file.root.genome.as_ref().unwrap();
    let array = "static const float node0_hidden_weights[] = {\n    ";
    let first = format!("{array}{:e}f,", genome[0]);
    let changed = format!("{array}{:e}f,", genome[0] * 1.001 + 0.001);
    assert!(model.contains(&first), "{model}");
    std::fs::write(&model_path, model.replacen(&first, &changed, 1)).unwrap();
    let output = Command::new("make")
        .arg("-s")
        .arg("-C")
        .arg(dir.path())
        .arg("check")
        .output()
        .unwrap();
    assert!(
        !output.status.success(),
        "a changed weight passed the check"
    );
    assert!(String::from_utf8_lossy(&output.stdout).contains("mismatches"));
}

#[test]
fn the_fixed_target_runs_the_rescue_close_to_sim_core() {
    if !c_toolchain("the_fixed_target_runs_the_rescue_close_to_sim_core") {
        return;
    }
    let text = std::fs::read_to_string(repo_root().join("controllers/rescue.json")).unwrap();
    let file = ControllerFile::from_json_str(&text).unwrap();
    let task = task_of("rescue");
    let dir = tempfile::tempdir().unwrap();
    let output = export_and_make(&file, &task, Target::Fixed, 1, dir.path(), "check");
    assert!(output.contains("check passed"), "{output}");
    // "active path as sim-core's in N (P %)": the fixed target mostly chooses alike.
    let percent: f64 = output
        .split("active path as sim-core's in ")
        .nth(1)
        .and_then(|rest| rest.split('(').nth(1))
        .and_then(|rest| rest.split(' ').next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no path agreement in {output}"));
    assert!(percent > 50.0, "{output}");
    eprintln!("{output}");
}

#[test]
fn the_float_export_in_the_loop_gives_sim_core_s_outcomes() {
    if !c_toolchain("the_float_export_in_the_loop_gives_sim_core_s_outcomes") {
        return;
    }
    let text = std::fs::read_to_string(repo_root().join("controllers/rescue.json")).unwrap();
    let file = ControllerFile::from_json_str(&text).unwrap();
    let task = task_of("rescue");
    let dir = tempfile::tempdir().unwrap();
    export_and_make(&file, &task, Target::Float, 1, dir.path(), "hevo_loop");
    let samples: Vec<Sample> = (0..8)
        .map(|k| Sample {
            seed: 100 + k,
            variant: Some((k % 4) as u32),
        })
        .collect();
    let report =
        closed_loop::run(&dir.path().join("hevo_loop"), &file, &task, &samples, 2).unwrap();
    assert_eq!(report.identical(), samples.len(), "{report:?}");
    assert!(
        report.simulated_solved() > 0,
        "the samples include solved ones"
    );
}

#[test]
fn an_activator_with_a_minimum_exports_bit_identical() {
    if !c_toolchain("an_activator_with_a_minimum_exports_bit_identical") {
        return;
    }
    // No shipped controller keeps a child on for a minimum: the rescue tree with minimums
    // long enough to hold children the plain activator would have left.
    let text = std::fs::read_to_string(repo_root().join("controllers/rescue.json")).unwrap();
    let plain = ControllerFile::from_json_str(&text).unwrap();
    let mut file = plain.clone();
    file.root.min_active_cycles = 300;
    file.root.children[1].min_active_cycles = 50;
    file.root.children[2].min_active_cycles = 50;
    let task = task_of("rescue");
    let samples = vectors::default_samples(&task, 1);
    let paths = |file: &ControllerFile| -> Vec<Vec<u16>> {
        let model = hevo_export::ExportModel::new(file, &task).unwrap();
        vectors::record(file, &task, &model, &samples)
            .unwrap()
            .into_iter()
            .flat_map(|sample| sample.cycles.into_iter().map(|cycle| cycle.path))
            .collect()
    };
    assert_ne!(paths(&plain), paths(&file), "the minimums change nothing");
    let dir = tempfile::tempdir().unwrap();
    let output = export_and_make(&file, &task, Target::Float, 1, dir.path(), "check");
    assert!(output.contains("bit-identical to sim-core"), "{output}");
}
