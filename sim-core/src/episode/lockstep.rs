//! The lockstep evaluator: [`LANES`] samples of one controller advance together, cycle by
//! cycle. Every genome of a generation runs the same samples, so the networks of all lanes
//! share their weights and differ only in their state: a [`LaneController`] steps them all at
//! once. The world of each lane (sensing, moving, judging) runs the scalar evaluator's own
//! per-sample code (`evaluate::SampleRun`), so an outcome here is bit-identical to
//! [`Evaluator::evaluate`]'s for the same controller and sample; the property tests in
//! `tests/sim/lockstep.rs` hold the two to that. A lane whose sample ends takes the next sample
//! at once, so samples that end early leave no lane idle.

use crate::body::Arc;
use crate::episode::evaluator::{Evaluator, SampleRun};
use crate::episode::judge::phase_children;
use crate::math::lanes::{LANES, LaneMask, Lanes};
use crate::math::trig;
use crate::network::lanes::LaneController;
use crate::outcome::{Outcome, Sample};
use crate::sensors::frame::N_FLAT;

impl Evaluator {
    /// Runs every sample with `controller`, `LANES` (eight) at a time in lockstep, and returns the
    /// outcomes in sample order: the same, bit for bit, as [`Evaluator::evaluate`] gives for
    /// the controller it was built from.
    pub fn evaluate_lockstep(
        &self,
        controller: &mut LaneController,
        samples: &[Sample],
    ) -> Vec<Outcome> {
        let n_nodes = controller.controller().n_nodes();
        let phase_child = phase_children(&self.task().scenario, controller.controller());
        let mut outcomes: Vec<Option<Outcome>> = vec![None; samples.len()];
        let mut runs: [Option<(usize, SampleRun<'_>)>; LANES] = std::array::from_fn(|_| None);
        let mut pending = samples.iter().copied().enumerate();
        // The lanes' frames input by input, as the networks read them.
        let mut frame_lanes = [Lanes::ZERO; N_FLAT];
        loop {
            for (lane, slot) in runs.iter_mut().enumerate() {
                if slot.is_none()
                    && let Some((idx, sample)) = pending.next()
                {
                    controller.reset_lane(lane);
                    let mut run = SampleRun::new(self, sample, n_nodes, phase_child);
                    // A team's other robots run scalar copies; the focal robot is the lane's.
                    run.drive_team_with(controller.controller());
                    *slot = Some((idx, run));
                }
            }
            let live = runs
                .iter()
                .enumerate()
                .filter(|(_, slot)| slot.is_some())
                .fold(0, |mask: LaneMask, (lane, _)| mask | 1 << lane);
            if live == 0 {
                break;
            }
            // The sines of every lane's heading at once, then each lane senses.
            let headings = runs
                .each_ref()
                .map(|slot| slot.as_ref().map_or(0.0, |(_, run)| run.heading()));
            let (sines, cosines) = trig::sin_cos_lanes(&headings);
            for (lane, slot) in runs.iter_mut().enumerate() {
                if let Some((_, run)) = slot {
                    let frame = run.sense_at((sines[lane], cosines[lane]));
                    for (input, &value) in frame_lanes.iter_mut().zip(&frame.inputs) {
                        input.0[lane] = value;
                    }
                }
            }
            let wheels = controller.step(&frame_lanes, live);
            // Each lane's arc, the sines of all the arcs at once, then each lane moves and the
            // cycle ends.
            let arcs: [Option<Arc>; LANES] = std::array::from_fn(|lane| {
                let (_, run) = runs[lane].as_mut()?;
                run.count_decision(controller.active_path(lane), controller.root_choice(lane));
                Some(run.plan_move(wheels[lane]))
            });
            let angles = |of: fn(&Arc) -> f32| arcs.map(|arc| arc.as_ref().map_or(0.0, of));
            let (sin_half_turns, _) = trig::sin_cos_lanes(&angles(|arc| arc.half_turn));
            let (sin_mids, cos_mids) = trig::sin_cos_lanes(&angles(|arc| arc.mid_heading));
            for (lane, (slot, arc)) in runs.iter_mut().zip(&arcs).enumerate() {
                let (Some((_, run)), Some(arc)) = (slot.as_mut(), arc) else {
                    continue;
                };
                let (before, collided) =
                    run.finish_move(arc, sin_half_turns[lane], (sin_mids[lane], cos_mids[lane]));
                if let Some(ending) = run.finish_cycle(&before, collided)
                    && let Some((idx, run)) = slot.take()
                {
                    outcomes[idx] = Some(run.finish(ending).outcome);
                }
            }
        }
        outcomes.into_iter().flatten().collect()
    }
}
