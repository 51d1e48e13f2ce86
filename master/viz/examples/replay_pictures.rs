//! Renders replays of the shipped controllers, to look at: `cargo run -p hevo-viz --example
//! replay_pictures [OUT_DIR]` (the system's temporary directory by default) writes the maze
//! arbitrator's longest solved sample of 40 with the IR cones drawn at one cycle, the same
//! sample animated, the room exit, the rescue, and a team: a robot that steers clear of
//! obstacles among three wanderers (`fixtures/team_arena.toml`). The pictures' structure is
//! tested in `src/replay.rs`; this is for the eye.

use hevo_sim_core::{
    Controller, ControllerFile, Evaluator, InputGroup, Policy, Pose, Sample, Scenario, SensorFrame,
    TaskConfig, Trace,
};
use hevo_viz::{ReplayOptions, replay_svg};
use std::path::{Path, PathBuf};

/// The shipped controller `controllers/TASK.json` and the task it was evolved for.
fn shipped(task: &str) -> Result<(Controller, Evaluator), Box<dyn std::error::Error>> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../controllers")
        .join(format!("{task}.json"));
    let text = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let file = ControllerFile::from_json_str(&text)?;
    let controller = Controller::new(&file, None)?;
    let task_config = TaskConfig::shipped(task).ok_or_else(|| format!("no shipped task {task}"))?;
    let evaluator = Evaluator::new(task_config)?;
    Ok((controller, evaluator))
}

/// The replay's options for a controller: its nodes named by path, as `hevo replay` names them.
fn options(controller: &Controller, evaluator: &Evaluator) -> ReplayOptions {
    ReplayOptions {
        node_names: (0..controller.n_nodes())
            .map(|i| controller.node_path(i).unwrap_or("?").to_string())
            .collect(),
        robot_radius: evaluator.task().params.robot.radius,
        ..ReplayOptions::default()
    }
}

/// Drives ahead and turns away from whatever its IR sensors see: enough to cross the team's
/// arena for a while, with no controller file for that scenario.
#[derive(Debug)]
struct SteerClear;

impl Policy for SteerClear {
    fn reset(&mut self) {}

    fn step(&mut self, frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        let ir = frame.values(InputGroup::IR);
        // Sensors 0 and 1 look left of ahead, 2 and 3 right; a wheel output of 0.5 stands.
        let (left, right) = (ir[0].max(ir[1]), ir[2].max(ir[3]));
        let blocked = ir[0].max(ir[3]);
        let steer = 0.6 * (left - right) + 0.5 * blocked;
        [
            (0.85 + steer).clamp(0.0, 1.0),
            (0.85 - steer).clamp(0.0, 1.0),
        ]
    }

    fn active_path(&self) -> &[usize] {
        &[0]
    }

    fn n_nodes(&self) -> usize {
        1
    }
}

fn write(dir: &Path, name: &str, svg: String) -> Result<(), Box<dyn std::error::Error>> {
    let path = dir.join(name);
    std::fs::write(&path, svg).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    println!("{}", path.display());
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args_os()
        .nth(1)
        .map_or_else(std::env::temp_dir, PathBuf::from);

    let (mut controller, evaluator) = shipped("solve_maze")?;
    let trace: Trace = (0..40)
        .map(|seed| evaluator.evaluate_traced(&mut controller, Sample::seeded(seed)))
        .max_by_key(|t| (t.outcome.solved, t.cycles.len()))
        .ok_or("no samples")?;
    let maze = options(&controller, &evaluator);
    let cones = |pose: &Pose| evaluator.ir_cones(pose);
    let still = ReplayOptions {
        rays_at_cycles: vec![30],
        ..maze.clone()
    };
    write(&dir, "replay_maze.svg", replay_svg(&trace, &still, &cones))?;
    let animated = ReplayOptions {
        animate: true,
        ..maze
    };
    write(
        &dir,
        "replay_maze_animated.svg",
        replay_svg(&trace, &animated, &cones),
    )?;

    let (mut controller, room) = shipped("exit_room")?;
    let trace = room.evaluate_traced(&mut controller, Sample::seeded(2));
    let options_room = ReplayOptions {
        rays_at_cycles: vec![0, 120],
        ..options(&controller, &room)
    };
    let svg = replay_svg(&trace, &options_room, &|pose| room.ir_cones(pose));
    write(&dir, "replay_room.svg", svg)?;

    let (mut controller, rescue) = shipped("rescue")?;
    let trace = rescue.evaluate_traced(&mut controller, Sample::seeded(4));
    let svg = replay_svg(&trace, &options(&controller, &rescue), &|pose| {
        rescue.ir_cones(pose)
    });
    write(&dir, "replay_rescue.svg", svg)?;

    let text = include_str!("../fixtures/team_arena.toml");
    let scenario = Scenario::parse(text, "fixtures/team_arena.toml")?;
    let arena = Evaluator::new(TaskConfig::from_scenario(std::sync::Arc::new(scenario)))?;
    let trace = arena.evaluate_traced(&mut SteerClear, Sample::seeded(3));
    let options_arena = ReplayOptions {
        node_names: vec!["steer_clear".to_string()],
        robot_radius: arena.task().params.robot.radius,
        ..ReplayOptions::default()
    };
    let svg = replay_svg(&trace, &options_arena, &|pose| arena.ir_cones(pose));
    write(&dir, "replay_team.svg", svg)?;
    Ok(())
}
