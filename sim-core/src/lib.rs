//! hevo's simulation core: a pure, deterministic e-puck world (rapier2d scene, measured IR and
//! light sensor models), CTRNN behaviour primitives and arbitrators composed into trees of any
//! depth, the paper's tasks with their fitness functions, and the evaluation of one genome on
//! one seeded sample. It does no IO: no threads, no clock, no files, no global random state.

// The floors, lowest first: each imports only its own floor and those below
// (`tests/sim/floors.rs` holds the order).
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
pub use body::{Pose, wheel_speed};
pub use config::{
    ConfigError, CorridorConfig, CurveChoice, IrConfig, IrMapping, LightConfig, N_LIGHT, Params,
    RabConfig, RobotConfig, RoomConfig, StartConfig,
};
pub use episode::batch::{
    BatchError, BatchEvaluator, EvaluatorKind, SampleSummary, controller_fits,
};
pub use episode::evaluator::{Evaluator, TaskError};
pub use episode::regions::{NamedRegion, named_regions};
pub use episode::stepping::{Episode, StepError, WHEEL_RANGE};
pub use geometry::items::ITEM_RADIUS;
pub use geometry::scene::{Rect, RectKind, Scene};
pub use math::hash::{Fnv1a, fnv1a, fnv1a_hex};
pub use math::rng::{SimRng, Stream, derive_seed, mix64, stream_rng};
pub use network::Policy;
pub use network::controller::{
    Controller, ControllerError, ControllerFile, NodeKind, NodeSpec, PRIMITIVE_OUTPUTS,
};
pub use network::ctrnn::{CtrnnTopology, GENE_MAX, GENE_MIN, logistic, tau_from_gene};
pub use outcome::{
    CycleItem, Ending, N_SUB_TASKS, NodeUse, Outcome, Sample, SubTaskChoices, Trace, TraceCycle,
    TracedBox, TracedItem, TracedMover,
};
pub use scenario::file::ChildRef;
pub use scenario::{
    ControllerSource, DEFAULT_DESCRIPTOR, MAX_BOXES, MAX_CONTROLLER_FILE_BYTES, MAX_DESCRIPTOR,
    MAX_ITEMS, MAX_LIGHTS, MAX_MOVERS, MAX_ROBOTS, SHIPPED, SHIPPED_NAMES, Scenario, ScenarioError,
};
pub use sensors::IrCone;
pub use sensors::calibration::MeanStd;
pub use sensors::frame::{InputGroup, N_FLAT, SensorFrame, SensorSet};
pub use sensors::ir::{
    IR_CURVE_NAMES, IrModel, IrSensorSetup, MEAN_IR_CURVE, N_IR, N_MEASURED_IR_CURVES,
};
pub use sensors::light::{FlashDetector, LightModel};
pub use task::{TaskConfig, task_content_hash};

/// Whether a test comparing a CPU-specific code path with its reference can run on this CPU
/// (`present`: the CPU has `feature`). Without it the comparison would pass without comparing
/// anything, so the test says so on stderr and is skipped; under CI, whose machines have the
/// features, `tests/sim/golden.rs` fails instead (sim-core itself reads no environment).
#[cfg(test)]
pub(crate) fn cpu_feature_for_test(feature: &str, present: bool, test: &str) -> bool {
    if !present {
        eprintln!("SKIPPED {test}: this CPU lacks {feature}, so there is nothing to compare");
    }
    present
}

/// The model's tasks are part of the model: each shipped scenario's and map's text, as hashed when
/// [`MODEL_VERSION`] was last set. A paper task travels (and is fingerprinted) by its name, so
/// an edit to `scenarios/*.toml` would otherwise leave every run fingerprint valid.
#[cfg(test)]
mod model_version {
    use super::MODEL_VERSION;
    use crate::math::hash::fnv1a_hex;
    use crate::scenario::{SHIPPED, SHIPPED_MAPS};

    /// (model version, [(scenario or map, FNV-1a of its text)]).
    const PINNED: (u32, [(&str, &str); 8]) = (
        4,
        [
            ("exit_room", "d146835303d35f91"),
            ("follow_wall", "8761a9efdb396143"),
            ("turn_left", "a070d04f56b0a86e"),
            ("turn_right", "dfde944d756bad84"),
            ("solve_maze", "002798383ff4b40c"),
            ("return_room", "8ca4c4631b61d883"),
            ("rescue", "1e9366bf444614df"),
            ("maps/double_t_maze", "e7fa2b47c20f0a7c"),
        ],
    );

    #[test]
    fn shipped_scenarios_are_the_texts_this_model_version_was_measured_with() {
        let maps = SHIPPED_MAPS.map(|(name, text)| (format!("maps/{name}"), text));
        let found: Vec<(&str, String)> = SHIPPED
            .iter()
            .map(|(name, text)| (*name, *text))
            .chain(maps.iter().map(|(name, text)| (name.as_str(), *text)))
            .map(|(name, text)| (name, fnv1a_hex(text.as_bytes())))
            .collect();
        let pinned: Vec<(&str, String)> = PINNED
            .1
            .iter()
            .map(|(name, hash)| (*name, hash.to_string()))
            .collect();
        assert!(
            found == pinned && PINNED.0 == MODEL_VERSION,
            "a shipped scenario changed (or MODEL_VERSION did without these pins): a change to a \
             paper task changes its trajectories or fitness, so bump MODEL_VERSION, re-measure \
             the shipped controllers, and pin the new texts here:\n  found {found:?}\n  pinned \
             {pinned:?} at model version {}",
            PINNED.0
        );
    }
}
