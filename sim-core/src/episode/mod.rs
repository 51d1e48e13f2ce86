//! Episodes: one policy on one seeded sample of a task (setting the world up, the control loop,
//! the judge, a team's other robots), the evaluator that runs them, the lockstep evaluation of many samples at once
//! and the batch API the engine and the bindings call.

pub mod batch;
pub mod evaluator;
pub mod judge;
pub mod lockstep;
pub mod regions;
pub mod setup;
pub mod stepping;
pub(crate) mod team;
