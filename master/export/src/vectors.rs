//! Test vectors: cycles recorded from sim-core's own evaluation of the controller (the network
//! inputs of the frame, every node's outputs, the active path, the wheels), with raw readings
//! that sim-core's sensor model maps to exactly those inputs, in a little binary file the C
//! harness (`check.c`) reads.
//!
//! sim-core does not keep the raw readings it draws, so they are recovered from the inputs:
//! an IR input is a monotone function of the raw reading (the average-table inverse, times
//! the sample's gain, clamped), so a bisection over the readings' bits finds one that sim-core's
//! `IrModel::map_raw` maps to the recorded input bit for bit; a light input is the flash
//! detector's held output, so detections are placed where the held runs start (and re-armed
//! where a run outlasts one hold), and sim-core's `FlashDetector` is run over the result to
//! check it gives the recorded inputs. Both are checked here, so a vector that exists is exact.

use hevo_sim_core::MEAN_IR_CURVE;
use hevo_sim_core::SensorFrame;
use hevo_sim_core::wheel_speed;
use hevo_sim_core::{Controller, ControllerFile};
use hevo_sim_core::{Evaluator, Outcome, Policy, Sample, TaskConfig};
use hevo_sim_core::{FlashDetector, IrMapping, IrModel, N_IR, N_LIGHT};
use hevo_sim_core::{Stream, stream_rng};

use crate::ExportError;
use crate::model::{EXPORTED_INPUTS, ExportModel};

/// The vectors' file name in the export directory.
pub const FILE_NAME: &str = "vectors.bin";
/// First word of the file: "HEVV" little-endian.
pub const MAGIC: u32 = u32::from_le_bytes(*b"HEVV");
/// The file format's version.
pub const VERSION: u32 = 1;

/// One cycle's raw readings, as `hevo_raw_inputs` holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawInputs {
    /// Raw proximity readings, IR input order.
    pub ir: [f32; N_IR],
    /// Raw ambient readings, left and right.
    pub light: [f32; N_LIGHT],
    /// The near-robot flag.
    pub near_robot: bool,
}

/// One recorded cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct Cycle {
    /// Raw readings that give `inputs`.
    pub raw: RawInputs,
    /// The network inputs sim-core's sensors gave, as far as the C holds them (ir, light,
    /// near_robot: the frame's first groups).
    pub inputs: [f32; EXPORTED_INPUTS],
    /// Every node's outputs after the cycle (0 for nodes reset or never stepped), node after
    /// node.
    pub outputs: Vec<f32>,
    /// Node indices from the root to the primitive that drove.
    pub path: Vec<u16>,
    /// The wheel outputs, in [0, 1].
    pub wheels: [f32; 2],
}

/// One recorded sample.
#[derive(Debug, Clone)]
pub struct RecordedSample {
    /// The sample.
    pub sample: Sample,
    /// Per IR sensor, `1 + offset`: the sample's fixed offset noise as a gain.
    pub ir_gain: [f32; N_IR],
    /// Its cycles.
    pub cycles: Vec<Cycle>,
    /// sim-core's outcome.
    pub outcome: Outcome,
}

/// What a vectors file holds, for the README and the command's output.
#[derive(Debug, Clone, Default)]
pub struct VectorSummary {
    /// Per sample: seed, variant, cycles, solved.
    pub samples: Vec<(u64, Option<u32>, usize, bool)>,
    /// Cycles over all samples.
    pub n_cycles: usize,
}

/// A sample's IR gains, `1 + offset`, drawn as sim-core's IR sensor draws them: first from the
/// sample's sensor-setup stream (the IR sensor is the registry's first).
pub fn ir_gains(task: &TaskConfig, seed: u64) -> [f32; N_IR] {
    let setup = task
        .params
        .ir
        .draw_setup(&mut stream_rng(seed, Stream::SensorSetup));
    setup.offset.map(|offset| 1.0 + offset)
}

/// A raw proximity reading that sim-core maps, with `gain`, to exactly `input`; `None` if
/// there is none (an input sim-core cannot give).
pub fn ir_raw_for(input: f32, gain: f32) -> Option<f32> {
    let model = IrModel::builtin();
    let reading = |raw: f32| {
        (model.map_raw(MEAN_IR_CURVE, raw, IrMapping::AverageTable) * gain).clamp(0.0, 1.0)
    };
    let (means, _, _) = model.inverse_table();
    // Non-negative floats order like their bits, and the reading does not decrease with the
    // raw value: find the smallest raw whose reading reaches the input.
    let (mut low, mut high) = (0u32, means.first()?.to_bits());
    // NaN compares false: no reading reaches it.
    if reading(f32::from_bits(high))
        .partial_cmp(&input)
        .is_none_or(|o| o.is_lt())
    {
        return None;
    }
    while low < high {
        let middle = low + (high - low) / 2;
        if reading(f32::from_bits(middle)) >= input {
            high = middle;
        } else {
            low = middle + 1;
        }
    }
    let raw = f32::from_bits(low);
    (reading(raw).to_bits() == input.to_bits()).then_some(raw)
}

/// Raw ambient readings (per cycle, one side) that the flash detector turns into `held`:
/// `flash` where a detection is needed, `dark` elsewhere.
fn light_raw_for(held: &[f32], hold: u32, flash: f32, dark: f32) -> Vec<f32> {
    let mut raw = vec![dark; held.len()];
    let hold = hold as usize;
    let mut start = 0;
    while start < held.len() {
        if held[start] != 1.0 || hold == 0 {
            start += 1;
            continue;
        }
        let mut end = start;
        while end + 1 < held.len() && held[end + 1] == 1.0 {
            end += 1;
        }
        // A detection holds the input for `hold` cycles from its own; a run that ends before
        // the trace does ended `hold` cycles after its last detection.
        let last = if end + 1 < held.len() {
            (end + 1).saturating_sub(hold).max(start)
        } else {
            end
        };
        let mut detection = start;
        while detection < last {
            raw[detection] = flash;
            detection += hold;
        }
        raw[last] = flash;
        start = end + 1;
    }
    raw
}

/// The controller, recording each cycle.
struct Recording {
    controller: Controller,
    cycles: Vec<Cycle>,
}

impl Policy for Recording {
    fn reset(&mut self) {
        self.controller.reset();
        self.cycles.clear();
    }

    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let wheels = self.controller.step(frame, dt);
        let outputs = (0..self.controller.n_nodes())
            .flat_map(|node| self.controller.last_outputs(node).unwrap_or_default())
            .copied()
            .collect();
        self.cycles.push(Cycle {
            raw: RawInputs {
                ir: [0.0; N_IR],
                light: [0.0; N_LIGHT],
                near_robot: false,
            },
            inputs: std::array::from_fn(|input| frame.inputs[input]),
            outputs,
            path: self
                .controller
                .active_path()
                .iter()
                .map(|&n| n as u16)
                .collect(),
            wheels: [wheels.left, wheels.right],
        });
        [wheels.left, wheels.right]
    }

    fn root_choice(&self) -> Option<usize> {
        self.controller.root_choice()
    }

    fn active_path(&self) -> &[usize] {
        self.controller.active_path()
    }

    fn n_nodes(&self) -> usize {
        self.controller.n_nodes()
    }

    fn root_child_index(&self, name: &str) -> Option<usize> {
        self.controller.root_child_index(name)
    }
}

/// Evaluates the controller on each sample with sim-core and records every cycle, with raw
/// readings recovered and checked (see the module docs).
pub fn record(
    file: &ControllerFile,
    task: &TaskConfig,
    model: &ExportModel,
    samples: &[Sample],
) -> Result<Vec<RecordedSample>, ExportError> {
    let evaluator =
        Evaluator::new(task.clone()).map_err(|err| ExportError::Task(err.to_string()))?;
    let mut policy = Recording {
        controller: Controller::new(file, None)?,
        cycles: Vec::new(),
    };
    let mut recorded = Vec::with_capacity(samples.len());
    for &sample in samples {
        let outcome = evaluator.evaluate(&mut policy, sample);
        let mut cycles = std::mem::take(&mut policy.cycles);
        let ir_gain = ir_gains(task, sample.seed);
        fill_raw(model, &ir_gain, &mut cycles).map_err(|problem| {
            ExportError::Vectors(format!("sample seed {}: {problem}", sample.seed))
        })?;
        recorded.push(RecordedSample {
            sample,
            ir_gain,
            cycles,
            outcome,
        });
    }
    Ok(recorded)
}

/// Fills each cycle's raw readings from its inputs and checks them against sim-core's model.
fn fill_raw(
    model: &ExportModel,
    ir_gain: &[f32; N_IR],
    cycles: &mut [Cycle],
) -> Result<(), String> {
    let [ir_live, light_live, near_live] = model.live;
    for (cycle_idx, cycle) in cycles.iter_mut().enumerate() {
        for (sensor, &gain) in ir_gain.iter().enumerate() {
            let input = cycle.inputs[sensor];
            cycle.raw.ir[sensor] = if ir_live {
                ir_raw_for(input, gain).ok_or_else(|| {
                    format!("cycle {cycle_idx}: no raw reading gives IR input {sensor} = {input:e}")
                })?
            } else {
                0.0
            };
        }
        cycle.raw.near_robot = near_live && cycle.inputs[N_IR + N_LIGHT] == 1.0;
    }
    for side in 0..N_LIGHT {
        let held: Vec<f32> = cycles.iter().map(|c| c.inputs[N_IR + side]).collect();
        let flash = model.light_threshold[side] - 1.0;
        let dark = model.light_dark[side].max(model.light_threshold[side]);
        let raw = if light_live {
            light_raw_for(&held, model.light_hold, flash, dark)
        } else {
            vec![dark; held.len()]
        };
        for (cycle, &raw) in cycles.iter_mut().zip(&raw) {
            cycle.raw.light[side] = raw;
        }
    }
    if light_live {
        let mut detector = FlashDetector::new(model.light_threshold, model.light_hold);
        for (cycle_idx, cycle) in cycles.iter().enumerate() {
            let held = detector.update(cycle.raw.light);
            if held[..] != cycle.inputs[N_IR..N_IR + N_LIGHT] {
                return Err(format!(
                    "cycle {cycle_idx}: the recovered light readings give {held:?}, sim-core \
                     read {:?}",
                    &cycle.inputs[N_IR..N_IR + N_LIGHT]
                ));
            }
        }
    }
    Ok(())
}

/// Little-endian 32-bit words.
#[derive(Default)]
struct Words(Vec<u8>);

impl Words {
    fn u32(&mut self, value: u32) {
        self.0.extend_from_slice(&value.to_le_bytes());
    }

    fn f32(&mut self, value: f32) {
        self.u32(value.to_bits());
    }
}

/// The vectors file (all words little-endian u32; floats as their bits):
///
/// ```text
/// header: MAGIC, VERSION, n_samples, n_nodes, n_outputs_total, max_path
/// per sample: seed low, seed high, variant (0xffffffff: drawn), n_cycles, ir_gain[4]
///   per cycle: raw ir[4], raw light[2], near_robot (0/1), inputs[7], outputs[n_outputs_total],
///              path_len, path[max_path] (unused slots 0), wheels[2], wheel speeds m/s[2]
/// ```
pub fn encode(model: &ExportModel, recorded: &[RecordedSample]) -> (Vec<u8>, VectorSummary) {
    let mut words = Words::default();
    let max_path = model.max_path();
    let mut summary = VectorSummary::default();
    for value in [
        MAGIC,
        VERSION,
        recorded.len() as u32,
        model.nodes.len() as u32,
        model.n_outputs_total() as u32,
        max_path as u32,
    ] {
        words.u32(value);
    }
    for sample in recorded {
        let seed = sample.sample.seed;
        words.u32(seed as u32);
        words.u32((seed >> 32) as u32);
        words.u32(sample.sample.variant.unwrap_or(u32::MAX));
        words.u32(sample.cycles.len() as u32);
        sample.ir_gain.iter().for_each(|&g| words.f32(g));
        for cycle in &sample.cycles {
            cycle.raw.ir.iter().for_each(|&v| words.f32(v));
            cycle.raw.light.iter().for_each(|&v| words.f32(v));
            words.u32(u32::from(cycle.raw.near_robot));
            cycle.inputs.iter().for_each(|&v| words.f32(v));
            cycle.outputs.iter().for_each(|&v| words.f32(v));
            words.u32(cycle.path.len() as u32);
            for slot in 0..max_path {
                words.u32(cycle.path.get(slot).map_or(0, |&n| u32::from(n)));
            }
            cycle.wheels.iter().for_each(|&v| words.f32(v));
            cycle
                .wheels
                .iter()
                .for_each(|&v| words.f32(wheel_speed(v, model.v_max)));
        }
        summary.samples.push((
            seed,
            sample.sample.variant,
            sample.cycles.len(),
            sample.outcome.solved,
        ));
        summary.n_cycles += sample.cycles.len();
    }
    (words.0, summary)
}

/// The samples the vectors record by default: `per_variant` seeds (from 1) of every variant.
pub fn default_samples(task: &TaskConfig, per_variant: u32) -> Vec<Sample> {
    let n_variants = task.scenario.n_variants();
    (0..n_variants)
        .flat_map(|variant| {
            (0..per_variant).map(move |k| Sample {
                seed: 1 + u64::from(variant) * u64::from(per_variant) + u64::from(k),
                variant: (n_variants > 1).then_some(variant),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_runs_are_reproduced_by_the_detector() {
        let hold = 3;
        let cases: &[&[u8]] = &[
            &[0, 1, 1, 1, 0, 0],
            &[1, 1, 1, 1, 1, 0, 1, 1, 1],
            &[0, 1, 1, 1, 1, 1, 1, 1, 0],
            &[1, 1],
            &[0, 0, 0],
        ];
        for held in cases {
            let held: Vec<f32> = held.iter().map(|&b| f32::from(b)).collect();
            let raw = light_raw_for(&held, hold, 1.0, 10.0);
            let mut detector = FlashDetector::new([5.0, 5.0], hold);
            let got: Vec<f32> = raw.iter().map(|&r| detector.update([r, 10.0])[0]).collect();
            assert_eq!(got, held, "raw {raw:?}");
        }
    }

    #[test]
    fn ir_inputs_are_found_again_from_raw_readings() {
        let model = IrModel::builtin();
        let (means, _, _) = model.inverse_table();
        let mut found = 0;
        for gain in [1.0f32, 1.0 + 0.049, 1.0 - 0.031] {
            for step in 0..=400 {
                let raw = means[means.len() - 1]
                    + (means[0] - means[means.len() - 1]) * step as f32 / 400.0;
                let input = (model.map_raw(MEAN_IR_CURVE, raw, IrMapping::AverageTable) * gain)
                    .clamp(0.0, 1.0);
                let again =
                    ir_raw_for(input, gain).expect("an input sim-core gave has a raw reading");
                let back = (model.map_raw(MEAN_IR_CURVE, again, IrMapping::AverageTable) * gain)
                    .clamp(0.0, 1.0);
                assert_eq!(back.to_bits(), input.to_bits());
                found += 1;
            }
        }
        assert_eq!(found, 3 * 401);
        // An input above the gain's ceiling has none.
        assert_eq!(ir_raw_for(1.0, 0.9), None);
    }
}
