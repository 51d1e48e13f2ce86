//! The controllers shipped in `controllers/` still do what REPRODUCTION.md says they do under
//! the current simulator. A change to physics, sensors or tasks that silently breaks the
//! evolved hierarchy fails here, instead of surprising the first user who runs
//! `hevo eval controllers/rescue.json`. The post-evaluation in REPRODUCTION.md uses 100
//! samples per light configuration; this test uses fewer, so the floors sit a little below
//! the measured rates.

use hevo_engine::post_evaluation::{post_evaluation_samples, report};
use hevo_sim_core::batch::SampleSummary;
use hevo_sim_core::controller::{Controller, ControllerFile};
use hevo_sim_core::{Evaluator, TaskConfig};
use std::path::PathBuf;

/// Samples per light configuration (or start branch).
const N_SAMPLES: u32 = 25;

/// Every shipped controller: file name, task, and the solve rate it must reach here.
const SHIPPED: &[(&str, &str, f64)] = &[
    ("exit_room.json", "exit_room", 0.92),
    ("follow_wall.json", "follow_wall", 0.95),
    ("turn_left.json", "turn_left", 0.9),
    ("turn_right.json", "turn_right", 0.9),
    ("solve_maze.json", "solve_maze", 0.95),
    ("return_room.json", "return_room", 0.85),
    ("rescue.json", "rescue", 0.75),
];

fn controllers_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../controllers")
}

#[test]
fn every_shipped_controller_is_listed_here() {
    let mut found: Vec<String> = std::fs::read_dir(controllers_dir())
        .expect("controllers/ exists")
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".json"))
        .collect();
    found.sort();
    let mut listed: Vec<String> = SHIPPED
        .iter()
        .map(|(file, _, _)| file.to_string())
        .collect();
    listed.sort();
    assert_eq!(
        found, listed,
        "add new controllers to SHIPPED with their floor"
    );
}

#[test]
fn shipped_controllers_solve_their_tasks() {
    let mut failures = Vec::new();
    for &(file, task, floor) in SHIPPED {
        let path = controllers_dir().join(file);
        let text = std::fs::read_to_string(&path).expect("shipped controller is readable");
        let controller_file = ControllerFile::from_json_str(&text)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let kind = &'static str::from_name(task).expect("known task");
        let evaluator = Evaluator::new(TaskConfig::shipped(kind).unwrap()).expect("valid task");
        let summaries: Vec<SampleSummary> = post_evaluation_samples(kind, N_SAMPLES, 1)
            .into_iter()
            .map(|sample| {
                let mut controller = Controller::new(&controller_file, None)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                SampleSummary::from(&evaluator.evaluate(&mut controller, sample))
            })
            .collect();
        let solve_rate = report(kind, &summaries, &controller_file.node_paths()).solve_rate;
        eprintln!("{file}: {:.1}% on {task}", 100.0 * solve_rate);
        if solve_rate < floor {
            failures.push(format!(
                "{file} solves {:.1}% of {} {task} samples, below its floor {:.1}%",
                100.0 * solve_rate,
                summaries.len(),
                100.0 * floor
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
