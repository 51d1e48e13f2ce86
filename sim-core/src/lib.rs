//! hevo's simulation core: a pure, deterministic e-puck world (rapier2d scene, measured IR and
//! light sensor models), CTRNN behaviour primitives and arbitrators composed into trees of any
//! depth, the paper's tasks with their fitness functions, and the evaluation of one genome on
//! one seeded sample. It does no IO: no threads, no clock, no files, no global random state.

// The floors, lowest first: each imports only its own floor and those below
// (`tests/floors.rs` holds the order).
mod body;
mod config;
mod episode;
mod geometry;
mod math;
mod network;
mod outcome;
mod scenario;
mod sensors;
mod task;
mod world;

/// Version of the simulation model. Bump it whenever a change alters any trajectory or fitness
/// (the golden tests catch such changes): run fingerprints include it, so checkpoints written by
/// an older model are refused instead of being silently continued with a different one.
pub const MODEL_VERSION: u32 = 4;

// The surface other crates use.
pub use body::Pose;
pub use config::{
    ConfigError, CorridorConfig, CurveChoice, IrConfig, IrMapping, LightConfig, N_LIGHT, Params,
    RobotConfig, RoomConfig, StartConfig,
};
pub use episode::batch::{
    BatchError, BatchEvaluator, EvaluatorKind, SampleSummary, controller_fits,
};
pub use episode::evaluator::{Evaluator, TaskError};
pub use episode::regions::{NamedRegion, named_regions};
pub use geometry::scene::{Rect, RectKind, Scene};
pub use math::hash::{Fnv1a, fnv1a, fnv1a_hex};
pub use math::rng::{SimRng, Stream, derive_seed, mix64, stream_rng};
pub use network::Policy;
pub use network::controller::{Controller, ControllerError, ControllerFile, NodeKind, NodeSpec};
pub use network::ctrnn::CtrnnTopology;
pub use outcome::{
    Ending, N_SUB_TASKS, NodeUse, Outcome, Sample, SubTaskChoices, Trace, TraceCycle,
};
pub use scenario::file::ChildRef;
pub use scenario::{MAX_LIGHTS, SHIPPED, SHIPPED_NAMES, Scenario, ScenarioError};
pub use sensors::IrCone;
pub use sensors::frame::{InputGroup, N_FLAT, SensorFrame, SensorSet};
pub use sensors::ir::{
    IR_CURVE_NAMES, IrModel, IrSensorSetup, MEAN_IR_CURVE, N_IR, N_MEASURED_IR_CURVES,
};
pub use task::{TaskConfig, task_content_hash};
