//! Post-evaluation: a controller's solve rate over many fresh samples, per variant (light
//! configuration, start branch) where the task's scenario has them, per stage and per phase of
//! the derived fitness where it has those, with mean fitness and collisions. The paper's
//! tasks keep the report shape they had before scenarios (the rescue's `stages`, its right
//! choices keyed by the child each of its phases asks for); any other scenario's report names
//! its variants, stages and phases as its file does. Used after each
//! evolutionary run and by `hevo eval`. Evaluations go through the dispatcher, so they spread
//! over every worker like a generation does. The report's format (and its text) is
//! `hevo_rundir::eval_report`'s, re-exported here.

use crate::dispatch::{DispatchError, Dispatcher, EvaluationRequest, RequestShared};
use hevo_sim_core::ControllerFile;
use hevo_sim_core::SampleSummary;
use hevo_sim_core::derive_seed;
use hevo_sim_core::{ChildRef, Sample, Scenario, TaskConfig};
use std::sync::Arc;

pub use hevo_rundir::eval_report::*;

/// One report per node below the root, from the samples' counts, when every sample counted
/// `node_paths.len()` nodes; empty otherwise (a lone primitive, or counts missing).
fn node_use_reports(summaries: &[SampleSummary], node_paths: &[String]) -> Vec<NodeUseReport> {
    let n_nodes = node_paths.len();
    let complete = summaries.iter().all(|s| {
        s.node_use.active_cycles.len() == n_nodes && s.node_use.activations.len() == n_nodes
    });
    if n_nodes < 2 || summaries.is_empty() || !complete {
        return Vec::new();
    }
    let total_cycles: u64 = summaries.iter().map(|s| u64::from(s.cycles)).sum();
    let sum_of = |counts: fn(&SampleSummary) -> &[u32], node: usize| -> u64 {
        summaries.iter().map(|s| u64::from(counts(s)[node])).sum()
    };
    (1..n_nodes)
        .map(|node| {
            let active = sum_of(|s| &s.node_use.active_cycles, node);
            let activations = sum_of(|s| &s.node_use.activations, node);
            NodeUseReport {
                node: node_paths[node].clone(),
                active_share: active as f64 / total_cycles.max(1) as f64,
                activations_per_sample: activations as f64 / summaries.len() as f64,
                cycles_per_activation: (activations > 0)
                    .then(|| active as f64 / activations as f64),
            }
        })
        .collect()
}

/// Each phase's share of right choices, averaged over the samples that reached it.
fn mean_phase_shares(summaries: &[SampleSummary], phase: usize) -> Option<f64> {
    let shares: Vec<f64> = summaries
        .iter()
        .filter_map(|s| s.sub_task_choices.shares()[phase])
        .map(f64::from)
        .collect();
    (!shares.is_empty()).then(|| shares.iter().sum::<f64>() / shares.len() as f64)
}

/// Each phase of the scenario's derived fitness, keyed by `key` (of its name and the child it
/// asks for), with its share of right choices averaged over the samples that reached it.
fn phase_shares(
    scenario: &Scenario,
    summaries: &[SampleSummary],
    key: fn(&str, &ChildRef) -> String,
) -> Vec<PhaseShare> {
    scenario
        .phases
        .iter()
        .enumerate()
        .map(|(idx, phase)| PhaseShare {
            phase: key(&phase.name, &phase.child),
            right_choice: mean_phase_shares(summaries, idx),
        })
        .collect()
}

/// The child a phase asks for, which keys the rescue's phases in its reports.
fn phase_child(_name: &str, child: &ChildRef) -> String {
    match child {
        ChildRef::Name(name) => name.clone(),
        ChildRef::Index(idx) => idx.to_string(),
    }
}

/// The samples of a post-evaluation: `per_variant` samples of each variant of the task (one
/// variant for tasks without), seeds derived from `seed` alone.
pub fn post_evaluation_samples(task: &TaskConfig, per_variant: u32, seed: u64) -> Vec<Sample> {
    let n_variants = task.scenario.n_variants();
    let variant_fixed = n_variants > 1;
    (0..per_variant)
        .flat_map(|i| {
            (0..n_variants).map(move |v| Sample {
                seed: derive_seed(seed, &[u64::from(i), u64::from(v)]),
                variant: variant_fixed.then_some(v),
            })
        })
        .collect()
}

/// Summarises sample outcomes of the controller whose nodes have the paths `node_paths`
/// ([`ControllerFile::node_paths`]).
pub fn report(task: &TaskConfig, summaries: &[SampleSummary], node_paths: &[String]) -> EvalReport {
    let scenario = &task.scenario;
    // The paper's tasks keep the report they had before scenarios.
    let paper = scenario.legacy().is_some();
    let n = summaries.len().max(1) as f64;
    let share =
        |f: &dyn Fn(&SampleSummary) -> bool| summaries.iter().filter(|s| f(s)).count() as f64 / n;
    let n_variants = scenario.n_variants();
    let per_variant = if n_variants > 1 {
        (0..n_variants)
            .map(|variant| {
                let of: Vec<&SampleSummary> =
                    summaries.iter().filter(|s| s.variant == variant).collect();
                VariantReport {
                    variant,
                    name: (!paper).then(|| scenario.variants[variant as usize].name.clone()),
                    samples: of.len() as u32,
                    solve_rate: of.iter().filter(|s| s.solved).count() as f64
                        / of.len().max(1) as f64,
                }
            })
            .collect()
    } else {
        Vec::new()
    };
    EvalReport {
        task: scenario.name().to_string(),
        samples: summaries.len() as u32,
        solve_rate: share(&|s| s.solved),
        mean_fitness: summaries.iter().map(|s| f64::from(s.fitness)).sum::<f64>() / n,
        collision_rate: share(&|s| s.collided),
        mean_cycles: summaries.iter().map(|s| f64::from(s.cycles)).sum::<f64>() / n,
        per_variant,
        stages: (paper && scenario.has_phases()).then(|| StageReport {
            exited_room: share(&|s| s.stage >= 1),
            reached_teammate: share(&|s| s.stage >= 2),
            returned: share(&|s| s.stage >= 3),
            right_choice: Some(RightChoice {
                phases: phase_shares(scenario, summaries, phase_child),
            }),
        }),
        per_stage: if paper || scenario.stages.is_empty() {
            Vec::new()
        } else {
            scenario
                .stage_names()
                .into_iter()
                .enumerate()
                .map(|(idx, stage)| StageShare {
                    stage,
                    share: share(&|s| usize::from(s.stage) > idx),
                })
                .collect()
        },
        per_phase: if paper {
            Vec::new()
        } else {
            phase_shares(scenario, summaries, |name, _child| name.to_string())
        },
        node_use: node_use_reports(summaries, node_paths),
    }
}

/// The unsolved samples among `samples`, whose outcomes are `summaries` in the same order.
pub fn failed_samples(samples: &[Sample], summaries: &[SampleSummary]) -> Vec<FailedSample> {
    samples
        .iter()
        .zip(summaries)
        .filter(|(_, summary)| !summary.solved)
        .map(|(sample, summary)| FailedSample {
            seed: sample.seed,
            variant: sample.variant,
            collided: summary.collided,
            stage: summary.stage,
            cycles: summary.cycles,
        })
        .collect()
}

/// Evaluates a complete controller (no free node) on the given samples through the dispatcher.
pub async fn evaluate_controller(
    dispatcher: &Dispatcher,
    job: &str,
    controller: ControllerFile,
    task: TaskConfig,
    samples: Vec<Sample>,
) -> Result<EvalReport, DispatchError> {
    let node_paths = controller.node_paths();
    let summaries = evaluate_samples(dispatcher, job, controller, task.clone(), samples).await?;
    Ok(report(&task, &summaries, &node_paths))
}

/// Evaluates a complete controller on the given samples: one outcome per sample, in order.
pub async fn evaluate_samples(
    dispatcher: &Dispatcher,
    job: &str,
    controller: ControllerFile,
    task: TaskConfig,
    samples: Vec<Sample>,
) -> Result<Vec<SampleSummary>, DispatchError> {
    let shared = Arc::new(RequestShared::new(controller, task));
    let request = EvaluationRequest {
        job: job.to_string(),
        shared,
        genomes: vec![Arc::from(Vec::new())],
        samples: samples.into(),
    };
    let mut results = dispatcher.evaluate(request).await?;
    Ok(results.swap_remove(0))
}

/// How many samples failed and how many of those touched a wall, and for a scenario with
/// stages the last stage they reached (the rescue: in the room, in the maze, on the way back):
/// where a researcher starts looking.
pub fn describe_failures(task: &TaskConfig, failures: &[FailedSample]) -> String {
    let count = |group: &[&FailedSample]| {
        let collided = group.iter().filter(|f| f.collided).count();
        format!("{} ({collided} touched a wall)", group.len())
    };
    let all: Vec<&FailedSample> = failures.iter().collect();
    let mut text = format!("unsolved samples: {}", count(&all));
    let scenario = &task.scenario;
    if !scenario.stages.is_empty() {
        let places: Vec<String> = if scenario.legacy() == Some("rescue") {
            ["still in the room", "in the maze", "on the way back"]
                .map(String::from)
                .to_vec()
        } else {
            std::iter::once("before any stage".to_string())
                .chain(scenario.stages.iter().map(|s| format!("after {}", s.name)))
                .collect()
        };
        for (stage, place) in places.iter().enumerate() {
            let group: Vec<&FailedSample> = failures
                .iter()
                .filter(|f| usize::from(f.stage) == stage)
                .collect();
            text.push_str(&format!("\n  {place}: {}", count(&group)));
        }
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shipped(name: &str) -> TaskConfig {
        TaskConfig::shipped(name).unwrap()
    }
    use hevo_sim_core::NodeUse;
    use hevo_sim_core::SubTaskChoices;

    #[test]
    fn failures_are_counted_by_ending_and_rescue_stage() {
        let failed = |stage, collided| FailedSample {
            seed: 1,
            variant: None,
            collided,
            stage,
            cycles: 10,
        };
        let failures = [failed(0, true), failed(0, false), failed(2, false)];
        let rescue = describe_failures(&shipped("rescue"), &failures);
        assert_eq!(
            rescue,
            "unsolved samples: 3 (1 touched a wall)\n  still in the room: 2 (1 touched a wall)\n  \
             in the maze: 0 (0 touched a wall)\n  on the way back: 1 (0 touched a wall)"
        );
        assert_eq!(
            describe_failures(&shipped("exit_room"), &failures[..1]),
            "unsolved samples: 1 (1 touched a wall)"
        );
    }

    #[test]
    fn maze_post_evaluation_balances_light_configurations() {
        let samples = post_evaluation_samples(&shipped("solve_maze"), 100, 1);
        assert_eq!(samples.len(), 400);
        for v in 0..4 {
            assert_eq!(samples.iter().filter(|s| s.variant == Some(v)).count(), 100);
        }
        let room = post_evaluation_samples(&shipped("exit_room"), 100, 1);
        assert_eq!(room.len(), 100);
        assert!(room.iter().all(|s| s.variant.is_none()));
    }

    #[test]
    fn failed_samples_keep_the_seed_and_variant_that_replay_them() {
        let samples = post_evaluation_samples(&shipped("solve_maze"), 2, 7);
        let summaries: Vec<SampleSummary> = samples
            .iter()
            .enumerate()
            .map(|(i, sample)| SampleSummary {
                fitness: 1.0,
                solved: i % 3 != 1,
                collided: i == 4,
                stage: 0,
                variant: sample.variant.unwrap_or(0),
                cycles: 100 + i as u32,
                ..SampleSummary::default()
            })
            .collect();
        let failures = failed_samples(&samples, &summaries);
        let indices = [1usize, 4, 7];
        assert_eq!(failures.len(), indices.len());
        for (failure, &i) in failures.iter().zip(&indices) {
            assert_eq!(failure.seed, samples[i].seed);
            assert_eq!(failure.variant, samples[i].variant);
            assert_eq!(failure.cycles, 100 + i as u32);
            assert_eq!(failure.collided, i == 4);
        }
    }

    #[test]
    fn reports_count_stages_and_variants() {
        let s = |solved, stage, variant| SampleSummary {
            fitness: 1.0,
            solved,
            collided: false,
            stage,
            variant,
            cycles: 10,
            ..SampleSummary::default()
        };
        let summaries = [
            s(true, 3, 0),
            s(false, 2, 1),
            s(false, 1, 0),
            s(false, 0, 1),
        ];
        let r = report(&shipped("rescue"), &summaries, &[]);
        assert_eq!(r.solve_rate, 0.25);
        let stages = r.stages.unwrap();
        assert_eq!(
            (stages.exited_room, stages.reached_teammate, stages.returned),
            (0.75, 0.5, 0.25)
        );
        assert_eq!(r.per_variant[0].solve_rate, 0.5);
        // No sample carried sub-task counts, so no sub-task was reached.
        let right_choice = stages.right_choice.unwrap();
        let shares: Vec<(&str, Option<f64>)> = right_choice
            .phases
            .iter()
            .map(|p| (p.phase.as_str(), p.right_choice))
            .collect();
        assert_eq!(
            shares,
            [
                ("exit_room", None),
                ("solve_maze", None),
                ("return_room", None)
            ]
        );
    }

    #[test]
    fn right_choices_average_each_sub_task_over_the_samples_that_reached_it() {
        let s = |cycles: [u32; 3], correct: [u32; 3]| {
            let mut choices = SubTaskChoices::default();
            choices.cycles[..3].copy_from_slice(&cycles);
            choices.correct[..3].copy_from_slice(&correct);
            SampleSummary {
                sub_task_choices: choices,
                ..SampleSummary::default()
            }
        };
        // Two samples reach the maze; one chose right in half its maze cycles, one never.
        // Only the first reaches the teammate.
        let summaries = [
            s([100, 200, 50], [100, 100, 50]),
            s([300, 100, 0], [150, 0, 0]),
        ];
        let r = report(&shipped("rescue"), &summaries, &[]);
        let right_choice = r.stages.as_ref().unwrap().right_choice.clone().unwrap();
        let shares: Vec<Option<f64>> = right_choice.phases.iter().map(|p| p.right_choice).collect();
        assert_eq!(shares, [Some(0.75), Some(0.25), Some(1.0)]);
        assert_eq!(right_choice.share("solve_maze"), Some(0.25));
        // The same counts give each sample's f3.
        assert_eq!(summaries[0].sub_task_choices.derived_fitness(), 2.5);
        assert_eq!(summaries[1].sub_task_choices.derived_fitness(), 0.5);
        assert!(
            describe(&r).contains("in the room 75.0%, in the maze 25.0%, on the way back 100.0%")
        );
    }

    #[test]
    fn node_use_sums_cycles_and_switch_ons_over_samples() {
        let s = |cycles, active_cycles: [u32; 4], activations: [u32; 4]| SampleSummary {
            cycles,
            node_use: NodeUse {
                active_cycles: active_cycles.to_vec(),
                activations: activations.to_vec(),
            },
            ..SampleSummary::default()
        };
        // A root over three children: the second child never runs; the third flicks on and off.
        let summaries = [
            s(100, [100, 60, 0, 40], [1, 1, 0, 20]),
            s(300, [300, 300, 0, 0], [1, 1, 0, 0]),
        ];
        let paths: Vec<String> = ["root", "root/a", "root/b", "root/c"]
            .map(String::from)
            .to_vec();
        let r = report(&shipped("return_room"), &summaries, &paths);
        let expected = [
            ("root/a", 0.9, 1.0, Some(180.0)),
            ("root/b", 0.0, 0.0, None),
            ("root/c", 0.1, 10.0, Some(2.0)),
        ];
        assert_eq!(r.node_use.len(), expected.len());
        for (node, (path, share, per_sample, dwell)) in r.node_use.iter().zip(expected) {
            assert_eq!(node.node, path);
            assert!((node.active_share - share).abs() < 1e-12, "{node:?}");
            assert_eq!(node.activations_per_sample, per_sample);
            assert_eq!(node.cycles_per_activation, dwell);
        }
        let text = describe(&r);
        assert!(
            text.contains("\n    root/b    0.0%     0.0       -"),
            "{text}"
        );
        assert!(
            text.contains("\n    root/c   10.0%    10.0     2.0"),
            "{text}"
        );

        // Counts for another tree, or none at all, give no table rather than a wrong one.
        assert!(
            report(&shipped("return_room"), &summaries, &paths[..3])
                .node_use
                .is_empty()
        );
        let plain = [SampleSummary::default()];
        assert!(
            report(&shipped("return_room"), &plain, &paths)
                .node_use
                .is_empty()
        );
    }
}
