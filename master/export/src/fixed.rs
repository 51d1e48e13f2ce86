//! The fixed-point target: the model in integers for a core without FPU (the e-puck1's
//! dsPIC30F6014A), and the logistic as a table. Values (inputs, states, firing rates, outputs,
//! gains) are Q16 (`HEVO_ONE` = 65536 is 1.0), weights and biases Q11 in 16 bits (genes lie in
//! [-10, 10], so ±20480), the step factors dt/tau Q30, the IR table's means Q4. The table
//! holds the logistic at [`SIGMOID_ENTRIES`] + 1 points over [-16, 16] (1/32 apart), read with
//! linear interpolation; [`sigmoid_fixed`] is the C function's twin, so its largest error can
//! be measured here over every Q16 input rather than estimated.

use std::fmt::Write as _;

use crate::ExportError;
use crate::Target;
use crate::csource::{c_array, input_indices, model_preamble, node_table};
use crate::model::ExportModel;

/// Q16: one in values.
pub const ONE: i32 = 1 << 16;
/// Q11: one in weights and biases.
pub const WEIGHT_ONE: f32 = 2048.0;
/// Q30: one in the step factors.
pub const STEP_ONE: f64 = (1u32 << 30) as f64;
/// Intervals of the sigmoid table.
pub const SIGMOID_ENTRIES: usize = 1024;
/// The table covers [-SIGMOID_RANGE, SIGMOID_RANGE].
pub const SIGMOID_RANGE: i32 = 16;
/// log2 of a table interval in Q16 (32 / 1024 = 1/32, 2048 in Q16).
pub const SIGMOID_STEP_BITS: u32 = 11;

const _: () = assert!(
    (2 * SIGMOID_RANGE * ONE) as usize == SIGMOID_ENTRIES << SIGMOID_STEP_BITS,
    "the table's intervals tile its range"
);

/// The fixed target's types in the header.
pub const TYPES: &str = "\
/* The fixed target (e-puck1, dsPIC30F6014A: no FPU): integers only. Values (network inputs,
 * states, firing rates, outputs, IR gains) are Q16: HEVO_ONE is 1.0. Weights and biases are
 * Q11 in 16 bits. Raw readings are the ADC's integers. Needs arithmetic right shifts of
 * negative numbers (every C compiler for these cores has them). */
#define HEVO_TARGET_FIXED 1
#define HEVO_ONE 65536L
typedef int32_t hevo_value;   /* Q16 */
typedef int16_t hevo_weight;  /* Q11 */
typedef int16_t hevo_raw;     /* raw sensor readings, ADC units */
typedef int32_t hevo_ir_mean; /* the IR table's mean raw readings, Q4 (raw * 16) */

typedef struct {
    hevo_value left, right;          /* the active primitive's outputs, Q16 in [0, HEVO_ONE] */
    int16_t left_steps, right_steps; /* (2 output - 1) v_max in motor steps per second,
                                        rounded: e_set_speed_left / e_set_speed_right */
} hevo_wheel_outputs;";

/// The fixed target's declarations of the sigmoid table.
pub const MODEL_DECLS: &str = "\
/* The logistic at -RANGE + k / 32, k = 0 .. ENTRIES, Q16. */
#define HEVO_SIGMOID_RANGE 16
#define HEVO_SIGMOID_ENTRIES 1024
#define HEVO_SIGMOID_STEP_BITS 11
extern const int32_t hevo_sigmoid_table[HEVO_SIGMOID_ENTRIES + 1];";

/// The sigmoid table: the logistic at -16 + k/32, rounded to Q16.
pub fn sigmoid_table() -> Vec<i32> {
    (0..=SIGMOID_ENTRIES)
        .map(|k| {
            let x = -f64::from(SIGMOID_RANGE)
                + k as f64 * f64::from(2 * SIGMOID_RANGE) / SIGMOID_ENTRIES as f64;
            (f64::from(ONE) / (1.0 + (-x).exp())).round() as i32
        })
        .collect()
}

/// The C `logistic` of the fixed target, on a Q16 input.
pub fn sigmoid_fixed(x: i32, table: &[i32]) -> i32 {
    let low = -SIGMOID_RANGE * ONE;
    if x <= low {
        return table[0];
    }
    if x >= SIGMOID_RANGE * ONE {
        return table[SIGMOID_ENTRIES];
    }
    let offset = x - low;
    let index = (offset >> SIGMOID_STEP_BITS) as usize;
    let fraction = offset & ((1 << SIGMOID_STEP_BITS) - 1);
    let (below, above) = (table[index], table[index + 1]);
    below + (((above - below) * fraction + (1 << (SIGMOID_STEP_BITS - 1))) >> SIGMOID_STEP_BITS)
}

/// The largest error of [`sigmoid_fixed`] against the exact logistic of its input, over every
/// Q16 input in [-20, 20] (beyond, both saturate further).
pub fn sigmoid_error(table: &[i32]) -> f64 {
    let mut worst = 0.0f64;
    for x in -20 * ONE..=20 * ONE {
        let exact = 1.0 / (1.0 + (-(f64::from(x) / f64::from(ONE))).exp());
        let got = f64::from(sigmoid_fixed(x, table)) / f64::from(ONE);
        worst = worst.max((got - exact).abs());
    }
    worst
}

/// A weight or bias in Q11.
fn weight(value: f32) -> Result<i16, ExportError> {
    let scaled = (value * WEIGHT_ONE).round();
    if !(f32::from(i16::MIN)..=f32::from(i16::MAX)).contains(&scaled) {
        return Err(ExportError::Unsupported(format!(
            "the weight {value} does not fit Q11 in 16 bits (|w| < 16)"
        )));
    }
    Ok(scaled as i16)
}

/// The model converted, ready to emit.
#[derive(Debug)]
pub struct FixedModel<'m> {
    model: &'m ExportModel,
    table: Vec<i32>,
    /// The sigmoid table's largest error against the exact logistic.
    pub sigmoid_error: f64,
}

impl<'m> FixedModel<'m> {
    /// Converts `model`, refusing what does not fit the formats.
    pub fn new(model: &'m ExportModel) -> Result<FixedModel<'m>, ExportError> {
        for node in &model.nodes {
            for &factor in &node.dt_over_tau {
                if !(0.0..1.99).contains(&factor) {
                    return Err(ExportError::Unsupported(format!(
                        "{}: the step factor dt/tau = {factor} is outside [0, 1.99] (Q30)",
                        node.path
                    )));
                }
            }
            for &w in node.hidden_weights.iter().chain(&node.output_weights) {
                weight(w)?;
            }
            for &b in node.hidden_biases.iter().chain(&node.output_biases) {
                weight(b)?;
            }
        }
        let table = sigmoid_table();
        let sigmoid_error = sigmoid_error(&table);
        Ok(FixedModel {
            model,
            table,
            sigmoid_error,
        })
    }

    /// The fixed target's `hevo_model.c`.
    pub fn model_c(&self) -> String {
        let model = self.model;
        let mut text = model_preamble(model, Target::Fixed);
        text.push_str(&input_indices(model));
        // Checked in `new`.
        let q11 = |v: &f32| weight(*v).unwrap_or(0).to_string();
        for (idx, node) in model.nodes.iter().enumerate() {
            for (what, values) in [
                ("hidden_weights", &node.hidden_weights),
                ("hidden_biases", &node.hidden_biases),
                ("output_weights", &node.output_weights),
                ("output_biases", &node.output_biases),
            ] {
                text.push_str(&c_array(
                    &format!("static const int16_t node{idx}_{what}[]"),
                    values,
                    q11,
                ));
            }
            text.push_str(&c_array(
                &format!("static const int32_t node{idx}_dt_over_tau[]"),
                &node.dt_over_tau,
                |v| format!("{}", (f64::from(*v) * STEP_ONE).round() as i64),
            ));
            // The rest firing rates as the C logistic computes them from the Q11 biases.
            let rest: Vec<i32> = node
                .hidden_biases
                .iter()
                .map(|&theta| {
                    sigmoid_fixed(i32::from(weight(theta).unwrap_or(0)) << 5, &self.table)
                })
                .collect();
            text.push_str(&c_array(
                &format!("static const int32_t node{idx}_rest_firing[]"),
                &rest,
                |v| v.to_string(),
            ));
        }
        text.push('\n');
        text.push_str(&node_table(model));
        text.push_str(&c_array(
            "const hevo_ir_mean hevo_ir_means[HEVO_IR_GRID]",
            &model.ir.means,
            |m| format!("{}", (m * 16.0).round() as i32),
        ));
        // Only the number of grid points is read: distances are counted in grid steps.
        let _ = writeln!(
            text,
            "const hevo_value hevo_ir_step = {}, hevo_ir_max_distance = {};",
            (f64::from(model.ir.step) * f64::from(ONE)).round() as i64,
            (f64::from(model.ir.max_distance) * f64::from(ONE)).round() as i64
        );
        // An integer reading r is below a threshold t exactly when r < ceil(t).
        text.push_str(&c_array(
            "const hevo_raw hevo_light_threshold[HEVO_N_LIGHT]",
            &model.light_threshold,
            |t| {
                format!(
                    "{}",
                    t.ceil().clamp(f32::from(i16::MIN), f32::from(i16::MAX)) as i32
                )
            },
        ));
        text.push_str(&c_array(
            "const int32_t hevo_sigmoid_table[HEVO_SIGMOID_ENTRIES + 1]",
            &self.table,
            |v| v.to_string(),
        ));
        text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sigmoid_table_is_accurate_to_three_hundred_thousandths() {
        let table = sigmoid_table();
        assert_eq!(table[SIGMOID_ENTRIES / 2], ONE / 2);
        assert_eq!(table[SIGMOID_ENTRIES], ONE);
        assert_eq!(table[0], 0);
        let error = sigmoid_error(&table);
        assert!(error < 3e-5, "largest error {error}");
        assert!(
            error > 1e-6,
            "an error of {error} is implausibly small for Q16"
        );
        // Monotone: a larger input never gives a smaller output.
        let mut previous = sigmoid_fixed(-20 * ONE, &table);
        for x in -20 * ONE..20 * ONE {
            let value = sigmoid_fixed(x, &table);
            assert!(value >= previous, "at {x}");
            previous = value;
        }
    }

    #[test]
    fn weights_round_to_q11_and_refuse_what_does_not_fit() {
        assert_eq!(weight(10.0).unwrap(), 20480);
        assert_eq!(weight(-10.0).unwrap(), -20480);
        assert_eq!(weight(0.25).unwrap(), 512);
        assert!(weight(16.0).is_err());
    }
}
