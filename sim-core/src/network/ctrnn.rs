//! The continuous-time recurrent neural network (CTRNN, Beer 1995) that every behaviour primitive
//! and arbitrator runs: one fully connected recurrent hidden layer integrated with forward Euler,
//! and a logistic output layer. It defines the genome layout (a file format: controller files store
//! genomes in this order) and the per-cycle update, which is on the simulator's hot path and so
//! never allocates.
//!
//! # Genome layout
//!
//! A genome for topology `I-H-O` (`n_inputs`, `n_hidden`, `n_outputs`) is a flat list of
//! `I*H + H*H + H + H + H*O + O` genes, all nominally in [-10, 10], in this order:
//!
//! | group | genes | index of one gene |
//! |---|---|---|
//! | input -> hidden weights | `I*H` | `h*I + k`: weight from input `k` to hidden `h` |
//! | hidden -> hidden weights | `H*H` | `I*H + h*H + j`: weight from hidden `j` to hidden `h` |
//! | hidden biases theta | `H` | `I*H + H*H + h` |
//! | time-constant genes | `H` | `I*H + H*H + H + h` |
//! | hidden -> output weights | `H*O` | `I*H + H*H + 2H + o*H + j`: weight from hidden `j` to output `o` |
//! | output biases | `O` | `I*H + H*H + 2H + H*O + o` |
//!
//! Every weight matrix is stored one row per *receiving* neuron, so each neuron's incoming
//! weights are contiguous. For 4-3-2 that is 35 genes, for 6-10-3 213 and for 4-10-2 182.
//!
//! A time-constant gene `g` maps to `tau = 10^(-1 + 2.5 (g + 10) / 20)`, so [-10, 10] covers
//! 0.1 .. 31.6 exponentially.
//!
//! # Update
//!
//! With firing rates `f_j = sigma(y_j + theta_j)` and sigma the logistic function, one step does
//!
//! ```text
//! y_h <- y_h + (dt / tau_h) * (-y_h + sum_j w_jh f_j + sum_k w_kh I_k)   (f from the old state)
//! o_o  = sigma(sum_j w_jo f'_j + b_o)                                     (f' from the new state)
//! ```
//!
//! The recurrent term uses the firing rates of the state before the update, which is what
//! forward Euler means: every derivative is evaluated at the start of the step. The outputs read
//! the updated state, so an input change reaches the outputs in the same cycle.

use std::fmt;
use std::ops::Range;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::math::lanes::Real;

/// Smallest value a gene takes in evolution and in a valid controller file.
pub const GENE_MIN: f32 = -10.0;
/// Largest value a gene takes in evolution and in a valid controller file.
pub const GENE_MAX: f32 = 10.0;

/// The shape of one network: how many inputs, hidden neurons and outputs it has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct CtrnnTopology {
    /// Number of inputs (sensor values) the network reads.
    pub n_inputs: usize,
    /// Number of recurrently connected hidden neurons.
    pub n_hidden: usize,
    /// Number of outputs.
    pub n_outputs: usize,
}

/// Where each group of genes sits in a genome of a given topology (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GenomeLayout {
    /// Input -> hidden weights, one row of `n_inputs` per hidden neuron.
    pub input_weights: Range<usize>,
    /// Hidden -> hidden weights, one row of `n_hidden` per receiving hidden neuron.
    pub hidden_weights: Range<usize>,
    /// Hidden biases theta, one per hidden neuron.
    pub hidden_biases: Range<usize>,
    /// Time-constant genes, one per hidden neuron.
    pub tau_genes: Range<usize>,
    /// Hidden -> output weights, one row of `n_hidden` per output.
    pub output_weights: Range<usize>,
    /// Output biases, one per output.
    pub output_biases: Range<usize>,
}

impl CtrnnTopology {
    /// A topology with the given numbers of inputs, hidden neurons and outputs.
    pub fn new(n_inputs: usize, n_hidden: usize, n_outputs: usize) -> Self {
        Self {
            n_inputs,
            n_hidden,
            n_outputs,
        }
    }

    /// Where each group of genes sits in the genome. The arithmetic saturates instead of
    /// overflowing, so an absurd topology read from a file gives an impossible genome length
    /// (which validation then reports) rather than a panic.
    pub fn layout(&self) -> GenomeLayout {
        let n_in = self.n_inputs;
        let n_hid = self.n_hidden;
        let n_out = self.n_outputs;
        let mut start = 0usize;
        let mut next = |len: usize| {
            let range = start..start.saturating_add(len);
            start = range.end;
            range
        };
        GenomeLayout {
            input_weights: next(n_in.saturating_mul(n_hid)),
            hidden_weights: next(n_hid.saturating_mul(n_hid)),
            hidden_biases: next(n_hid),
            tau_genes: next(n_hid),
            output_weights: next(n_hid.saturating_mul(n_out)),
            output_biases: next(n_out),
        }
    }

    /// Total number of genes of a genome for this topology.
    pub fn n_genes(&self) -> usize {
        self.layout().output_biases.end
    }
}

impl fmt::Display for CtrnnTopology {
    /// Formats the topology the way the paper writes it: `inputs-hidden-outputs`, e.g. `4-3-2`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}-{}-{}", self.n_inputs, self.n_hidden, self.n_outputs)
    }
}

/// What can be wrong when building or stepping a network.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CtrnnError {
    /// The topology has no hidden neurons, so it has no state and no path to the outputs.
    #[error("topology {topology} has no hidden neurons")]
    NoHiddenNeurons { topology: CtrnnTopology },
    /// The topology has no outputs.
    #[error("topology {topology} has no outputs")]
    NoOutputs { topology: CtrnnTopology },
    /// The genome does not have the number of genes the topology needs.
    #[error("genome has {found} genes, topology {topology} needs {needed}")]
    GenomeLength {
        found: usize,
        needed: usize,
        topology: CtrnnTopology,
    },
    /// A gene is NaN or infinite.
    #[error("gene {gene_idx} is not finite ({value})")]
    NonFiniteGene { gene_idx: usize, value: f32 },
    /// The input slice given to `step` has the wrong length.
    #[error("step got {found} inputs, topology {topology} has {needed}")]
    InputLength {
        found: usize,
        needed: usize,
        topology: CtrnnTopology,
    },
    /// The output slice given to `step` has the wrong length.
    #[error("step got room for {found} outputs, topology {topology} has {needed}")]
    OutputLength {
        found: usize,
        needed: usize,
        topology: CtrnnTopology,
    },
    /// The time step is zero, negative or not finite.
    #[error("time step {dt} is not a positive finite number of seconds")]
    BadTimeStep { dt: f32 },
}

/// Maps a time-constant gene in [-10, 10] to its time constant in seconds, 0.1 .. 31.6:
/// `10^(-1 + 2.5 (g + 10) / 20)`. The power is taken as `e^(x ln 10)` with the portable
/// exponential of [`logistic`] rather than libm's `powf`, for the same reason: identical time
/// constants on every platform.
pub fn tau_from_gene(gene: f32) -> f32 {
    let decimal_exponent = -1.0 + 2.5 * (gene - GENE_MIN) / (GENE_MAX - GENE_MIN);
    portable_exp(decimal_exponent * std::f32::consts::LN_10)
}

/// The logistic function 1 / (1 + e^-x).
///
/// It uses its own exponential made only of IEEE basic operations instead of the platform's
/// `expf`, because libm implementations differ in their last bits between systems and the
/// simulator promises the same trajectory on every machine. The exponential is the Cephes
/// `expf` scheme (Cody-Waite range reduction and a degree-7 polynomial), relative error about
/// 2e-7, which is about as fast as a libm call and vectorises. The argument of the exponential is
/// clamped to [-20, 88]: below -20, 1 + e^t already rounds to exactly 1, and above 88 the true
/// result is under 1e-38, so the clamp changes nothing that matters while keeping the
/// power-of-two scaling in the normal range. NaN propagates; nothing panics.
#[inline]
pub fn logistic(x: f32) -> f32 {
    logistic_of(x)
}

/// [`logistic`] on any [`Real`]: the one definition, which the lockstep evaluator runs on many
/// samples at once with the same operations in every lane.
#[inline(always)]
pub(crate) fn logistic_of<T: Real>(x: T) -> T {
    (T::splat(1.0) + portable_exp(-x)).recip()
}

/// e^t for t in [-20, 88] (clamped outside), relative error about 2e-7; see [`logistic`].
#[inline(always)]
fn portable_exp<T: Real>(t: T) -> T {
    const LOG2_E: f32 = std::f32::consts::LOG2_E;
    // ln 2 split in a high part with few mantissa bits (so n * LN2_HIGH is exact) and the rest.
    const LN2_HIGH: f32 = 0.693_359_4;
    const LN2_LOW: f32 = -2.121_944_4e-4;
    // Adding and subtracting 1.5 * 2^23 rounds to the nearest integer with one IEEE add each.
    const ROUNDER: f32 = 12_582_912.0;
    let c = T::splat;
    let t = t.clamp_to(-20.0, 88.0);
    let shifted = t * c(LOG2_E) + c(ROUNDER);
    let n = shifted - c(ROUNDER);
    let r = (t - n * c(LN2_HIGH)) - n * c(LN2_LOW);
    // exp(r) = 1 + r + r^2 (c0 + c1 r + .. + c5 r^5), the polynomial evaluated in Estrin's
    // scheme (pairs first, then powers of r^2) rather than Horner's: the same accuracy with a
    // shorter chain of dependent operations, which matters because every network layer waits
    // for its logistics.
    let r2 = r * r;
    let r4 = r2 * r2;
    let pair01 = c(0.5) + c(1.666_666_5e-1) * r;
    let pair23 = c(4.166_579_6e-2) + c(8.333_452e-3) * r;
    let pair45 = c(1.398_199_9e-3) + c(1.987_569_1e-4) * r;
    let poly = (pair01 + r2 * pair23) + r4 * pair45;
    let exp_r = (c(1.0) + r) + r2 * poly;
    // `shifted` is 1.5 * 2^23 + n, so its low mantissa bits hold n in two's complement; adding
    // the exponent bias and shifting gives the bits of 2^n without a float-to-int conversion,
    // which keeps the function branch-free and vectorisable. n lies in [-29, 127], so 2^n is a
    // normal number. A NaN t gives a NaN r and so a NaN result, whatever the scale bits are.
    let scale = shifted.bits_to_scale(ROUNDER.to_bits(), 127, 23);
    exp_r * scale
}

/// One CTRNN with its parameters decoded from a genome and its state.
///
/// Weights are stored row per receiving neuron, and each hidden row holds the input weights
/// followed by the recurrent weights, so one hidden neuron's net input is a single dot product
/// with the `presynaptic` buffer `[inputs | firing rates]`.
#[derive(Debug, Clone)]
pub struct Ctrnn {
    topology: CtrnnTopology,
    /// `n_hidden` rows of `n_inputs + n_hidden` weights: input weights, then recurrent weights.
    hidden_weights: Vec<f32>,
    /// theta, one per hidden neuron.
    hidden_biases: Vec<f32>,
    /// Time constants in seconds, one per hidden neuron.
    taus: Vec<f32>,
    /// 1 / tau, one per hidden neuron.
    inv_taus: Vec<f32>,
    /// `n_outputs` rows of `n_hidden` weights.
    output_weights: Vec<f32>,
    /// One bias per output.
    output_biases: Vec<f32>,
    /// Firing rates of the zero state, sigma(theta), copied in on reset.
    rest_firing: Vec<f32>,
    /// Hidden state y.
    state: Vec<f32>,
    /// Scratch: the current inputs followed by the current firing rates sigma(y + theta). The
    /// firing rates are computed once per step, after the state update, and serve both the
    /// outputs of this step and the recurrent term of the next.
    presynaptic: Vec<f32>,
    /// The time step `dt_over_taus` was computed for; NaN until the first step.
    cached_dt: f32,
    /// dt / tau for `cached_dt`, one per hidden neuron.
    dt_over_taus: Vec<f32>,
}

impl Ctrnn {
    /// Builds a network from a genome laid out as described in the module docs, with its state
    /// at zero. Genes outside [-10, 10] are accepted here (controller files reject them), but a
    /// very negative time-constant gene gives a time constant so small that Euler integration
    /// diverges.
    pub fn new(topology: CtrnnTopology, genes: &[f32]) -> Result<Self, CtrnnError> {
        if topology.n_hidden == 0 {
            return Err(CtrnnError::NoHiddenNeurons { topology });
        }
        if topology.n_outputs == 0 {
            return Err(CtrnnError::NoOutputs { topology });
        }
        let needed = topology.n_genes();
        if genes.len() != needed {
            return Err(CtrnnError::GenomeLength {
                found: genes.len(),
                needed,
                topology,
            });
        }
        if let Some((gene_idx, &value)) = genes.iter().enumerate().find(|(_, g)| !g.is_finite()) {
            return Err(CtrnnError::NonFiniteGene { gene_idx, value });
        }

        let layout = topology.layout();
        let n_inputs = topology.n_inputs;
        let n_hidden = topology.n_hidden;
        let input_weights = &genes[layout.input_weights];
        let recurrent_weights = &genes[layout.hidden_weights];
        let mut hidden_weights = Vec::with_capacity(n_hidden * (n_inputs + n_hidden));
        for hidden_idx in 0..n_hidden {
            let input_row = hidden_idx * n_inputs..(hidden_idx + 1) * n_inputs;
            let recurrent_row = hidden_idx * n_hidden..(hidden_idx + 1) * n_hidden;
            hidden_weights.extend_from_slice(&input_weights[input_row]);
            hidden_weights.extend_from_slice(&recurrent_weights[recurrent_row]);
        }
        let hidden_biases = genes[layout.hidden_biases].to_vec();
        let taus: Vec<f32> = genes[layout.tau_genes]
            .iter()
            .map(|&g| tau_from_gene(g))
            .collect();
        let inv_taus = taus.iter().map(|&tau| 1.0 / tau).collect();
        let rest_firing: Vec<f32> = hidden_biases.iter().map(|&theta| logistic(theta)).collect();
        let mut presynaptic = vec![0.0; n_inputs + n_hidden];
        presynaptic[n_inputs..].copy_from_slice(&rest_firing);

        Ok(Self {
            topology,
            hidden_weights,
            hidden_biases,
            taus,
            inv_taus,
            output_weights: genes[layout.output_weights].to_vec(),
            output_biases: genes[layout.output_biases].to_vec(),
            rest_firing,
            state: vec![0.0; n_hidden],
            presynaptic,
            cached_dt: f32::NAN,
            dt_over_taus: vec![0.0; n_hidden],
        })
    }

    /// The network's shape.
    pub fn topology(&self) -> CtrnnTopology {
        self.topology
    }

    /// The hidden state y, one value per hidden neuron.
    pub fn state(&self) -> &[f32] {
        &self.state
    }

    /// The time constants in seconds, one per hidden neuron.
    pub fn taus(&self) -> &[f32] {
        &self.taus
    }

    /// Sets the hidden state to zero, as at the start of a sample.
    pub fn reset(&mut self) {
        self.state.fill(0.0);
        let n_inputs = self.topology.n_inputs;
        let (inputs, firing) = self.presynaptic.split_at_mut(n_inputs);
        inputs.fill(0.0);
        firing.copy_from_slice(&self.rest_firing);
    }

    /// Advances the network by one Euler step of `dt` seconds with the given inputs and writes
    /// its outputs, each in [0, 1]. Never allocates.
    pub fn step(&mut self, inputs: &[f32], dt: f32, outputs: &mut [f32]) -> Result<(), CtrnnError> {
        let topology = self.topology;
        if inputs.len() != topology.n_inputs {
            return Err(CtrnnError::InputLength {
                found: inputs.len(),
                needed: topology.n_inputs,
                topology,
            });
        }
        if outputs.len() != topology.n_outputs {
            return Err(CtrnnError::OutputLength {
                found: outputs.len(),
                needed: topology.n_outputs,
                topology,
            });
        }
        if !(dt > 0.0 && dt.is_finite()) {
            return Err(CtrnnError::BadTimeStep { dt });
        }
        self.step_prechecked(inputs, dt, outputs);
        Ok(())
    }

    /// [`Ctrnn::step`] without the argument checks, for callers that sized their buffers from
    /// this network's topology and validated `dt` themselves. Wrong lengths cannot panic (every
    /// loop zips), they only give meaningless outputs.
    #[inline]
    pub(crate) fn step_prechecked(&mut self, inputs: &[f32], dt: f32, outputs: &mut [f32]) {
        if dt != self.cached_dt {
            for (dt_over_tau, &inv_tau) in self.dt_over_taus.iter_mut().zip(&self.inv_taus) {
                *dt_over_tau = dt * inv_tau;
            }
            self.cached_dt = dt;
        }

        let weights = StepWeights {
            n_inputs: self.topology.n_inputs,
            n_hidden: self.topology.n_hidden,
            hidden_weights: &self.hidden_weights,
            hidden_biases: &self.hidden_biases,
            dt_over_taus: &self.dt_over_taus,
            output_weights: &self.output_weights,
            output_biases: &self.output_biases,
        };
        euler_step(
            &weights,
            inputs,
            &mut self.presynaptic,
            &mut self.state,
            outputs,
        );
    }

    /// The parameters one step reads, with the step factors `dt_over_taus` (from
    /// [`Ctrnn::dt_over_taus`]), for a caller that keeps the state itself.
    pub(crate) fn step_weights<'a>(&'a self, dt_over_taus: &'a [f32]) -> StepWeights<'a> {
        StepWeights {
            n_inputs: self.topology.n_inputs,
            n_hidden: self.topology.n_hidden,
            hidden_weights: &self.hidden_weights,
            hidden_biases: &self.hidden_biases,
            dt_over_taus,
            output_weights: &self.output_weights,
            output_biases: &self.output_biases,
        }
    }

    /// dt / tau per hidden neuron, computed as [`Ctrnn::step`] computes it.
    pub(crate) fn dt_over_taus(&self, dt: f32) -> Vec<f32> {
        self.inv_taus.iter().map(|&inv_tau| dt * inv_tau).collect()
    }

    /// The firing rates of the zero state, sigma(theta), per hidden neuron.
    pub(crate) fn rest_firing(&self) -> &[f32] {
        &self.rest_firing
    }
}

/// What one network step reads: the weights, biases and step factors, borrowed from a
/// [`Ctrnn`], so the same step runs on the network's own state or on a lockstep state.
#[derive(Debug, Clone, Copy)]
pub(crate) struct StepWeights<'a> {
    n_inputs: usize,
    n_hidden: usize,
    hidden_weights: &'a [f32],
    hidden_biases: &'a [f32],
    dt_over_taus: &'a [f32],
    output_weights: &'a [f32],
    output_biases: &'a [f32],
}

impl<'a> StepWeights<'a> {
    /// Inputs per network.
    pub(crate) fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// Hidden neurons per network.
    pub(crate) fn n_hidden(&self) -> usize {
        self.n_hidden
    }

    /// The same weights for a network of exactly `n_inputs`, `n_hidden` and `n_outputs`, every
    /// slice cut to that shape's length (`None` if this network has another shape). Given
    /// constants, the compiler knows every loop's length in a step through the result.
    #[inline(always)]
    pub(crate) fn with_shape(
        &self,
        n_inputs: usize,
        n_hidden: usize,
        n_outputs: usize,
    ) -> Option<StepWeights<'a>> {
        if (self.n_inputs, self.n_hidden) != (n_inputs, n_hidden) {
            return None;
        }
        Some(StepWeights {
            n_inputs,
            n_hidden,
            hidden_weights: self
                .hidden_weights
                .get(..n_hidden * (n_inputs + n_hidden))?,
            hidden_biases: self.hidden_biases.get(..n_hidden)?,
            dt_over_taus: self.dt_over_taus.get(..n_hidden)?,
            output_weights: self.output_weights.get(..n_outputs * n_hidden)?,
            output_biases: self.output_biases.get(..n_outputs)?,
        })
    }
}

/// One forward-Euler step (see the module docs) on a state of any [`Real`]: `presynaptic` is
/// `[inputs | firing rates]` and `state` the hidden state, both updated; `outputs` written.
/// On `f32` this is the reference network; on lanes every lane performs the same operations.
#[inline(always)]
pub(crate) fn euler_step<T: Real>(
    weights: &StepWeights<'_>,
    inputs: &[T],
    presynaptic: &mut [T],
    state: &mut [T],
    outputs: &mut [T],
) {
    let n_inputs = weights.n_inputs;
    let row_len = n_inputs + weights.n_hidden;
    for (slot, &input) in presynaptic.iter_mut().zip(inputs) {
        *slot = input;
    }

    // Euler update of every hidden neuron. `presynaptic` still holds the firing rates of the
    // old state while this loop runs, so the order of neurons does not matter.
    let rows = weights.hidden_weights.chunks_exact(row_len);
    for ((y, row), &dt_over_tau) in state.iter_mut().zip(rows).zip(weights.dt_over_taus) {
        let net_input = dot(row, presynaptic);
        *y = *y + T::splat(dt_over_tau) * (net_input - *y);
    }

    // Firing rates of the new state, each computed once.
    let firing = &mut presynaptic[n_inputs.min(row_len)..];
    for ((rate, &y), &theta) in firing
        .iter_mut()
        .zip(state.iter())
        .zip(weights.hidden_biases)
    {
        *rate = logistic_of(y + T::splat(theta));
    }

    let firing = &presynaptic[n_inputs.min(row_len)..];
    let rows = weights.output_weights.chunks_exact(weights.n_hidden);
    for ((output, row), &bias) in outputs.iter_mut().zip(rows).zip(weights.output_biases) {
        *output = logistic_of(dot(row, firing) + T::splat(bias));
    }
}

/// Sum of element-wise products of two equally long slices.
///
/// Four independent partial sums (elements 0, 4, 8, .. in the first, 1, 5, 9, .. in the second,
/// and so on, the leftover tail separately) break the chain of dependent additions that makes a
/// plain left-to-right sum slow, and let the compiler use SIMD. The order of additions is fixed
/// by the code, so the result is still bit-reproducible.
#[inline(always)]
fn dot<T: Real>(weights: &[f32], values: &[T]) -> T {
    const LANES: usize = 4;
    let weight_chunks = weights.chunks_exact(LANES);
    let value_chunks = values.chunks_exact(LANES);
    let tail: T = weight_chunks
        .remainder()
        .iter()
        .zip(value_chunks.remainder())
        .fold(T::splat(0.0), |acc, (&w, &v)| acc + T::splat(w) * v);
    let mut partial_sums = [T::splat(0.0); LANES];
    for (weight_chunk, value_chunk) in weight_chunks.zip(value_chunks) {
        for lane in 0..LANES {
            partial_sums[lane] =
                partial_sums[lane] + T::splat(weight_chunk[lane]) * value_chunk[lane];
        }
    }
    ((partial_sums[0] + partial_sums[1]) + (partial_sums[2] + partial_sums[3])) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn gene_counts_of_the_papers_topologies() {
        assert_eq!(CtrnnTopology::new(4, 3, 2).n_genes(), 35);
        assert_eq!(CtrnnTopology::new(6, 10, 3).n_genes(), 213);
        // 40 + 100 + 10 + 10 + 20 + 2.
        assert_eq!(CtrnnTopology::new(4, 10, 2).n_genes(), 182);
        assert_eq!(CtrnnTopology::new(4, 10, 3).n_genes(), 193);
        assert_eq!(CtrnnTopology::new(5, 10, 3).n_genes(), 203);
        assert_eq!(CtrnnTopology::new(6, 10, 2).n_genes(), 202);
    }

    #[test]
    fn layout_groups_are_contiguous_and_in_order() {
        let layout = CtrnnTopology::new(4, 3, 2).layout();
        assert_eq!(layout.input_weights, 0..12);
        assert_eq!(layout.hidden_weights, 12..21);
        assert_eq!(layout.hidden_biases, 21..24);
        assert_eq!(layout.tau_genes, 24..27);
        assert_eq!(layout.output_weights, 27..33);
        assert_eq!(layout.output_biases, 33..35);
    }

    #[test]
    fn absurd_topology_saturates_instead_of_overflowing() {
        let topology = CtrnnTopology::new(usize::MAX, usize::MAX, 2);
        assert_eq!(topology.n_genes(), usize::MAX);
    }

    #[test]
    fn topology_displays_like_the_paper() {
        assert_eq!(CtrnnTopology::new(6, 10, 3).to_string(), "6-10-3");
    }

    #[test]
    fn tau_mapping_endpoints() {
        assert!((tau_from_gene(-10.0) - 0.1).abs() < 1e-7);
        assert!((tau_from_gene(10.0) - 31.622_776).abs() < 1e-4);
        // The middle of the exponential range: 10^0.25.
        assert!((tau_from_gene(0.0) - 1.778_279_4).abs() < 1e-5);
        assert!((tau_from_gene(-2.0) - 1.0).abs() < 1e-6);
        for step_idx in 0..=2000 {
            let gene = -10.0 + step_idx as f32 * 0.01;
            let exact = 10f64.powf(-1.0 + 2.5 * (gene as f64 + 10.0) / 20.0);
            let relative = ((tau_from_gene(gene) as f64 - exact) / exact).abs();
            assert!(relative < 1e-6, "gene {gene}: relative error {relative}");
        }
    }

    #[test]
    fn logistic_is_accurate_to_a_micro_relative() {
        let mut worst = 0.0f64;
        let mut x = -87.0f32;
        while x <= 30.0 {
            let exact = 1.0 / (1.0 + (-(x as f64)).exp());
            let relative = ((logistic(x) as f64 - exact) / exact).abs();
            worst = worst.max(relative);
            x += 0.001_3;
        }
        assert!(worst < 1e-6, "worst relative error {worst}");
        assert_eq!(logistic(0.0), 0.5);
        assert_eq!(logistic(100.0), 1.0);
        assert!(logistic(-1000.0) < 1e-37);
        assert!(logistic(f32::NAN).is_nan());
        assert_eq!(logistic(f32::INFINITY), 1.0);
    }

    /// The 1-2-1 network of the hand-computed test:
    /// input weights h0<-i0 = 2, h1<-i0 = -1; recurrent rows h0: [h0<-h0 = 0, h0<-h1 = 1],
    /// h1: [h1<-h0 = -2, h1<-h1 = 0.5]; theta = [0, 1]; tau genes [-2, -10] (tau 1 s and 0.1 s);
    /// output weights o0: [1, -1]; output bias -0.5.
    fn tiny_network() -> Ctrnn {
        let genes = [
            2.0, -1.0, 0.0, 1.0, -2.0, 0.5, 0.0, 1.0, -2.0, -10.0, 1.0, -1.0, -0.5,
        ];
        Ctrnn::new(CtrnnTopology::new(1, 2, 1), &genes).unwrap()
    }

    #[test]
    fn hand_computed_two_steps() {
        let mut net = tiny_network();
        let sigma = |x: f64| 1.0 / (1.0 + (-x).exp());
        let dt = 0.1;
        let mut out = [0.0f32];

        // Step 1, input 1. Old state y = [0, 0], so firing f = [sigma(0), sigma(1)]
        // = [0.5, 0.7310585786].
        // net0 = 2*1 + 0*0.5 + 1*0.7310585786 = 2.7310585786; dt/tau0 = 0.1/1 = 0.1;
        //   y0 = 0 + 0.1*(2.7310585786 - 0) = 0.27310585786.
        // net1 = -1*1 - 2*0.5 + 0.5*0.7310585786 = -1.6344707107; dt/tau1 = 0.1/0.1 = 1;
        //   y1 = 0 + 1*(-1.6344707107 - 0) = -1.6344707107.
        // New firing f' = [sigma(0.27310585786), sigma(-1.6344707107 + 1)]
        //   = [0.5678552291, 0.3464975100].
        // Output = sigma(1*0.5678552291 - 1*0.3464975100 - 0.5) = sigma(-0.2786422810)
        //   = 0.4307866704.
        net.step(&[1.0], dt, &mut out).unwrap();
        assert!((net.state()[0] - 0.273_105_86).abs() < 1e-6);
        assert!((net.state()[1] - -1.634_470_7).abs() < 1e-6);
        assert!((out[0] as f64 - sigma(-0.278_642_281)).abs() < 1e-6);
        assert!((out[0] - 0.430_786_67).abs() < 1e-6);

        // Step 2, input 0. Firing of the old state f = [0.5678552291, 0.3464975100].
        // net0 = 2*0 + 0*0.5678552291 + 1*0.3464975100 = 0.3464975100;
        //   y0 = 0.27310585786 + 0.1*(0.3464975100 - 0.27310585786) = 0.2804450231.
        // net1 = -1*0 - 2*0.5678552291 + 0.5*0.3464975100 = -0.9624617031;
        //   y1 = -1.6344707107 + 1*(-0.9624617031 + 1.6344707107) = -0.9624617031.
        // New firing f' = [sigma(0.2804450231), sigma(0.0375382969)] = [0.5696553239, 0.5093834724].
        // Output = sigma(0.5696553239 - 0.5093834724 - 0.5) = sigma(-0.4397281485) = 0.3918057479.
        net.step(&[0.0], dt, &mut out).unwrap();
        assert!((net.state()[0] - 0.280_445).abs() < 1e-6);
        assert!((net.state()[1] - -0.962_461_7).abs() < 1e-6);
        assert!((out[0] - 0.391_805_75).abs() < 1e-6);
    }

    #[test]
    fn reset_behaves_like_a_fresh_network() {
        let mut used = tiny_network();
        let mut out = [0.0f32];
        for step_idx in 0..50 {
            used.step(&[(step_idx % 3) as f32 * 0.5], 0.1, &mut out)
                .unwrap();
        }
        used.reset();
        let mut fresh = tiny_network();
        let mut fresh_out = [0.0f32];
        for step_idx in 0..20 {
            let input = [(step_idx % 4) as f32 * 0.25];
            used.step(&input, 0.1, &mut out).unwrap();
            fresh.step(&input, 0.1, &mut fresh_out).unwrap();
            assert_eq!(out[0].to_bits(), fresh_out[0].to_bits(), "step {step_idx}");
        }
        assert_eq!(used.state(), fresh.state());
    }

    #[test]
    fn changing_dt_recomputes_the_step_factors() {
        let mut a = tiny_network();
        let mut b = tiny_network();
        let mut out_a = [0.0f32];
        let mut out_b = [0.0f32];
        a.step(&[1.0], 0.1, &mut out_a).unwrap();
        a.step(&[1.0], 0.05, &mut out_a).unwrap();
        b.step(&[1.0], 0.1, &mut out_b).unwrap();
        b.step(&[1.0], 0.1, &mut out_b).unwrap();
        assert_ne!(a.state(), b.state());
        // Going back to the first dt must give the factors of that dt again.
        let mut c = tiny_network();
        let mut out_c = [0.0f32];
        c.step(&[1.0], 0.05, &mut out_c).unwrap();
        c.step(&[1.0], 0.1, &mut out_c).unwrap();
        let mut d = tiny_network();
        let mut out_d = [0.0f32];
        d.step(&[1.0], 0.05, &mut out_d).unwrap();
        d.dt_over_taus.fill(0.0);
        d.cached_dt = f32::NAN;
        d.step(&[1.0], 0.1, &mut out_d).unwrap();
        assert_eq!(c.state(), d.state());
    }

    #[test]
    fn construction_errors_name_the_problem() {
        let topology = CtrnnTopology::new(4, 3, 2);
        let err = Ctrnn::new(topology, &[0.0; 34]).unwrap_err();
        assert_eq!(
            err,
            CtrnnError::GenomeLength {
                found: 34,
                needed: 35,
                topology
            }
        );
        assert_eq!(
            err.to_string(),
            "genome has 34 genes, topology 4-3-2 needs 35"
        );

        let mut genes = [0.0f32; 35];
        genes[17] = f32::NAN;
        let err = Ctrnn::new(topology, &genes).unwrap_err();
        assert!(matches!(
            err,
            CtrnnError::NonFiniteGene { gene_idx: 17, .. }
        ));
        assert_eq!(err.to_string(), "gene 17 is not finite (NaN)");

        let empty = CtrnnTopology::new(4, 0, 2);
        assert!(matches!(
            Ctrnn::new(empty, &vec![0.0; empty.n_genes()]),
            Err(CtrnnError::NoHiddenNeurons { .. })
        ));
        let mute = CtrnnTopology::new(4, 2, 0);
        assert!(matches!(
            Ctrnn::new(mute, &vec![0.0; mute.n_genes()]),
            Err(CtrnnError::NoOutputs { .. })
        ));
    }

    #[test]
    fn step_errors_instead_of_panicking() {
        let mut net = tiny_network();
        let mut out = [0.0f32];
        assert!(matches!(
            net.step(&[1.0, 2.0], 0.1, &mut out),
            Err(CtrnnError::InputLength {
                found: 2,
                needed: 1,
                ..
            })
        ));
        assert!(matches!(
            net.step(&[1.0], 0.1, &mut [0.0; 3]),
            Err(CtrnnError::OutputLength {
                found: 3,
                needed: 1,
                ..
            })
        ));
        for dt in [0.0, -0.1, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                net.step(&[1.0], dt, &mut out),
                Err(CtrnnError::BadTimeStep { .. })
            ));
        }
        // A rejected step leaves the state untouched.
        assert_eq!(net.state(), &[0.0, 0.0]);
    }

    proptest! {
        #[test]
        fn state_stays_finite_and_outputs_in_unit_range(
            genes in proptest::collection::vec(GENE_MIN..=GENE_MAX, 213),
            input_seed in any::<u64>(),
        ) {
            let mut net = Ctrnn::new(CtrnnTopology::new(6, 10, 3), &genes).unwrap();
            let mut inputs = [0.0f32; 6];
            let mut outputs = [0.0f32; 3];
            let mut bits = input_seed;
            for _ in 0..2000 {
                for input in &mut inputs {
                    bits = crate::math::rng::mix64(bits);
                    *input = (bits >> 40) as f32 / (1u64 << 24) as f32;
                }
                net.step(&inputs, 0.1, &mut outputs).unwrap();
                prop_assert!(net.state().iter().all(|y| y.is_finite()));
                prop_assert!(outputs.iter().all(|o| (0.0..=1.0).contains(o)));
            }
        }
    }
}
