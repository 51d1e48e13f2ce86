//! Renders the fitness plot of a node's runs, to look at: `cargo run -p hevo-viz --example
//! fitness_plot [NODE_DIR] [OUT.svg]`. By default the shipped runs of the maze arbitrator
//! (`experiments/runs/solve_maze`), written to `fitness_plot.svg` in the system's temporary
//! directory. The plot's structure is tested in `src/plot.rs`; this is for the eye.

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args_os().skip(1);
    let node_dir = args.next().map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../experiments/runs/solve_maze"),
        PathBuf::from,
    );
    let out = args.next().map_or_else(
        || std::env::temp_dir().join("fitness_plot.svg"),
        PathBuf::from,
    );
    let runs =
        hevo_viz::read_run_logs(&node_dir).map_err(|e| format!("{}: {e}", node_dir.display()))?;
    let title = format!(
        "{}: fitness by generation",
        node_dir
            .file_name()
            .map_or_else(|| "runs".into(), |n| n.to_string_lossy())
    );
    std::fs::write(&out, hevo_viz::fitness_plot_svg(&title, &runs, None))
        .map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    println!("{} runs -> {}", runs.len(), out.display());
    Ok(())
}
