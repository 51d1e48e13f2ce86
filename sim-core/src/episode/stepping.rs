//! One sample stepped cycle by cycle by its caller: an [`Episode`] shows the robot's sensor
//! frame of the current cycle, takes the wheel outputs for it, and says when the sample ended
//! and its outcome. It is the scalar evaluator's own control loop, not a copy of it:
//! [`Evaluator::evaluate`] and [`Evaluator::evaluate_traced`] run every sample as an episode
//! whose wheels their controller sets, so an episode driven with a controller's outputs ends
//! exactly where that controller's evaluation ends (`tests/sim/stepping.rs` holds them to it).
//! For a policy outside hevo (a Python environment, a learner), which has no controller tree:
//! no node use is counted and no root choice is made.

use super::evaluator::{Evaluator, Finished, SampleRun};
use crate::body::Pose;
use crate::network::Policy;
use crate::outcome::{CycleItem, Ending, N_SUB_TASKS, Outcome, Sample, TraceCycle};
use crate::sensors::frame::SensorFrame;

/// Receives each cycle; the plain evaluation records nothing and compiles to nothing.
pub(crate) trait Recorder {
    fn record(&mut self, make: impl FnOnce() -> TraceCycle);
}

impl Recorder for () {
    #[inline(always)]
    fn record(&mut self, _make: impl FnOnce() -> TraceCycle) {}
}

impl Recorder for Vec<TraceCycle> {
    fn record(&mut self, make: impl FnOnce() -> TraceCycle) {
        self.push(make());
    }
}

/// The range of a wheel output: 0 drives the wheel full speed backwards, 0.5 stops it, 1
/// drives it full speed forwards ([`crate::wheel_speed`]), as a controller's outputs do.
pub const WHEEL_RANGE: (f32, f32) = (0.0, 1.0);

/// Why [`Episode::step`] refused a step.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// A wheel output that is NaN or infinite.
    #[error(
        "wheel {wheel} ({}) is {value:?}: wheel outputs must be finite",
        if *wheel == 0 { "left" } else { "right" }
    )]
    NotFinite {
        /// 0 left, 1 right.
        wheel: usize,
        /// The value given.
        value: f32,
    },
    /// The episode has ended; its outcome is all that is left.
    #[error("the episode ended ({ending:?}) after {cycles} cycles; start a new one")]
    Ended {
        /// Why it ended.
        ending: Ending,
        /// Cycles it ran.
        cycles: u32,
    },
}

/// One sample in progress, stepped by its caller. Made by [`Episode::new`] (or by the
/// evaluator for its controller), it has sensed its first cycle's frame.
#[derive(Debug)]
pub struct Episode<'e> {
    run: SampleRun<'e>,
    /// What the robot sensed at the start of the current cycle.
    frame: SensorFrame,
    /// Why the sample ended, once it has.
    ending: Option<Ending>,
}

impl<'e> Episode<'e> {
    /// Starts `sample` of the evaluator's task for a caller that sets the wheels itself. The
    /// caller drives the focal robot alone: a team's `evolved` robots (`[[robots]]`), which
    /// run copies of an evaluated controller, stand still.
    /// ([`crate::Scenario::has_evolved_team`] says whether a scenario has them.)
    pub fn new(evaluator: &'e Evaluator, sample: Sample) -> Episode<'e> {
        // No controller tree: no nodes to count, and no root child a phase could ask for.
        Episode::for_policy(evaluator, sample, 0, [usize::MAX; N_SUB_TASKS])
    }

    /// Starts `sample` for a controller of `n_nodes` nodes whose root's phase children are
    /// `phase_child` (the controller itself is reset by the caller).
    pub(crate) fn for_policy(
        evaluator: &'e Evaluator,
        sample: Sample,
        n_nodes: usize,
        phase_child: [usize; N_SUB_TASKS],
    ) -> Episode<'e> {
        let mut run = SampleRun::new(evaluator, sample, n_nodes, phase_child);
        let frame = run.sense();
        Episode {
            run,
            frame,
            ending: None,
        }
    }

    /// Gives a team's `evolved` robots their own reset copies of `policy` (a scenario with
    /// `[[robots]]`); until then they stand still.
    pub(crate) fn drive_team_with(&mut self, policy: &dyn Policy) {
        self.run.drive_team_with(policy);
    }

    /// The sensor frame of the current cycle (of the last one, once ended).
    #[inline]
    pub fn frame(&self) -> &SensorFrame {
        &self.frame
    }

    /// Why the sample ended, or `None` while it runs.
    pub fn ending(&self) -> Option<Ending> {
        self.ending
    }

    /// Cycles begun, the current one included (once ended: the cycles it ran).
    pub fn cycles(&self) -> u32 {
        self.run.cycles_run()
    }

    /// A team's other robots' poses at the start of the current cycle (once ended: where
    /// they ended), group by group as a trace's `team`; empty without a team.
    pub fn team_poses(&self) -> Vec<Pose> {
        self.run.team_poses()
    }

    /// The movers' then the boxes' centres at the start of the current cycle (once ended:
    /// where they ended), as a trace's `bodies`; empty without either.
    pub fn body_centres(&self) -> Vec<[f32; 2]> {
        self.run.body_centres()
    }

    /// Every item at the start of the current cycle (once ended: where it ended), as a
    /// trace's per-cycle `items`; empty without items.
    pub fn item_places(&self) -> Vec<CycleItem> {
        self.run.item_places()
    }

    /// The variant the sample runs (light configuration, start branch).
    pub fn variant(&self) -> u32 {
        self.run.variant()
    }

    /// Runs the current cycle with wheel outputs `wheels` (left, right; [`WHEEL_RANGE`]),
    /// then senses the next cycle's frame unless the sample ended. A wheel output outside the
    /// range is clipped to it (as a controller's cannot be); NaN and infinity are refused,
    /// as is a step after the end. Returns the ending if the sample ended in this cycle.
    pub fn step(&mut self, wheels: [f32; 2]) -> Result<Option<Ending>, StepError> {
        if let Some(ending) = self.ending {
            return Err(StepError::Ended {
                ending,
                cycles: self.cycles(),
            });
        }
        let mut clipped = wheels;
        for (wheel, value) in clipped.iter_mut().enumerate() {
            if !value.is_finite() {
                return Err(StepError::NotFinite {
                    wheel,
                    value: *value,
                });
            }
            *value = value.clamp(WHEEL_RANGE.0, WHEEL_RANGE.1);
        }
        Ok(self.cycle(clipped, &[], None, &mut ()))
    }

    /// The current cycle, as the controller with `active_path` and `root_choice` decided it:
    /// counts the decision, moves the robot, records the cycle, and either ends the sample or
    /// senses the next frame.
    #[inline]
    pub(crate) fn cycle<R: Recorder>(
        &mut self,
        wheels: [f32; 2],
        active_path: &[usize],
        root_choice: Option<usize>,
        recorder: &mut R,
    ) -> Option<Ending> {
        let run = &mut self.run;
        run.count_decision(active_path, root_choice);
        let (before, collided) = run.move_robot(wheels);
        recorder.record(|| TraceCycle {
            robot: before,
            teammate: run.teammate_pose(),
            frame: self.frame,
            wheels,
            active_path: active_path.iter().map(|&n| n as u16).collect(),
            collided,
            lit_lights: run.lit_mask(),
            sub_task: run.sub_task().unwrap_or(0),
            team: run.team_poses(),
            bodies: run.body_centres(),
            items: run.item_places(),
        });
        match run.finish_cycle(&before, collided) {
            Some(ending) => {
                self.ending = Some(ending);
                Some(ending)
            }
            None => {
                self.frame = run.sense();
                None
            }
        }
    }

    /// The outcome of an ended sample; `None` for one still running (an episode ends when
    /// [`Episode::step`] returns its ending).
    pub fn into_outcome(self) -> Option<Outcome> {
        let ending = self.ending?;
        Some(self.run.finish(ending).outcome)
    }

    /// The outcome, the sample's world (for a trace) and every robot's final pose, the sample
    /// having ended with `ending`.
    pub(crate) fn finish(self, ending: Ending) -> Finished {
        self.run.finish(ending)
    }
}
