//! What the simulator's tests share: the example scenario files (embedded, so a test never
//! depends on the working directory) and the tasks they compile to, a driver with fixed wheel
//! outputs, and each paper task's scripted reference policy chosen by the task's name.

use hevo_scripted::{
    CorridorFollower, MazeSolver, Rescuer, Returner, RoomExiter, TurnSide, Turner,
};
use hevo_sim_core::{Evaluator, Policy, Rect, Scenario, SensorFrame, TaskConfig};
use std::sync::Arc;

/// `scenarios/examples/t_maze.toml`.
pub const T_MAZE: &str = include_str!("../../../scenarios/examples/t_maze.toml");
/// `scenarios/examples/find_wanderer.toml`.
pub const FIND_WANDERER: &str = include_str!("../../../scenarios/examples/find_wanderer.toml");
/// `scenarios/examples/room_to_corridor.toml`.
pub const ROOM_TO_CORRIDOR: &str =
    include_str!("../../../scenarios/examples/room_to_corridor.toml");

/// The example scenarios of `scenarios/examples/`, by name.
pub const EXAMPLES: [(&str, &str); 10] = [
    ("t_maze", T_MAZE),
    (
        "triple_t_maze",
        include_str!("../../../scenarios/examples/triple_t_maze.toml"),
    ),
    (
        "cross_yard",
        include_str!("../../../scenarios/examples/cross_yard.toml"),
    ),
    (
        "room_to_yard",
        include_str!("../../../scenarios/examples/room_to_yard.toml"),
    ),
    ("find_wanderer", FIND_WANDERER),
    ("room_to_corridor", ROOM_TO_CORRIDOR),
    (
        "phototaxis",
        include_str!("../../../scenarios/examples/phototaxis.toml"),
    ),
    (
        "exit_room_authors",
        include_str!("../../../scenarios/examples/exit_room_authors.toml"),
    ),
    (
        "random_maze",
        include_str!("../../../scenarios/examples/random_maze.toml"),
    ),
    (
        "map_to_corridor",
        include_str!("../../../scenarios/examples/map_to_corridor.toml"),
    ),
];

/// The text of the example scenario `name` (a name of [`EXAMPLES`]).
pub fn example(name: &str) -> &'static str {
    EXAMPLES
        .iter()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("no example scenario named {name}"))
        .1
}

/// The example scenario `name` compiled into a task, as `hevo` reads it from `NAME.toml`.
pub fn example_task(name: &str) -> TaskConfig {
    TaskConfig::from_scenario(Arc::new(
        Scenario::parse(example(name), &format!("{name}.toml")).expect("the example compiles"),
    ))
}

/// Drives with fixed wheel outputs for `drive` cycles, then stands still: outputs 0.5 command
/// speed 0, which the multiplicative wheel noise leaves at 0.
#[derive(Debug, Clone)]
pub struct Fixed {
    wheels: [f32; 2],
    drive: u32,
    cycle: u32,
}

impl Fixed {
    /// `wheels` for the first `drive` cycles of a sample.
    pub fn new(wheels: [f32; 2], drive: u32) -> Fixed {
        Fixed {
            wheels,
            drive,
            cycle: 0,
        }
    }

    /// Full speed ahead, for ever.
    pub fn straight() -> Fixed {
        Fixed::new([1.0, 1.0], u32::MAX)
    }

    /// Spinning on the spot, left wheel back and right forward: the wheels at equal and
    /// opposite speeds move the robot nowhere.
    pub fn spin() -> Fixed {
        Fixed::new([0.0, 1.0], u32::MAX)
    }

    /// Standing still from the first cycle.
    pub fn still() -> Fixed {
        Fixed::new([0.5, 0.5], 0)
    }
}

impl Policy for Fixed {
    fn reset(&mut self) {
        self.cycle = 0;
    }

    fn step(&mut self, _frame: &SensorFrame, _dt: f32) -> [f32; 2] {
        let wheels = if self.cycle < self.drive {
            self.wheels
        } else {
            [0.5, 0.5]
        };
        self.cycle = self.cycle.saturating_add(1);
        wheels
    }
}

/// The scripted reference policy of a paper task, chosen by the task's name.
#[derive(Debug)]
pub enum Scripted {
    /// `follow_wall`.
    Follower(CorridorFollower),
    /// `turn_left` and `turn_right`.
    Turner(Turner),
    /// `solve_maze`.
    Solver(MazeSolver),
    /// `return_room`.
    Returner(Returner),
    /// `exit_room`.
    Exiter(RoomExiter),
    /// `rescue`.
    Rescuer(Rescuer),
}

impl Scripted {
    /// The policy of task `kind` for the paper's robot and the default IR mapping.
    pub fn standard(kind: &str) -> Scripted {
        match kind {
            "follow_wall" => Scripted::Follower(CorridorFollower::new()),
            "turn_left" => Scripted::Turner(Turner::new(TurnSide::Left)),
            "turn_right" => Scripted::Turner(Turner::new(TurnSide::Right)),
            "solve_maze" => Scripted::Solver(MazeSolver::new()),
            "return_room" => Scripted::Returner(Returner::new()),
            "exit_room" => Scripted::Exiter(RoomExiter::new()),
            "rescue" => Scripted::Rescuer(Rescuer::new()),
            other => panic!("no scripted policy for {other}"),
        }
    }

    /// The policy of task `kind`, told the robot and IR mapping of `task`.
    pub fn for_task(kind: &str, task: &TaskConfig) -> Scripted {
        match kind {
            "follow_wall" => Scripted::Follower(CorridorFollower::for_task(task)),
            "turn_left" => Scripted::Turner(Turner::for_task(TurnSide::Left, task)),
            "turn_right" => Scripted::Turner(Turner::for_task(TurnSide::Right, task)),
            "solve_maze" => Scripted::Solver(MazeSolver::for_task(task)),
            "return_room" => Scripted::Returner(Returner::for_task(task)),
            "exit_room" => Scripted::Exiter(RoomExiter::for_task(task)),
            "rescue" => Scripted::Rescuer(Rescuer::for_task(task)),
            other => panic!("no scripted policy for {other}"),
        }
    }

    fn policy(&self) -> &dyn Policy {
        match self {
            Scripted::Follower(p) => p,
            Scripted::Turner(p) => p,
            Scripted::Solver(p) => p,
            Scripted::Returner(p) => p,
            Scripted::Exiter(p) => p,
            Scripted::Rescuer(p) => p,
        }
    }

    fn policy_mut(&mut self) -> &mut dyn Policy {
        match self {
            Scripted::Follower(p) => p,
            Scripted::Turner(p) => p,
            Scripted::Solver(p) => p,
            Scripted::Returner(p) => p,
            Scripted::Exiter(p) => p,
            Scripted::Rescuer(p) => p,
        }
    }
}

/// Every method forwarded, so the policy reports what the wrapped one does (its tree, its
/// root's choices), not the trait's defaults.
impl Policy for Scripted {
    fn reset(&mut self) {
        self.policy_mut().reset();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        self.policy_mut().step(frame, dt)
    }

    fn root_choice(&self) -> Option<usize> {
        self.policy().root_choice()
    }

    fn active_path(&self) -> &[usize] {
        self.policy().active_path()
    }

    fn n_nodes(&self) -> usize {
        self.policy().n_nodes()
    }

    fn root_child_index(&self, name: &str) -> Option<usize> {
        self.policy().root_child_index(name)
    }
}

/// Why the scenario `text`, with its first `from` replaced by `to`, is refused: by its
/// compiler, or else by the evaluator that builds its worlds (a region with no room, say).
/// Panics when it is accepted.
pub fn refusal_of(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from}");
    let text = text.replacen(from, to, 1);
    match Scenario::parse(&text, "mine.toml") {
        Err(error) => error.to_string(),
        Ok(scenario) => match Evaluator::new(TaskConfig::from_scenario(Arc::new(scenario))) {
            Err(error) => error.to_string(),
            Ok(_) => panic!("accepted with {to}"),
        },
    }
}

/// A primitive reading `inputs`, with random genes in [-10, 10): it drives anywhere, into
/// walls and robots.
pub fn random_primitive(
    rng: &mut hevo_sim_core::SimRng,
    inputs: Vec<hevo_sim_core::InputGroup>,
) -> (hevo_sim_core::ControllerFile, Vec<f32>) {
    use rand::RngExt;
    let spec = hevo_sim_core::NodeSpec::primitive("root", inputs, 3);
    let n_genes = spec.topology().n_genes();
    let genes: Vec<f32> = (0..n_genes)
        .map(|_| rng.random_range(-10.0f32..10.0))
        .collect();
    (hevo_sim_core::ControllerFile::new(spec), genes)
}

/// The outcomes of `genes` in `template` on samples 0 to 10 of `task`, after asserting that
/// the scalar evaluator gives the same twice and the lockstep one the same again.
pub fn outcomes_on_every_evaluator(
    template: &hevo_sim_core::ControllerFile,
    genes: &[f32],
    task: &TaskConfig,
) -> Vec<hevo_sim_core::Outcome> {
    use hevo_sim_core::{BatchEvaluator, EvaluatorKind, Sample};
    let samples: Vec<Sample> = (0..11).map(Sample::seeded).collect();
    let outcomes = |kind| {
        BatchEvaluator::new(template.clone(), task.clone())
            .expect("valid")
            .with_kind(kind)
            .evaluate_genome(Some(genes), &samples)
            .expect("genes fit")
    };
    let scalar = outcomes(EvaluatorKind::Scalar);
    assert_eq!(scalar, outcomes(EvaluatorKind::Scalar), "run twice");
    assert_eq!(scalar, outcomes(EvaluatorKind::Lockstep), "lockstep");
    scalar
}

/// Signed distance from a point to a possibly rotated rectangle: negative inside.
pub fn signed_distance(point: [f32; 2], rect: &Rect) -> f32 {
    let (sin, cos) = rect.angle.sin_cos();
    let (dx, dy) = (point[0] - rect.center[0], point[1] - rect.center[1]);
    // Into the rectangle's own frame (rotation by -angle).
    let local = [cos * dx + sin * dy, -sin * dx + cos * dy];
    let q = [
        local[0].abs() - rect.half_extents[0],
        local[1].abs() - rect.half_extents[1],
    ];
    let outside = q[0].max(0.0).hypot(q[1].max(0.0));
    let inside = q[0].max(q[1]).min(0.0);
    outside + inside
}
