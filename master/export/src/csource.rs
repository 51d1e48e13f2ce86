//! The C files of an export: the header and Makefile filled in from their templates in `c/`,
//! the runtime (`hevo.c`: the target's arithmetic, `c/arith_float.c` or `c/arith_fixed.c`,
//! followed by the controller both share, `c/runtime.c`), the
//! model as constant data (`hevo_model.c`, generated here), the harness and the closed-loop
//! program, and the README. Templates mark their blanks `{{NAME}}`; [`fill`] refuses to leave
//! one empty.

use std::fmt::Write as _;

use crate::model::ExportModel;
use crate::vectors::VectorSummary;
use crate::{ExportError, ExportOptions, Target, fixed};

const HEADER_TEMPLATE: &str = include_str!("../c/hevo.h.in");
const MAKEFILE_TEMPLATE: &str = include_str!("../c/Makefile.in");
const README_TEMPLATE: &str = include_str!("../c/README.md.in");
const FLOAT_ARITHMETIC: &str = include_str!("../c/arith_float.c");
const FIXED_ARITHMETIC: &str = include_str!("../c/arith_fixed.c");
const RUNTIME: &str = include_str!("../c/runtime.c");
const CHECK_HARNESS: &str = include_str!("../c/check.c");
const LOOP_PROGRAM: &str = include_str!("../c/loop.c");
const QEMU_RULES: &str = include_str!("../c/qemu.mk");
const QEMU_STARTUP: &str = include_str!("../c/qemu_startup.c");
const QEMU_LINKER_SCRIPT: &str = include_str!("../c/qemu.ld");

/// The e-puck's wheel: 41 mm across, 1000 motor steps per turn.
pub const WHEEL_DIAMETER_M: f64 = 0.041;
/// Motor steps per wheel turn.
pub const STEPS_PER_TURN: f64 = 1000.0;

/// Motor steps per metre of wheel travel.
pub fn steps_per_metre() -> f64 {
    STEPS_PER_TURN / (std::f64::consts::PI * WHEEL_DIAMETER_M)
}

/// The float target's types in the header.
const FLOAT_TYPES: &str = "\
/* The float target (e-puck2, Cortex-M4F): IEEE single precision throughout. Compiled with
 * -ffp-contract=off (no fused multiply-add), every value is sim-core's bit for bit. */
#define HEVO_TARGET_FIXED 0
typedef float hevo_value;   /* network inputs, states, outputs, IR gains */
typedef float hevo_weight;  /* network parameters */
typedef float hevo_raw;     /* raw sensor readings */
typedef float hevo_ir_mean; /* the IR table's mean raw readings */
#define HEVO_STEPS_PER_METRE {{STEPS_PER_METRE}}

typedef struct {
    hevo_value left, right;          /* the active primitive's outputs, [0, 1] */
    float left_mps, right_mps;       /* (2 output - 1) v_max, [-v_max, v_max] m/s */
    int16_t left_steps, right_steps; /* the same in motor steps per second, rounded:
                                        e_set_speed_left / e_set_speed_right */
} hevo_wheel_outputs;";

/// Files by name (relative to the output directory) and content.
pub type Files = Vec<(String, Vec<u8>)>;

/// Generates every file but the vectors and the README; for the fixed target also the
/// sigmoid table's largest error.
pub fn generate(
    model: &ExportModel,
    options: &ExportOptions,
) -> Result<(Files, Option<f64>), ExportError> {
    let (types, arithmetic, model_c, model_decls, sigmoid_error) = match options.target {
        Target::Float => (
            fill(FLOAT_TYPES, &common_blanks(model))?,
            FLOAT_ARITHMETIC,
            float_model_c(model),
            String::new(),
            None,
        ),
        Target::Fixed => {
            let fixed = fixed::FixedModel::new(model)?;
            (
                fill(fixed::TYPES, &common_blanks(model))?,
                FIXED_ARITHMETIC,
                fixed.model_c(),
                fixed::MODEL_DECLS.to_string(),
                Some(fixed.sigmoid_error),
            )
        }
    };
    let (qemu_core, qemu_arch) = match options.target {
        Target::Float => (
            "Cortex-M4F, single-precision FPU",
            "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard -DHEVO_QEMU_FPU",
        ),
        Target::Fixed => (
            "Cortex-M3, no FPU",
            "-mcpu=cortex-m3 -mthumb -mfloat-abi=soft",
        ),
    };
    let mut blanks = common_blanks(model);
    blanks.extend([
        ("QEMU_CORE", qemu_core.to_string()),
        ("QEMU_ARCH", qemu_arch.to_string()),
        ("TARGET_TYPES", types),
        ("TARGET_MODEL_DECLS", model_decls),
        ("TARGET", options.target.name().to_string()),
        ("NODE_LIST", node_list(model)),
    ]);
    let header = fill(HEADER_TEMPLATE, &blanks)?;
    let mut makefile_blanks = blanks.clone();
    makefile_blanks.push(("QEMU_RULES", fill(QEMU_RULES, &blanks)?));
    let makefile = fill(MAKEFILE_TEMPLATE, &makefile_blanks)?;
    let files = vec![
        ("hevo.h".to_string(), header),
        ("hevo.c".to_string(), format!("{arithmetic}{RUNTIME}")),
        ("hevo_model.c".to_string(), model_c),
        ("check.c".to_string(), CHECK_HARNESS.to_string()),
        ("loop.c".to_string(), LOOP_PROGRAM.to_string()),
        ("qemu_startup.c".to_string(), QEMU_STARTUP.to_string()),
        ("qemu.ld".to_string(), QEMU_LINKER_SCRIPT.to_string()),
        ("Makefile".to_string(), makefile),
    ];
    Ok((
        files
            .into_iter()
            .map(|(name, text)| (name, text.into_bytes()))
            .collect(),
        sigmoid_error,
    ))
}

/// The blanks every template may use.
fn common_blanks(model: &ExportModel) -> Vec<(&'static str, String)> {
    let cycle_ms = (f64::from(model.dt) * 1000.0).round();
    vec![
        ("CONTROLLER", model.controller_name.clone()),
        ("TASK", model.task_name.clone()),
        ("N_NODES", model.nodes.len().to_string()),
        ("MAX_PATH", model.max_path().to_string()),
        ("N_HIDDEN_TOTAL", model.n_hidden_total().to_string()),
        ("N_PRESYN_TOTAL", model.n_presyn_total().to_string()),
        ("N_OUTPUTS_TOTAL", model.n_outputs_total().to_string()),
        ("CYCLE_MS", format!("{cycle_ms}")),
        ("V_MAX_MPS", float_literal(model.v_max)),
        (
            "V_MAX_STEPS",
            format!("{}", (f64::from(model.v_max) * steps_per_metre()).round()),
        ),
        ("STEPS_PER_METRE", float_literal(steps_per_metre() as f32)),
        (
            "WHEEL_DIAMETER_MM",
            format!("{}", WHEEL_DIAMETER_M * 1000.0),
        ),
        ("NEAR_RANGE", format!("{}", model.near_robot_range)),
        ("IR_GRID", model.ir.means.len().to_string()),
    ]
}

/// Replaces every `{{NAME}}` of `template` by its value; a blank without a value is an error
/// (a template and this generator out of step).
pub fn fill(template: &str, blanks: &[(&str, String)]) -> Result<String, ExportError> {
    let mut text = template.to_string();
    for (name, value) in blanks {
        text = text.replace(&format!("{{{{{name}}}}}"), value);
    }
    match text.find("{{") {
        Some(at) => Err(ExportError::Unsupported(format!(
            "a template blank has no value: {}",
            &text[at..text.len().min(at + 40)]
        ))),
        None => Ok(text),
    }
}

/// A float as a C `float` literal that reads back as the same bits: Rust prints the shortest
/// decimal that does, and C compilers round decimal literals correctly.
pub fn float_literal(value: f32) -> String {
    format!("{value:e}f")
}

/// A C array definition, eight values a line.
pub fn c_array<T>(declaration: &str, values: &[T], literal: impl Fn(&T) -> String) -> String {
    let mut text = format!("{declaration} = {{");
    if values.is_empty() {
        // C has no empty arrays; the one element is never read.
        text.push_str(" 0 };\n");
        return text;
    }
    for (idx, value) in values.iter().enumerate() {
        text.push_str(if idx % 8 == 0 { "\n    " } else { " " });
        text.push_str(&literal(value));
        text.push(',');
    }
    text.push_str("\n};\n");
    text
}

/// The header's list of nodes.
fn node_list(model: &ExportModel) -> String {
    let mut text = String::new();
    for (idx, node) in model.nodes.iter().enumerate() {
        let _ = writeln!(
            text,
            " *   {idx:>3}  {}  {}  {}-{}-{}{}",
            node.path,
            if node.is_arbitrator {
                "arbitrator"
            } else {
                "primitive"
            },
            node.n_inputs(),
            node.n_hidden,
            node.n_outputs,
            if node.min_active_cycles > 0 {
                format!(
                    "  (a child stays on at least {} cycles)",
                    node.min_active_cycles
                )
            } else {
                String::new()
            }
        );
    }
    text.trim_end().to_string()
}

/// What both targets' `hevo_model.c` hold besides the parameters: the node table (with each
/// node's parameter arrays named `node<i>_<what>`), the children, the live groups.
pub fn node_table(model: &ExportModel) -> String {
    let mut text = String::new();
    let mut children: Vec<usize> = Vec::new();
    let (mut hidden_offset, mut presyn_offset, mut output_offset) = (0, 0, 0);
    text.push_str("const hevo_node hevo_nodes[HEVO_N_NODES] = {\n");
    for (idx, node) in model.nodes.iter().enumerate() {
        let _ = writeln!(
            text,
            "    {{ {}, {}, {}, {}, node{idx}_input_index, {hidden_offset}, {presyn_offset}, \
             {output_offset}, {}, {}, {}u, node{idx}_hidden_weights, node{idx}_hidden_biases, \
             node{idx}_dt_over_tau, node{idx}_rest_firing, node{idx}_output_weights, \
             node{idx}_output_biases }}, /* {} */",
            u8::from(node.is_arbitrator),
            node.n_inputs(),
            node.n_hidden,
            node.n_outputs,
            children.len(),
            node.subtree_end,
            node.min_active_cycles,
            node.path
        );
        children.extend(&node.children);
        hidden_offset += node.n_hidden;
        presyn_offset += node.n_inputs() + node.n_hidden;
        output_offset += node.n_outputs;
    }
    text.push_str("};\n\n");
    text.push_str(&c_array("const uint16_t hevo_children[]", &children, |c| {
        c.to_string()
    }));
    let [ir, light, near] = model.live.map(u8::from);
    let _ = writeln!(
        text,
        "\nconst uint8_t hevo_live_ir = {ir}, hevo_live_light = {light}, \
         hevo_live_near_robot = {near};"
    );
    let _ = writeln!(
        text,
        "const uint16_t hevo_light_hold = {};",
        model.light_hold.min(u32::from(u16::MAX))
    );
    text
}

/// Each node's input indices, which both targets share.
pub fn input_indices(model: &ExportModel) -> String {
    let mut text = String::new();
    for (idx, node) in model.nodes.iter().enumerate() {
        text.push_str(&c_array(
            &format!("static const uint8_t node{idx}_input_index[]"),
            &node.input_index,
            |i| i.to_string(),
        ));
    }
    text
}

/// The opening comment of a generated `hevo_model.c`.
pub fn model_preamble(model: &ExportModel, target: Target) -> String {
    format!(
        "/*\n * hevo_model.c: the networks of {} ({} nodes, {} parameters) for the task {}, {} \
         target:\n * constant data, in flash. Generated by `hevo export`; do not edit.\n */\n\
         #include \"hevo.h\"\n\n",
        model.controller_name,
        model.nodes.len(),
        model.n_parameters(),
        model.task_name,
        target.name()
    )
}

/// The float target's `hevo_model.c`: every parameter as the float sim-core computes with.
fn float_model_c(model: &ExportModel) -> String {
    let mut text = model_preamble(model, Target::Float);
    text.push_str(&input_indices(model));
    let floats = |v: &f32| float_literal(*v);
    for (idx, node) in model.nodes.iter().enumerate() {
        for (what, values) in [
            ("hidden_weights", &node.hidden_weights),
            ("hidden_biases", &node.hidden_biases),
            ("dt_over_tau", &node.dt_over_tau),
            ("rest_firing", &node.rest_firing),
            ("output_weights", &node.output_weights),
            ("output_biases", &node.output_biases),
        ] {
            text.push_str(&c_array(
                &format!("static const float node{idx}_{what}[]"),
                values,
                floats,
            ));
        }
    }
    text.push('\n');
    text.push_str(&node_table(model));
    text.push_str(&c_array(
        "const float hevo_ir_means[HEVO_IR_GRID]",
        &model.ir.means,
        floats,
    ));
    let _ = writeln!(
        text,
        "const float hevo_ir_step = {}, hevo_ir_max_distance = {};",
        float_literal(model.ir.step),
        float_literal(model.ir.max_distance)
    );
    text.push_str(&c_array(
        "const float hevo_light_threshold[HEVO_N_LIGHT]",
        &model.light_threshold,
        floats,
    ));
    text
}

/// The generated README.
pub fn readme(
    model: &ExportModel,
    options: &ExportOptions,
    vectors: &VectorSummary,
    sigmoid_error: Option<f64>,
) -> String {
    let mut blanks = common_blanks(model);
    let target_notes = match options.target {
        Target::Float => "The float target computes in IEEE single precision with sim-core's own \
            operations in sim-core's order (its exponential, its dot products' four partial \
            sums), so compiled without fused multiply-add (`-ffp-contract=off`, in the \
            Makefile) every input, state, output and wheel speed is sim-core's bit for bit. \
            It needs a single-precision FPU to be fast (the e-puck2's Cortex-M4F has one: \
            `-mfpu=fpv4-sp-d16 -mfloat-abi=hard`)."
            .to_string(),
        Target::Fixed => format!(
            "The fixed target computes in integers only (no FPU, no libm): values in Q16 \
             (`HEVO_ONE` = 65536 is 1.0), weights in Q11, time step factors in Q30, the \
             logistic from a table of {} entries over [-{}, {}) with linear interpolation. \
             Raw readings are the ADC's integers. The table's largest error against the exact \
             logistic is {:.2e}; the results differ from sim-core's by rounding, and an \
             arbitrator may then choose another child where two outputs are close (`make \
             check` reports how often and the largest errors).",
            fixed::SIGMOID_ENTRIES,
            fixed::SIGMOID_RANGE,
            fixed::SIGMOID_RANGE,
            sigmoid_error.unwrap_or(f64::NAN)
        ),
    };
    let samples: Vec<String> = vectors
        .samples
        .iter()
        .map(|(seed, variant, cycles, solved)| {
            format!(
                "seed {seed}{}: {cycles} cycles, {}",
                variant.map(|v| format!(" variant {v}")).unwrap_or_default(),
                if *solved { "solved" } else { "not solved" }
            )
        })
        .collect();
    blanks.extend([
        ("TARGET", options.target.name().to_string()),
        ("TARGET_NOTES", target_notes),
        (
            "SOURCE",
            options
                .source_note
                .clone()
                .unwrap_or_else(|| "a controller file".into()),
        ),
        ("N_PARAMETERS", model.n_parameters().to_string()),
        ("VECTOR_SAMPLES", samples.join("; ")),
        ("VECTOR_CYCLES", vectors.n_cycles.to_string()),
        ("NODE_LIST", node_list(model).replace(" *   ", "    ")),
    ]);
    // The README template has no blank a model lacks; should one slip in, show it as it is.
    fill(README_TEMPLATE, &blanks).unwrap_or_else(|_| README_TEMPLATE.to_string())
}
