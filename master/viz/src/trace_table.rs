//! A traced sample as a table, one row per control cycle, for readers outside hevo
//! (`hevo replay --trace-out FILE.csv` or `FILE.json`): the robot's pose (and the teammate's),
//! the sensor inputs the controller read, its wheel outputs, the node that drove and what
//! happened, then a team's other robots' poses (`[[robots]]`), the movers' and boxes' centres
//! and the items' places (`[[movers]]`, `[[boxes]]`, `[[objects]]`). The Python module's
//! `hevo.trace` gives the robots' values as numpy arrays.

use hevo_sim_core::Trace;
use hevo_sim_core::TraceCycle;
use hevo_sim_core::{N_FLAT, SensorFrame};
use std::fmt::Write as _;

/// The columns before the sensor inputs.
const POSE_COLUMNS: [&str; 7] = [
    "cycle",
    "robot_x",
    "robot_y",
    "robot_heading",
    "teammate_x",
    "teammate_y",
    "teammate_heading",
];

/// The columns after them.
const OUTCOME_COLUMNS: [&str; 7] = [
    "wheel_left",
    "wheel_right",
    "active_node",
    "active_depth",
    "collided",
    "lit_lights",
    "sub_task",
];

/// The columns every row has, in order: the poses, every sensor input under its name
/// ([`SensorFrame::INPUT_NAMES`]: `ir_front_left`, ..., `near_robot`), then the wheels and
/// what happened. The teammate's pose columns are empty where the task has no teammate. A
/// trace with a team has more ([`trace_columns`]).
pub const TRACE_COLUMNS: [&str; POSE_COLUMNS.len() + N_FLAT + OUTCOME_COLUMNS.len()] = {
    let mut columns = [""; POSE_COLUMNS.len() + N_FLAT + OUTCOME_COLUMNS.len()];
    let mut idx = 0;
    while idx < columns.len() {
        columns[idx] = if idx < POSE_COLUMNS.len() {
            POSE_COLUMNS[idx]
        } else if idx < POSE_COLUMNS.len() + N_FLAT {
            SensorFrame::INPUT_NAMES[idx - POSE_COLUMNS.len()]
        } else {
            OUTCOME_COLUMNS[idx - POSE_COLUMNS.len() - N_FLAT]
        };
        idx += 1;
    }
    columns
};

/// The columns of `trace`'s rows: [`TRACE_COLUMNS`], then, for each of a team's other robots
/// ([`Trace::team_member_names`]: `swarm_0`, ...), its `_x`, `_y` and `_heading` at the start of
/// the cycle; then each mover's and box's centre (`mover[0]_x`, `mover[0]_y`, ...,
/// `box[0]_x`, ...) and each item's place and state (`item[0]_x`, `item[0]_y`,
/// `item[0]_state`: `floor`, `carried` or `delivered`), by index in the trace's `movers`,
/// `boxes` and `items`. Brackets cannot be in a group's name, so no team column takes these
/// names.
pub fn trace_columns(trace: &Trace) -> Vec<String> {
    let team = trace
        .team_member_names()
        .into_iter()
        .flat_map(|member| TEAM_POSE_SUFFIXES.map(|suffix| format!("{member}{suffix}")));
    let indexed = |kind: &'static str, count: usize, suffixes: &'static [&'static str]| {
        (0..count).flat_map(move |idx| {
            suffixes
                .iter()
                .map(move |suffix| format!("{kind}[{idx}]{suffix}"))
        })
    };
    TRACE_COLUMNS
        .iter()
        .map(|column| column.to_string())
        .chain(team)
        .chain(indexed("mover", trace.movers.len(), &CENTRE_SUFFIXES))
        .chain(indexed("box", trace.boxes.len(), &CENTRE_SUFFIXES))
        .chain(indexed("item", trace.items.len(), &ITEM_SUFFIXES))
        .collect()
}

/// The suffixes of a team robot's pose columns.
const TEAM_POSE_SUFFIXES: [&str; 3] = ["_x", "_y", "_heading"];
/// The suffixes of a mover's or a box's columns.
const CENTRE_SUFFIXES: [&str; 2] = ["_x", "_y"];
/// The suffixes of an item's columns.
const ITEM_SUFFIXES: [&str; 3] = ["_x", "_y", "_state"];

/// One cell.
enum Cell {
    Number(f32),
    Integer(u64),
    Text(String),
    Empty,
}

/// The cells of one cycle, in [`trace_columns`] order; `node_paths` names the controller's
/// nodes by index (the active node is the last of the cycle's active path).
fn cells(index: usize, cycle: &TraceCycle, node_paths: &[String]) -> Vec<Cell> {
    let number = Cell::Number;
    let teammate = |pick: fn(&hevo_sim_core::Pose) -> f32| {
        cycle
            .teammate
            .as_ref()
            .map_or(Cell::Empty, |pose| number(pick(pose)))
    };
    let active = cycle
        .active_path
        .last()
        .map(|&node| {
            node_paths
                .get(usize::from(node))
                .cloned()
                .unwrap_or_else(|| format!("node {node}"))
        })
        .unwrap_or_default();
    let poses = [
        Cell::Integer(index as u64),
        number(cycle.robot.x),
        number(cycle.robot.y),
        number(cycle.robot.heading),
        teammate(|pose| pose.x),
        teammate(|pose| pose.y),
        teammate(|pose| pose.heading),
    ];
    let inputs = cycle.frame.inputs.map(number);
    let outcomes = [
        number(cycle.wheels[0]),
        number(cycle.wheels[1]),
        Cell::Text(active),
        Cell::Integer(cycle.active_path.len() as u64),
        Cell::Integer(u64::from(cycle.collided)),
        Cell::Integer(u64::from(cycle.lit_lights)),
        Cell::Integer(u64::from(cycle.sub_task)),
    ];
    let team = cycle
        .team
        .iter()
        .flat_map(|pose| [pose.x, pose.y, pose.heading].map(number));
    // The movers' then the boxes' centres, as the columns list them.
    let bodies = cycle.bodies.iter().flat_map(|centre| centre.map(number));
    let items = cycle.items.iter().flat_map(|item| {
        let state = match (item.carried, item.delivered) {
            (_, true) => "delivered",
            (true, false) => "carried",
            (false, false) => "floor",
        };
        [
            number(item.at[0]),
            number(item.at[1]),
            Cell::Text(state.to_string()),
        ]
    });
    poses
        .into_iter()
        .chain(inputs)
        .chain(outcomes)
        .chain(team)
        .chain(bodies)
        .chain(items)
        .collect()
}

/// CSV text: a header line, then one line per cycle. Numbers are the shortest decimals that
/// read back to the same `f32`.
pub fn trace_csv(trace: &Trace, node_paths: &[String]) -> String {
    let mut text = trace_columns(trace).join(",");
    text.push('\n');
    for (index, cycle) in trace.cycles.iter().enumerate() {
        let row: Vec<String> = cells(index, cycle, node_paths)
            .into_iter()
            .map(|cell| match cell {
                Cell::Number(value) => format!("{value}"),
                Cell::Integer(value) => value.to_string(),
                // Node paths are names checked to be plain identifiers and slashes, so they
                // need no quoting; quote anyway should a comma or quote ever appear.
                Cell::Text(text) if text.contains([',', '"', '\n']) => {
                    format!("\"{}\"", text.replace('"', "\"\""))
                }
                Cell::Text(text) => text,
                Cell::Empty => String::new(),
            })
            .collect();
        let _ = writeln!(text, "{}", row.join(","));
    }
    text
}

/// JSON text: the sample and its outcome, the node paths, and `cycles`, one object per cycle
/// with the [`trace_columns`] as keys (the teammate's keys only where there is one).
pub fn trace_json(trace: &Trace, node_paths: &[String]) -> Result<String, serde_json::Error> {
    let columns = trace_columns(trace);
    let cycles: Vec<serde_json::Value> = trace
        .cycles
        .iter()
        .enumerate()
        .map(|(index, cycle)| {
            let mut object = serde_json::Map::new();
            for (column, cell) in columns.iter().zip(cells(index, cycle, node_paths)) {
                let value = match cell {
                    Cell::Number(value) => serde_json::json!(value),
                    Cell::Integer(value) => serde_json::json!(value),
                    Cell::Text(text) => serde_json::json!(text),
                    Cell::Empty => continue,
                };
                object.insert(column.clone(), value);
            }
            serde_json::Value::Object(object)
        })
        .collect();
    let document = serde_json::json!({
        "scenario": trace.scenario,
        "seed": trace.sample.seed,
        "variant": trace.outcome.variant,
        "outcome": trace.outcome,
        "node_paths": node_paths,
        "cycles": cycles,
    });
    serde_json::to_string(&document)
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::{Controller, ControllerFile};
    use hevo_sim_core::{Evaluator, Sample, TaskConfig};

    #[test]
    fn one_row_per_cycle_in_both_forms() {
        let mut task = TaskConfig::shipped("rescue").unwrap();
        task.max_cycles = Some(40);
        let file = ControllerFile::from_json_str(include_str!("../../../controllers/rescue.json"))
            .unwrap();
        let node_paths = file.node_paths();
        let mut controller = Controller::new(&file, None).unwrap();
        let evaluator = Evaluator::new(task).unwrap();
        let trace = evaluator.evaluate_traced(&mut controller, Sample::seeded(5));
        let n = trace.cycles.len();
        assert!(n > 0);

        let csv = trace_csv(&trace, &node_paths);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), n + 1);
        assert_eq!(lines[0], TRACE_COLUMNS.join(","));
        let first: Vec<&str> = lines[1].split(',').collect();
        assert_eq!(first.len(), TRACE_COLUMNS.len());
        assert_eq!(first[0], "0");
        // The values read back to the trace's own f32s.
        assert_eq!(first[1].parse::<f32>().unwrap(), trace.cycles[0].robot.x);
        // By name: the inputs' columns grow with the registered sensors.
        let column = |name: &str| TRACE_COLUMNS.iter().position(|c| *c == name).unwrap();
        assert_eq!(
            first[column("wheel_left")].parse::<f32>().unwrap(),
            trace.cycles[0].wheels[0]
        );
        let leaf = *trace.cycles[0].active_path.last().unwrap();
        assert_eq!(first[column("active_node")], node_paths[usize::from(leaf)]);
        // The rescue has a teammate.
        assert!(!first[4].is_empty());

        let json: serde_json::Value =
            serde_json::from_str(&trace_json(&trace, &node_paths).unwrap()).unwrap();
        let cycles = json["cycles"].as_array().unwrap();
        assert_eq!(cycles.len(), n);
        assert_eq!(cycles[n - 1]["cycle"], serde_json::json!(n - 1));
        assert_eq!(json["seed"], serde_json::json!(5));
        assert_eq!(
            cycles[0]["robot_y"].as_f64().unwrap() as f32,
            trace.cycles[0].robot.y
        );
        // Shortest round-trip decimals, not an f32 widened to f64's digits.
        assert_eq!(first[1], trace.cycles[0].robot.x.to_string());
    }

    /// The wheels of one side a little faster: the focal robot drives in circles.
    struct Circler;

    impl hevo_sim_core::Policy for Circler {
        fn reset(&mut self) {}
        fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
            [1.0, 0.8]
        }
    }

    #[test]
    fn a_team_adds_each_other_robots_pose_columns() {
        let text = include_str!("../fixtures/team_arena.toml");
        let scenario = hevo_sim_core::Scenario::parse(text, "team_arena.toml").unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        let trace = Evaluator::new(task)
            .unwrap()
            .evaluate_traced(&mut Circler, Sample::seeded(2));
        let columns = trace_columns(&trace);
        assert_eq!(columns.len(), TRACE_COLUMNS.len() + 3 * 3);
        assert_eq!(
            columns[TRACE_COLUMNS.len()..],
            [
                "swarm_0_x",
                "swarm_0_y",
                "swarm_0_heading",
                "swarm_1_x",
                "swarm_1_y",
                "swarm_1_heading",
                "swarm_2_x",
                "swarm_2_y",
                "swarm_2_heading",
            ]
        );
        let csv = trace_csv(&trace, &[]);
        let last = trace.cycles.len() - 1;
        let row: Vec<&str> = csv.lines().nth(last + 1).unwrap().split(',').collect();
        assert_eq!(row.len(), columns.len());
        let column = |name: &str| columns.iter().position(|c| c == name).unwrap();
        assert_eq!(
            row[column("swarm_2_y")].parse::<f32>().unwrap(),
            trace.cycles[last].team[2].y
        );
        let json: serde_json::Value =
            serde_json::from_str(&trace_json(&trace, &[]).unwrap()).unwrap();
        assert_eq!(
            json["cycles"][0]["swarm_1_heading"].as_f64().unwrap() as f32,
            trace.cycles[0].team[1].heading
        );
        // A trace without a team has exactly the fixed columns.
        let alone = Evaluator::new(TaskConfig::shipped("exit_room").unwrap())
            .unwrap()
            .evaluate_traced(&mut Circler, Sample::seeded(2));
        assert_eq!(trace_columns(&alone), TRACE_COLUMNS);
    }

    /// The shipped swarm scenario `name` traced with the robots circling.
    fn swarm_trace(name: &str, text: &str) -> Trace {
        let scenario = hevo_sim_core::Scenario::parse(text, name).unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        Evaluator::new(task)
            .unwrap()
            .evaluate_traced(&mut Circler, Sample::seeded(2))
    }

    #[test]
    fn movers_boxes_and_items_add_their_columns() {
        let crossing = swarm_trace(
            "crossing.toml",
            include_str!("../../../scenarios/swarm/crossing.toml"),
        );
        let columns = trace_columns(&crossing);
        let n_team = 2 * 3;
        assert_eq!(
            columns[TRACE_COLUMNS.len() + n_team..],
            [
                "mover[0]_x",
                "mover[0]_y",
                "mover[1]_x",
                "mover[1]_y",
                "mover[2]_x",
                "mover[2]_y"
            ]
        );
        let csv = trace_csv(&crossing, &[]);
        let last = crossing.cycles.len() - 1;
        let row: Vec<&str> = csv.lines().nth(last + 1).unwrap().split(',').collect();
        assert_eq!(row.len(), columns.len());
        let column =
            |columns: &[String], name: &str| columns.iter().position(|c| c == name).unwrap();
        assert_eq!(
            row[column(&columns, "mover[2]_y")].parse::<f32>().unwrap(),
            crossing.cycles[last].bodies[2][1]
        );

        let boxes = swarm_trace(
            "box_pushing.toml",
            include_str!("../../../scenarios/swarm/box_pushing.toml"),
        );
        let columns = trace_columns(&boxes);
        assert_eq!(columns[columns.len() - 2..], ["box[3]_x", "box[3]_y"]);

        let foraging = swarm_trace(
            "foraging.toml",
            include_str!("../../../scenarios/swarm/foraging.toml"),
        );
        let columns = trace_columns(&foraging);
        assert_eq!(
            columns[columns.len() - 3..],
            ["item[9]_x", "item[9]_y", "item[9]_state"]
        );
        let json: serde_json::Value =
            serde_json::from_str(&trace_json(&foraging, &[]).unwrap()).unwrap();
        assert_eq!(json["cycles"][0]["item[0]_state"], "floor");
        assert_eq!(
            json["cycles"][0]["item[4]_x"].as_f64().unwrap() as f32,
            foraging.items[4].start[0]
        );
    }
}
