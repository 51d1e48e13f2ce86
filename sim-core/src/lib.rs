//! hevo's simulation core: a pure, deterministic e-puck world (rapier2d scene, measured IR and
//! light sensor models), CTRNN behaviour primitives and arbitrators composed into trees of any
//! depth, the paper's tasks with their fitness functions, and the evaluation of one genome on
//! one seeded sample. It does no IO: no threads, no clock, no files, no global random state.

pub mod batch;
pub mod controller;
pub mod ctrnn;
mod float;
pub mod frame;
pub mod hash;
pub mod lanes;
pub mod lockstep;
pub mod rng;
pub mod sensors;

pub mod env;
pub mod evaluate;
pub mod robot;
pub mod scenario;
pub mod scene;
pub mod task;
mod trig;

/// Version of the simulation model. Bump it whenever a change alters any trajectory or fitness
/// (the golden tests catch such changes): run fingerprints include it, so checkpoints written by
/// an older model are refused instead of being silently continued with a different one.
pub const MODEL_VERSION: u32 = 4;

pub use evaluate::{
    Ending, Evaluator, NodeUse, Outcome, Policy, Sample, SubTaskChoices, Trace, TraceCycle,
};
pub use scenario::Scenario;
pub use task::TaskConfig;
