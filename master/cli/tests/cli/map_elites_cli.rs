//! A MAP-Elites run through the command line: its progress lines say what it optimises, every
//! elite of its archive is exported as a controller file that `hevo eval` takes, the node's
//! controller is the best elite, and `hevo plot` draws the archive and the QD-score curves.

use crate::support::{hevo, hevo_command, hevo_ok, succeeded, write_experiment};

const MAP_ELITES: &str = r#"
[experiment]
name = "archive"
seed = 5

[evolution]
algorithm = "map_elites"
population = 10
post_evaluation_samples = 2
map_elites_bins = [8, 8]
map_elites_ranges = [[-1.05, 1.05], [-1.65, 0.45]]
map_elites_variation = "iso_line"

[[node]]
name = "maze"
kind = "primitive"
inputs = ["ir", "light"]
hidden = 3
task = "maze_single"
samples = 4
cycles = 200
generations = 4
runs = 1
"#;

#[test]
fn a_map_elites_run_exports_every_elite_and_plots_its_archive() {
    let dir = tempfile::tempdir().unwrap();
    let experiment = write_experiment(dir.path(), MAP_ELITES);
    let out = dir.path().join("runs");
    let args = [
        "run",
        experiment.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--threads",
        "1",
    ];
    let run = hevo_command(&args)
        .env("RUST_LOG", "info")
        .output()
        .unwrap();
    let run = succeeded("hevo run", run);
    // Not a terminal: the log lines, which carry the archive's measures.
    let log = String::from_utf8_lossy(&run.stderr);
    let last = log
        .lines()
        .find(|line| line.contains("generation=3 "))
        .unwrap_or_else(|| panic!("{log}"));
    assert!(
        last.contains("coverage=\"")
            && last.contains("filled=\"")
            && last.contains("/64\"")
            && last.contains("qd_score=\"")
            && last.contains("best_elite=\""),
        "{last}"
    );
    let run_dir = out.join("maze/run-0");
    let qd = std::fs::read_to_string(run_dir.join("qd.csv")).unwrap();
    assert_eq!(qd.lines().count(), 5, "{qd}");

    let elites_dir = dir.path().join("elites");
    let export = hevo_ok(&[
        "archive",
        "export",
        out.join("maze").to_str().unwrap(),
        "--out",
        elites_dir.to_str().unwrap(),
    ]);
    let said = String::from_utf8_lossy(&export.stdout);
    assert!(said.contains("of 64 cells, generation 4)"), "{said}");
    let index = std::fs::read_to_string(elites_dir.join("elites.csv")).unwrap();
    let mut lines = index.lines();
    assert_eq!(
        lines.next(),
        Some("file,cell,bin_0,final.x,bin_1,final.y,fitness")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.len() >= 2, "{index}");
    // The node's controller is the fittest elite's.
    let best_row = rows
        .iter()
        .max_by(|a, b| {
            let fitness = |row: &Vec<&str>| row[6].parse::<f64>().unwrap();
            fitness(a).total_cmp(&fitness(b))
        })
        .unwrap();
    let best_elite: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(elites_dir.join(best_row[0])).unwrap())
            .unwrap();
    let node_best: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("maze/best.json")).unwrap())
            .unwrap();
    assert_eq!(best_elite, node_best);
    // Any elite is a controller `hevo eval` takes.
    let elite = elites_dir.join(rows[0][0]);
    let eval = hevo_ok(&[
        "eval",
        elite.to_str().unwrap(),
        "--task",
        "maze_single",
        "--samples",
        "1",
        "--threads",
        "1",
    ]);
    assert!(String::from_utf8_lossy(&eval.stdout).starts_with("solve_maze: solved"));

    let heatmap = dir.path().join("archive.svg");
    hevo_ok(&[
        "plot",
        out.to_str().unwrap(),
        "--node",
        "maze",
        "--archive",
        "--out",
        heatmap.to_str().unwrap(),
    ]);
    let svg = std::fs::read_to_string(&heatmap).unwrap();
    assert_eq!(svg.matches("class=\"elite\"").count(), rows.len());
    assert!(svg.contains(">final.x<") && svg.contains(">final.y<"));
    let curves = dir.path().join("qd.svg");
    hevo_ok(&[
        "plot",
        out.to_str().unwrap(),
        "--node",
        "maze",
        "--qd",
        "--out",
        curves.to_str().unwrap(),
    ]);
    assert!(
        std::fs::read_to_string(&curves)
            .unwrap()
            .contains("QD-score")
    );

    // A directory without an archive is named, with what to pass instead.
    let refused = hevo(&[
        "archive",
        "export",
        out.to_str().unwrap(),
        "--out",
        elites_dir.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && stderr.contains("no archive.json in"),
        "{stderr}"
    );
}
