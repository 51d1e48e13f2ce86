//! Conversions between sim-core's types and the `hevo.v1` messages, used by the master and the
//! worker alike. They are lossless where it matters for reproducibility: genes and fitness
//! travel as `float` (the same f32 bits), seeds as `uint64`, and templates and tasks as
//! sim-core's own JSON whose content hash is checked on arrival, so a worker evaluates exactly
//! what the master would have evaluated in-process. Anything from the wire that does not fit
//! (a stage above 255, a hash that does not match) is an error, never a silent truncation.

use crate::v1;
use hevo_sim_core::ControllerFile;
use hevo_sim_core::Sample;
use hevo_sim_core::TaskConfig;
use hevo_sim_core::{Ending, N_SUB_TASKS, NodeUse, SubTaskChoices};
use hevo_sim_core::{SampleSummary, task_content_hash};

/// Why a message could not be turned into sim-core values.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConvertError {
    /// A field holds a value sim-core cannot represent.
    #[error("{field}: {message}")]
    Field {
        /// The field, e.g. `genomes[2].samples[0].stage`.
        field: String,
        /// What is wrong.
        message: String,
    },
}

fn field_error(field: impl Into<String>, message: impl Into<String>) -> ConvertError {
    ConvertError::Field {
        field: field.into(),
        message: message.into(),
    }
}

/// A sample for the wire.
pub fn sample_to_proto(sample: &Sample) -> v1::SampleSpec {
    v1::SampleSpec {
        seed: sample.seed,
        variant: sample.variant,
    }
}

/// A sample from the wire.
pub fn sample_from_proto(sample: &v1::SampleSpec) -> Sample {
    Sample {
        seed: sample.seed,
        variant: sample.variant,
    }
}

/// One (genome, sample) outcome for the wire.
pub fn summary_to_proto(summary: &SampleSummary) -> v1::SampleResult {
    // Only the phases up to the last one reached: tasks without phases send nothing rather
    // than twelve zeros per sample.
    let choices = summary.sub_task_choices;
    let n_phases = choices
        .cycles
        .iter()
        .rposition(|&c| c > 0)
        .map_or(0, |last| last + 1);
    let sub_task_cycles = choices.cycles[..n_phases].to_vec();
    let sub_task_correct = choices.correct[..n_phases].to_vec();
    v1::SampleResult {
        fitness: summary.fitness,
        solved: summary.solved,
        collided: summary.collided,
        stage: u32::from(summary.stage),
        variant: summary.variant,
        cycles: summary.cycles,
        sub_task_cycles,
        sub_task_correct,
        node_active_cycles: summary.node_use.active_cycles.clone(),
        node_activations: summary.node_use.activations.clone(),
        descriptor: summary.descriptor.clone(),
        ending: ending_to_proto(summary.ending).into(),
    }
}

fn ending_to_proto(ending: Ending) -> v1::SampleEnding {
    match ending {
        Ending::Solved => v1::SampleEnding::Solved,
        Ending::Collision => v1::SampleEnding::Collision,
        Ending::WrongBranch => v1::SampleEnding::WrongBranch,
        Ending::Timeout => v1::SampleEnding::Timeout,
    }
}

/// The ending from the wire. Unset is what a hevo built before the field sends (a worker to a
/// master, or a master to a client): the message says so, since the fix is to update it.
fn ending_from_proto(result: &v1::SampleResult, field: &str) -> Result<Ending, ConvertError> {
    match v1::SampleEnding::try_from(result.ending) {
        Ok(v1::SampleEnding::Solved) => Ok(Ending::Solved),
        Ok(v1::SampleEnding::Collision) => Ok(Ending::Collision),
        Ok(v1::SampleEnding::WrongBranch) => Ok(Ending::WrongBranch),
        Ok(v1::SampleEnding::Timeout) => Ok(Ending::Timeout),
        Ok(v1::SampleEnding::Unspecified) => Err(field_error(
            format!("{field}.ending"),
            "not set: the sender is a hevo older than this one (it does not say why a \
             sample ended); update it (a worker: hevo-worker)",
        )),
        Err(_) => Err(field_error(
            format!("{field}.ending"),
            format!("{} is not an ending", result.ending),
        )),
    }
}

/// The node use from the wire: as many activation counts as active-cycle counts, and no node
/// switched on more often than it was active.
fn node_use_from_proto(result: &v1::SampleResult, field: &str) -> Result<NodeUse, ConvertError> {
    let active_cycles = &result.node_active_cycles;
    let activations = &result.node_activations;
    if active_cycles.len() != activations.len() {
        return Err(field_error(
            format!("{field}.node_activations"),
            format!(
                "{} values, expected {} (one per node_active_cycles)",
                activations.len(),
                active_cycles.len()
            ),
        ));
    }
    if let Some(node) = (0..activations.len()).find(|&n| activations[n] > active_cycles[n]) {
        return Err(field_error(
            format!("{field}.node_activations[{node}]"),
            format!(
                "{} activations in {} active cycles",
                activations[node], active_cycles[node]
            ),
        ));
    }
    Ok(NodeUse {
        active_cycles: active_cycles.clone(),
        activations: activations.clone(),
    })
}

/// The phase counts of a derived fitness from the wire: both empty, or as many of each (at
/// most one per phase a scenario may have; phases left out were not reached), with no phase
/// counting more correct cycles than it had.
fn sub_task_choices_from_proto(
    result: &v1::SampleResult,
    field: &str,
) -> Result<SubTaskChoices, ConvertError> {
    if result.sub_task_cycles.is_empty() && result.sub_task_correct.is_empty() {
        return Ok(SubTaskChoices::default());
    }
    let n_phases = result.sub_task_cycles.len();
    let counts = |values: &[u32], name: &str| -> Result<[u32; N_SUB_TASKS], ConvertError> {
        if values.len() != n_phases || n_phases > N_SUB_TASKS {
            return Err(field_error(
                format!("{field}.{name}"),
                format!(
                    "{} values, expected as many as sub_task_cycles and at most {N_SUB_TASKS}",
                    values.len()
                ),
            ));
        }
        let mut all = [0; N_SUB_TASKS];
        all[..n_phases].copy_from_slice(values);
        Ok(all)
    };
    let choices = SubTaskChoices {
        cycles: counts(&result.sub_task_cycles, "sub_task_cycles")?,
        correct: counts(&result.sub_task_correct, "sub_task_correct")?,
    };
    if let Some(s) = (0..N_SUB_TASKS).find(|&s| choices.correct[s] > choices.cycles[s]) {
        return Err(field_error(
            format!("{field}.sub_task_correct[{s}]"),
            format!(
                "{} correct cycles of {}",
                choices.correct[s], choices.cycles[s]
            ),
        ));
    }
    Ok(choices)
}

/// One outcome from the wire; `field` names it in errors.
pub fn summary_from_proto(
    result: &v1::SampleResult,
    field: &str,
) -> Result<SampleSummary, ConvertError> {
    let stage = u8::try_from(result.stage).map_err(|_| {
        field_error(
            format!("{field}.stage"),
            format!("{} is not a stage", result.stage),
        )
    })?;
    if !result.fitness.is_finite() {
        return Err(field_error(
            format!("{field}.fitness"),
            format!("{} is not finite", result.fitness),
        ));
    }
    // The length and each value's range are the task's to check (the dispatcher does).
    if result.descriptor.len() > hevo_sim_core::MAX_DESCRIPTOR {
        return Err(field_error(
            format!("{field}.descriptor"),
            format!(
                "{} values, at most {} are accepted",
                result.descriptor.len(),
                hevo_sim_core::MAX_DESCRIPTOR
            ),
        ));
    }
    if let Some(idx) = result.descriptor.iter().position(|v| !v.is_finite()) {
        return Err(field_error(
            format!("{field}.descriptor[{idx}]"),
            format!("{} is not finite", result.descriptor[idx]),
        ));
    }
    Ok(SampleSummary {
        fitness: result.fitness,
        solved: result.solved,
        collided: result.collided,
        ending: ending_from_proto(result, field)?,
        stage,
        variant: result.variant,
        cycles: result.cycles,
        sub_task_choices: sub_task_choices_from_proto(result, field)?,
        node_use: node_use_from_proto(result, field)?,
        descriptor: result.descriptor.clone(),
    })
}

/// A batch's results, `[genome][sample]`, for the wire.
pub fn results_to_proto(results: &[Vec<SampleSummary>]) -> Vec<v1::GenomeResult> {
    results
        .iter()
        .map(|genome| v1::GenomeResult {
            samples: genome.iter().map(summary_to_proto).collect(),
        })
        .collect()
}

/// A batch's results from the wire. The shape is not checked here (the dispatcher checks it
/// against the batch); every value is.
pub fn results_from_proto(
    results: &[v1::GenomeResult],
) -> Result<Vec<Vec<SampleSummary>>, ConvertError> {
    results
        .iter()
        .enumerate()
        .map(|(g, genome)| {
            genome
                .samples
                .iter()
                .enumerate()
                .map(|(s, result)| {
                    summary_from_proto(result, &format!("genomes[{g}].samples[{s}]"))
                })
                .collect()
        })
        .collect()
}

/// A task configuration as JSON text (compact).
pub fn task_to_json(task: &TaskConfig) -> String {
    // Plain data: serialising cannot fail; an empty string would be refused by the receiver.
    serde_json::to_string(task).unwrap_or_default()
}

/// A task configuration from JSON text, checked against the hash it was sent with.
pub fn task_from_json(json: &str, expected_hash: &str) -> Result<TaskConfig, ConvertError> {
    let task: TaskConfig =
        serde_json::from_str(json).map_err(|e| field_error("task_json", e.to_string()))?;
    let found = task_content_hash(&task);
    if found != expected_hash {
        return Err(field_error(
            "task_hash",
            format!("the task hashes to {found}, the batch says {expected_hash}"),
        ));
    }
    task.validate()
        .map_err(|error| field_error("task_json", error.to_string()))?;
    Ok(task)
}

/// A controller template as JSON text (compact).
pub fn template_to_json(template: &ControllerFile) -> String {
    serde_json::to_string(template).unwrap_or_default()
}

/// A controller template from JSON text, validated and checked against the content hash it
/// was sent with (the hash covers the exact bits of every gene).
pub fn template_from_json(json: &str, expected_hash: &str) -> Result<ControllerFile, ConvertError> {
    let template = ControllerFile::from_json_str(json)
        .map_err(|e| field_error("template_json", e.to_string()))?;
    let found = template.content_hash();
    if found != expected_hash {
        return Err(field_error(
            "template_hash",
            format!("the template hashes to {found}, the batch says {expected_hash}"),
        ));
    }
    Ok(template)
}

/// The key of a worker's evaluator cache, as listed in `LeaseBatchRequest.cached`.
pub fn cache_key(template_hash: &str, task_hash: &str) -> String {
    format!("{template_hash}/{task_hash}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use hevo_sim_core::InputGroup;
    use hevo_sim_core::NodeSpec;

    fn template(genes: Option<Vec<f32>>) -> ControllerFile {
        ControllerFile::new(NodeSpec {
            genome: genes,
            ..NodeSpec::primitive("p", vec![InputGroup::IR], 2)
        })
    }

    #[test]
    fn templates_and_tasks_round_trip_bit_for_bit() {
        let n = template(None).root.topology().n_genes();
        // Awkward values: subnormal, many digits, negative zero, the range limits.
        let genes: Vec<f32> = (0..n)
            .map(|i| match i % 5 {
                0 => 1.0e-40,
                1 => -0.0,
                2 => 0.1 + i as f32 * 1.0e-7,
                3 => -10.0,
                _ => std::f32::consts::PI,
            })
            .collect();
        let file = template(Some(genes.clone()));
        let back = template_from_json(&template_to_json(&file), &file.content_hash()).unwrap();
        let back_genes = back.root.genome.unwrap();
        assert!(
            genes
                .iter()
                .zip(&back_genes)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        for name in hevo_sim_core::SHIPPED_NAMES {
            let task = TaskConfig::shipped(name).unwrap();
            let hash = task_content_hash(&task);
            assert_eq!(task_from_json(&task_to_json(&task), &hash).unwrap(), task);
        }
    }

    #[test]
    fn a_task_whose_group_runs_a_controller_file_travels_with_the_file() {
        let text = include_str!("../../scenarios/swarm/mixed_aggregation.toml");
        let pilot = include_str!("../../controllers/aggregation.json");
        let path = "../../controllers/aggregation.json";
        let give = |written: &str| {
            (written == path)
                .then(|| pilot.to_string())
                .ok_or_else(|| format!("no {written}"))
        };
        let scenario = hevo_sim_core::Scenario::parse_with(text, "mixed.toml", &give).unwrap();
        let task = TaskConfig::from_scenario(std::sync::Arc::new(scenario));
        let hash = task_content_hash(&task);
        let json = task_to_json(&task);
        let back = task_from_json(&json, &hash).unwrap();
        assert_eq!(back, task);
        assert_eq!(back.scenario.controller_files[path], pilot);
        // Another controller in the same place is another task: the old hash refuses it.
        let other = json.replacen("5.9303937", "5.9303938", 1);
        assert_ne!(other, json);
        let error = task_from_json(&other, &hash).unwrap_err().to_string();
        assert!(error.starts_with("task_hash"), "{error}");
    }

    #[test]
    fn a_wrong_hash_is_refused() {
        let file = template(None);
        let err = template_from_json(&template_to_json(&file), "0000000000000000").unwrap_err();
        assert!(err.to_string().contains("template_hash"), "{err}");
        let task = TaskConfig::shipped("follow_wall").unwrap();
        assert!(task_from_json(&task_to_json(&task), "x").is_err());
        assert!(
            task_from_json("{", "x")
                .unwrap_err()
                .to_string()
                .starts_with("task_json")
        );
    }

    #[test]
    fn results_round_trip_and_bad_values_name_the_field() {
        let s = SampleSummary {
            fitness: 0.123_456_79,
            solved: true,
            collided: false,
            stage: 3,
            variant: 2,
            cycles: 777,
            sub_task_choices: SubTaskChoices {
                cycles: [300, 400, 77, 0, 0, 0],
                correct: [300, 0, 70, 0, 0, 0],
            },
            node_use: NodeUse {
                active_cycles: vec![777, 300, 400, 77],
                activations: vec![1, 2, 2, 1],
            },
            descriptor: vec![0.25, -1.5],
            ending: Ending::Solved,
        };
        let plain = SampleSummary {
            sub_task_choices: SubTaskChoices::default(),
            node_use: NodeUse::default(),
            ..s.clone()
        };
        let results = vec![vec![s.clone(), plain], vec![s]];
        let wire = results_to_proto(&results);
        assert!(wire[0].samples[1].sub_task_cycles.is_empty());
        assert_eq!(results_from_proto(&wire).unwrap(), results);
        let mut short = wire.clone();
        short[0].samples[0].sub_task_correct.pop();
        assert_eq!(
            results_from_proto(&short).unwrap_err().to_string(),
            "genomes[0].samples[0].sub_task_correct: 2 values, expected as many as sub_task_cycles and at most 6"
        );
        let mut too_many = wire.clone();
        too_many[1].samples[0].sub_task_correct[2] = 78;
        assert_eq!(
            results_from_proto(&too_many).unwrap_err().to_string(),
            "genomes[1].samples[0].sub_task_correct[2]: 78 correct cycles of 77"
        );
        let mut uneven = wire.clone();
        uneven[0].samples[0].node_activations.pop();
        assert_eq!(
            results_from_proto(&uneven).unwrap_err().to_string(),
            "genomes[0].samples[0].node_activations: 3 values, expected 4 (one per \
             node_active_cycles)"
        );
        let mut switched_on_too_often = wire.clone();
        switched_on_too_often[1].samples[0].node_activations[3] = 78;
        assert_eq!(
            results_from_proto(&switched_on_too_often)
                .unwrap_err()
                .to_string(),
            "genomes[1].samples[0].node_activations[3]: 78 activations in 77 active cycles"
        );
        // Each ending travels as itself; unset (an older worker) and unknown are refused.
        for ending in Ending::ALL {
            let one = vec![vec![SampleSummary {
                ending,
                ..SampleSummary::default()
            }]];
            assert_eq!(results_from_proto(&results_to_proto(&one)).unwrap(), one);
        }
        let mut unset = wire.clone();
        unset[0].samples[1].ending = 0;
        assert_eq!(
            results_from_proto(&unset).unwrap_err().to_string(),
            "genomes[0].samples[1].ending: not set: the sender is a hevo older than this one \
             (it does not say why a sample ended); update it (a worker: hevo-worker)"
        );
        let mut unknown = wire.clone();
        unknown[0].samples[0].ending = 9;
        assert_eq!(
            results_from_proto(&unknown).unwrap_err().to_string(),
            "genomes[0].samples[0].ending: 9 is not an ending"
        );
        let mut bad = wire.clone();
        bad[1].samples[0].stage = 300;
        assert_eq!(
            results_from_proto(&bad).unwrap_err().to_string(),
            "genomes[1].samples[0].stage: 300 is not a stage"
        );
        let mut nan = wire;
        nan[0].samples[1].fitness = f32::NAN;
        assert!(
            results_from_proto(&nan)
                .unwrap_err()
                .to_string()
                .contains("genomes[0].samples[1].fitness")
        );
    }

    #[test]
    fn samples_round_trip() {
        for sample in [
            Sample {
                seed: u64::MAX,
                variant: Some(3),
            },
            Sample::seeded(0),
        ] {
            assert_eq!(sample_from_proto(&sample_to_proto(&sample)), sample);
        }
    }
}
