//! Networks: the CTRNN, the controller trees built from them (file form and runtime), a tree
//! stepped for eight robots at once (`lanes.rs`), and the [`Policy`] every driver of the robot
//! implements.

pub mod controller;
pub mod ctrnn;
pub mod lanes;

use crate::sensors::frame::SensorFrame;
use controller::Controller;

/// Anything that drives the robot: an evolved controller tree or a scripted reference policy.
pub trait Policy {
    /// Clears all internal state; called at the start of every sample.
    fn reset(&mut self);
    /// One control cycle: the wheel outputs (left, right), each in [0, 1].
    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2];
    /// The root arbitrator's chosen child in the last step, for the derived fitness.
    fn root_choice(&self) -> Option<usize> {
        None
    }
    /// Node indices active in the last step, root first.
    fn active_path(&self) -> &[usize] {
        &[0]
    }
    /// Number of nodes, for counting active cycles per node.
    fn n_nodes(&self) -> usize {
        1
    }
    /// The output index of the root's child named `name`, for a derived fitness whose phases
    /// name their children; `None` when the policy has no such names (a phase then asks for
    /// the child at its own position).
    fn root_child_index(&self, name: &str) -> Option<usize> {
        let _ = name;
        None
    }
    /// The controller tree, if the policy is one: a team's `evolved` robots then run it eight
    /// at a time (a `LaneController`).
    fn controller(&self) -> Option<&Controller> {
        None
    }
    /// A fresh copy, reset, for another robot of a team to run with its own state, if the
    /// policy is no controller tree but can be copied (a team's `evolved` robots need one).
    fn team_copy(&self) -> Option<Box<dyn Policy + Send>> {
        None
    }
}

impl Policy for Controller {
    fn reset(&mut self) {
        Controller::reset(self);
    }

    #[inline]
    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let wheels = Controller::step(self, frame, dt);
        [wheels.left, wheels.right]
    }

    fn root_choice(&self) -> Option<usize> {
        Controller::root_choice(self)
    }

    fn active_path(&self) -> &[usize] {
        Controller::active_path(self)
    }

    fn n_nodes(&self) -> usize {
        Controller::n_nodes(self)
    }

    fn root_child_index(&self, name: &str) -> Option<usize> {
        Controller::root_child_index(self, name)
    }

    fn controller(&self) -> Option<&Controller> {
        Some(self)
    }
}
