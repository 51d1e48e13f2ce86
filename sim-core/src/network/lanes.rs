//! A controller tree stepped for [`LANES`] robots at once: every robot runs the same weights
//! and differs only in its state, laid out one [`Lanes`] per neuron, so each network steps once
//! per cycle for all the lanes in which it is active, with the compiler's vector instructions
//! ([`crate::math::lanes`]). A lane's outputs are bit for bit those of [`Controller::step`] on
//! its own inputs; the lockstep evaluator (eight samples of a genome) and a team's copies of
//! one controller (eight robots of a sample) both step their robots through it.

use crate::math::lanes::{LANES, LaneMask, Lanes, lanes_of};
use crate::network::controller::{Controller, NodeKind, arbitrate};
use crate::network::ctrnn::{StepWeights, euler_step};
use crate::sensors::frame::N_FLAT;
use std::ops::Range;

/// [`euler_step`] on lanes, compiled for the baseline CPU and again for AVX2, where one
/// register holds all [`LANES`] lanes; the CPU the program runs on picks the version once.
/// Both versions perform the same IEEE operations in the same order (Rust never fuses a
/// multiply and an add on its own), so the outcomes do not depend on the CPU.
#[multiversion::multiversion(targets("x86_64+avx2"))]
fn step_network(
    weights: &StepWeights<'_>,
    inputs: &[Lanes],
    presynaptic: &mut [Lanes],
    state: &mut [Lanes],
    outputs: &mut [Lanes],
) {
    // The paper's shapes (and the single network it compares with), and the shapes
    // `hevo bench` gives a scenario file's controller (every input), with their sizes as
    // constants, so the compiler unrolls every loop; any other shape runs the same step with
    // its sizes read at run time.
    let shape = (weights.n_inputs(), weights.n_hidden(), outputs.len());
    let stepped = match shape {
        (4, 3, 2) => step_fixed::<4, 3, 2>(weights, inputs, presynaptic, state, outputs),
        (4, 10, 2) => step_fixed::<4, 10, 2>(weights, inputs, presynaptic, state, outputs),
        (4, 10, 3) => step_fixed::<4, 10, 3>(weights, inputs, presynaptic, state, outputs),
        (5, 10, 3) => step_fixed::<5, 10, 3>(weights, inputs, presynaptic, state, outputs),
        (6, 10, 2) => step_fixed::<6, 10, 2>(weights, inputs, presynaptic, state, outputs),
        (6, 10, 3) => step_fixed::<6, 10, 3>(weights, inputs, presynaptic, state, outputs),
        (7, 4, 2) => step_fixed::<7, 4, 2>(weights, inputs, presynaptic, state, outputs),
        (7, 10, 2) => step_fixed::<7, 10, 2>(weights, inputs, presynaptic, state, outputs),
        _ => None,
    };
    if stepped.is_none() {
        euler_step(weights, inputs, presynaptic, state, outputs);
    }
}

/// [`euler_step`] for a network of `I` inputs, `H` hidden neurons and `O` outputs, every
/// slice cut to its constant length; `None` (nothing stepped) if a slice is too short.
#[inline(always)]
fn step_fixed<const I: usize, const H: usize, const O: usize>(
    weights: &StepWeights<'_>,
    inputs: &[Lanes],
    presynaptic: &mut [Lanes],
    state: &mut [Lanes],
    outputs: &mut [Lanes],
) -> Option<()> {
    let weights = weights.with_shape(I, H, O)?;
    euler_step(
        &weights,
        inputs.get(..I)?,
        presynaptic.get_mut(..I + H)?,
        state.get_mut(..H)?,
        outputs.get_mut(..O)?,
    );
    Some(())
}

/// One network's state in every lane, and the scratch a partial step needs.
#[derive(Debug, Clone)]
struct LaneNetwork {
    /// dt / tau per hidden neuron, as the scalar network computes them.
    dt_over_taus: Vec<f32>,
    n_inputs: usize,
    /// `[inputs | firing rates]`, as the scalar network's `presynaptic`.
    presynaptic: Vec<Lanes>,
    state: Vec<Lanes>,
    outputs: Vec<Lanes>,
    /// Copies for a step that only some lanes take.
    scratch_presynaptic: Vec<Lanes>,
    scratch_state: Vec<Lanes>,
    scratch_outputs: Vec<Lanes>,
}

impl LaneNetwork {
    fn reset_lane(&mut self, rest_firing: &[f32], lane: usize) {
        for y in &mut self.state {
            y.0[lane] = 0.0;
        }
        let (inputs, firing) = self.presynaptic.split_at_mut(self.n_inputs);
        for input in inputs {
            input.0[lane] = 0.0;
        }
        for (rate, &rest) in firing.iter_mut().zip(rest_firing) {
            rate.0[lane] = rest;
        }
        for output in &mut self.outputs {
            output.0[lane] = 0.0;
        }
    }
}

/// A controller tree run for [`LANES`] samples at once: the scalar [`Controller`]'s networks
/// and rules, with each node's network state and activator memory kept per lane.
#[derive(Debug, Clone)]
pub struct LaneController {
    controller: Controller,
    networks: Vec<LaneNetwork>,
    /// Per node: where its inputs lie in a frame, when they lie side by side there (`ir` then
    /// `light`, say), so a step reads them in place; `None` when they must be gathered.
    input_ranges: Vec<Option<Range<usize>>>,
    /// Per node and lane: the child position chosen last since the last reset.
    active_child: Vec<[Option<usize>; LANES]>,
    /// Per node and lane: steps the active child has been on.
    active_for: Vec<[u32; LANES]>,
    /// Per lane, the node indices from the root to the primitive of the last step.
    paths: [Vec<usize>; LANES],
    /// Scratch: per node, the lanes in which it is active this step.
    node_lanes: Vec<LaneMask>,
    /// Scratch: the current node's inputs, when they are gathered.
    inputs: Vec<Lanes>,
    /// Scratch: one lane's outputs of the current arbitrator.
    lane_outputs: Vec<f32>,
    /// Scratch: sub-trees (node range and lane) the current arbitrator switched away from.
    pending_resets: Vec<(usize, usize, usize)>,
}

impl LaneController {
    /// The lockstep form of `controller`, every lane reset, for steps of `dt` seconds.
    pub fn new(controller: Controller, dt: f32) -> LaneController {
        let nodes = controller.nodes();
        let networks = nodes
            .iter()
            .map(|node| {
                let topology = node.net.topology();
                let width = topology.n_inputs + topology.n_hidden;
                let mut network = LaneNetwork {
                    dt_over_taus: node.net.dt_over_taus(dt),
                    n_inputs: topology.n_inputs,
                    presynaptic: vec![Lanes::ZERO; width],
                    state: vec![Lanes::ZERO; topology.n_hidden],
                    outputs: vec![Lanes::ZERO; topology.n_outputs],
                    scratch_presynaptic: vec![Lanes::ZERO; width],
                    scratch_state: vec![Lanes::ZERO; topology.n_hidden],
                    scratch_outputs: vec![Lanes::ZERO; topology.n_outputs],
                };
                for lane in 0..LANES {
                    network.reset_lane(node.net.rest_firing(), lane);
                }
                network
            })
            .collect();
        let input_ranges = nodes
            .iter()
            .map(|node| {
                let mut groups = node.inputs.iter().map(|group| group.flat_range());
                let first = groups.next().unwrap_or(0..0);
                groups.try_fold(first, |joined, next| {
                    (joined.end == next.start).then_some(joined.start..next.end)
                })
            })
            .collect();
        let max_inputs = nodes
            .iter()
            .map(|node| node.net.topology().n_inputs)
            .max()
            .unwrap_or(0);
        let max_outputs = nodes
            .iter()
            .map(|node| node.net.topology().n_outputs)
            .max()
            .unwrap_or(0);
        let n_nodes = nodes.len();
        LaneController {
            networks,
            input_ranges,
            active_child: vec![[None; LANES]; n_nodes],
            active_for: vec![[0; LANES]; n_nodes],
            paths: std::array::from_fn(|_| Vec::with_capacity(n_nodes)),
            node_lanes: vec![0; n_nodes],
            inputs: vec![Lanes::ZERO; max_inputs],
            lane_outputs: vec![0.0; max_outputs],
            pending_resets: Vec::with_capacity(LANES),
            controller,
        }
    }

    /// The scalar controller whose networks this runs.
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// Resets lane `lane`, as [`Controller::reset`] resets the scalar controller.
    pub fn reset_lane(&mut self, lane: usize) {
        self.reset_lane_range(0, self.networks.len(), lane);
        self.paths[lane].clear();
    }

    /// Resets nodes `start..end` (a sub-tree) in lane `lane`.
    fn reset_lane_range(&mut self, start: usize, end: usize, lane: usize) {
        let nodes = self.controller.nodes();
        let range = start.min(nodes.len())..end.min(nodes.len());
        let memories = self.active_child[range.clone()]
            .iter_mut()
            .zip(&mut self.active_for[range.clone()]);
        for ((network, node), (active_child, active_for)) in self.networks[range.clone()]
            .iter_mut()
            .zip(&nodes[range])
            .zip(memories)
        {
            network.reset_lane(node.net.rest_firing(), lane);
            active_child[lane] = None;
            active_for[lane] = 0;
        }
    }

    /// One control cycle in every lane of `live`, each lane on its own frame (`frame_lanes`
    /// holds a frame's inputs lane by lane: input `i` of lane `l` is `frame_lanes[i].0[l]`):
    /// the wheel outputs per lane, as [`Controller::step`] gives them (lanes not live get
    /// zeros).
    pub fn step(&mut self, frame_lanes: &[Lanes; N_FLAT], live: LaneMask) -> [[f32; 2]; LANES] {
        let mut wheels = [[0.0f32; 2]; LANES];
        for path in &mut self.paths {
            path.clear();
        }
        self.node_lanes.fill(0);
        if let Some(root) = self.node_lanes.first_mut() {
            *root = live;
        }
        // Pre-order: every node comes after its parent, which has chosen its lanes by then.
        for node_idx in 0..self.networks.len() {
            let lanes = self.node_lanes[node_idx];
            if lanes == 0 {
                continue;
            }
            let node = &self.controller.nodes()[node_idx];
            let inputs: &[Lanes] = match &self.input_ranges[node_idx] {
                Some(range) => frame_lanes.get(range.clone()).unwrap_or_default(),
                None => {
                    let mut n_filled = 0;
                    for group in &node.inputs {
                        for (slot, value) in self.inputs[n_filled..]
                            .iter_mut()
                            .zip(&frame_lanes[group.flat_range()])
                        {
                            *slot = *value;
                        }
                        n_filled += group.width();
                    }
                    &self.inputs[..n_filled.min(self.inputs.len())]
                }
            };
            let network = &mut self.networks[node_idx];
            let weights = node.net.step_weights(&network.dt_over_taus);
            // Lanes without a sample may step freely; a lane with one steps only where the node
            // is active, as the scalar controller steps only the active path.
            if live & !lanes == 0 {
                step_network(
                    &weights,
                    inputs,
                    &mut network.presynaptic,
                    &mut network.state,
                    &mut network.outputs,
                );
            } else {
                network
                    .scratch_presynaptic
                    .copy_from_slice(&network.presynaptic);
                network.scratch_state.copy_from_slice(&network.state);
                network.scratch_outputs.copy_from_slice(&network.outputs);
                step_network(
                    &weights,
                    inputs,
                    &mut network.scratch_presynaptic,
                    &mut network.scratch_state,
                    &mut network.scratch_outputs,
                );
                let blend = |kept: &mut [Lanes], stepped: &[Lanes]| {
                    for (kept, &stepped) in kept.iter_mut().zip(stepped) {
                        *kept = kept.select(lanes, stepped);
                    }
                };
                blend(&mut network.presynaptic, &network.scratch_presynaptic);
                blend(&mut network.state, &network.scratch_state);
                blend(&mut network.outputs, &network.scratch_outputs);
            }

            match node.kind {
                NodeKind::Primitive => {
                    let pair = match &network.outputs[..] {
                        [left, right] => Some((left, right)),
                        _ => None,
                    };
                    for lane in lanes_of(lanes) {
                        self.paths[lane].push(node_idx);
                        if let Some((left, right)) = pair {
                            wheels[lane] = [left.0[lane], right.0[lane]];
                        }
                    }
                }
                NodeKind::Arbitrator => {
                    for lane in lanes_of(lanes) {
                        self.paths[lane].push(node_idx);
                        let outputs = &mut self.lane_outputs[..network.outputs.len()];
                        for (value, output) in outputs.iter_mut().zip(&network.outputs) {
                            *value = output.0[lane];
                        }
                        let (chosen, left) = arbitrate(
                            outputs,
                            &mut self.active_child[node_idx][lane],
                            &mut self.active_for[node_idx][lane],
                            node.min_active_cycles,
                        );
                        let Some(&chosen_node) = node.children.get(chosen) else {
                            continue;
                        };
                        if let Some(previous) = left
                            && let Some(&left_node) = node.children.get(previous)
                        {
                            let end = self.controller.nodes()[left_node].subtree_end;
                            self.pending_resets.push((left_node, end, lane));
                        }
                        self.node_lanes[chosen_node] |= 1 << lane;
                    }
                }
            }
            // The sub-trees left lie below this node in pre-order, so they are reset before
            // any of them steps, as in the scalar controller.
            while let Some((start, end, lane)) = self.pending_resets.pop() {
                self.reset_lane_range(start, end, lane);
            }
        }
        wheels
    }

    /// Node indices from the root to the primitive that drove lane `lane`'s wheels last.
    pub fn active_path(&self, lane: usize) -> &[usize] {
        &self.paths[lane]
    }

    /// The child position the root chose in lane `lane`'s last step (`None` for a primitive
    /// root, or before the first step).
    pub fn root_choice(&self, lane: usize) -> Option<usize> {
        self.active_child.first().and_then(|root| root[lane])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::lanes::Real;
    use crate::network::ctrnn::{Ctrnn, CtrnnTopology};
    use proptest::prelude::*;

    /// Every shape `step_network` has unrolled code for, and two it has not.
    const SHAPES: [(usize, usize, usize); 10] = [
        (4, 3, 2),
        (4, 10, 2),
        (4, 10, 3),
        (5, 10, 3),
        (6, 10, 2),
        (6, 10, 3),
        (7, 4, 2),
        (7, 10, 2),
        (5, 6, 4),
        (1, 1, 1),
    ];

    /// A shape of [`SHAPES`], genes for it and eight lanes of inputs.
    fn network_and_inputs() -> impl Strategy<Value = (CtrnnTopology, Vec<f32>, Vec<f32>)> {
        prop::sample::select(&SHAPES[..]).prop_flat_map(|(n_inputs, n_hidden, n_outputs)| {
            let topology = CtrnnTopology::new(n_inputs, n_hidden, n_outputs);
            (
                Just(topology),
                prop::collection::vec(-10.0f32..10.0, topology.n_genes()),
                prop::collection::vec(0.0f32..1.0, n_inputs * LANES),
            )
        })
    }

    proptest! {
        /// The version the CPU picks (AVX2 where it has it), with its unrolled code for the
        /// common shapes, gives the generic step's bits.
        #[test]
        fn dispatched_network_step_matches_the_generic_one_bit_for_bit(
            (topology, genes, inputs) in network_and_inputs(),
            n_steps in 1usize..20,
        ) {
            let net = Ctrnn::new(topology, &genes).unwrap();
            let dt_over_taus = net.dt_over_taus(0.1);
            let weights = net.step_weights(&dt_over_taus);
            let inputs: Vec<Lanes> = inputs
                .chunks_exact(LANES)
                .map(|chunk| Lanes(std::array::from_fn(|lane| chunk[lane])))
                .collect();
            let (n_inputs, n_hidden) = (topology.n_inputs, topology.n_hidden);
            let fresh = || {
                let mut presynaptic = vec![Lanes::ZERO; n_inputs + n_hidden];
                for (rate, &rest) in presynaptic[n_inputs..].iter_mut().zip(net.rest_firing()) {
                    *rate = Lanes::splat(rest);
                }
                (
                    presynaptic,
                    vec![Lanes::ZERO; n_hidden],
                    vec![Lanes::ZERO; topology.n_outputs],
                )
            };
            let (mut pre_a, mut state_a, mut out_a) = fresh();
            let (mut pre_b, mut state_b, mut out_b) = fresh();
            for _ in 0..n_steps {
                step_network(&weights, &inputs, &mut pre_a, &mut state_a, &mut out_a);
                euler_step(&weights, &inputs, &mut pre_b, &mut state_b, &mut out_b);
            }
            let bits = |values: &[Lanes]| -> Vec<u32> {
                values.iter().flat_map(|v| v.0.map(f32::to_bits)).collect()
            };
            prop_assert_eq!(bits(&state_a), bits(&state_b));
            prop_assert_eq!(bits(&out_a), bits(&out_b));
        }
    }
}
