//! Batch evaluation: the one function every worker (in-process or remote) calls. A batch is a
//! controller template (a controller file whose free node gets each genome's genes), a task and
//! a list of samples shared by all genomes; the result is one outcome per (genome, sample).
//! Built once per batch and shared by reference between the worker's threads.

use crate::episode::evaluator::{Evaluator, TaskError};
use crate::network::controller::{Controller, ControllerError, ControllerFile, NodeKind};
use crate::network::lanes::LaneController;
use crate::outcome::{Ending, NodeUse, Outcome, Sample, SubTaskChoices};
use crate::scenario::Scenario;
use crate::task::TaskConfig;

/// Why a batch cannot be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The task configuration is invalid.
    #[error(transparent)]
    Task(#[from] TaskError),
    /// The controller template or a genome does not fit.
    #[error(transparent)]
    Controller(#[from] ControllerError),
    /// The controller does not fit the scenario ([`controller_fits`]).
    #[error("controller '{node}' {problem}")]
    Mismatch {
        /// The root's name.
        node: String,
        /// What does not fit.
        problem: String,
    },
}

/// Whether `controller` can be judged on `scenario`, checked before any evaluation: the robot
/// carries every sensor its nodes read, and, where the scenario derives its fitness from the
/// root's choices, the root (an arbitrator) has every child a phase asks for. Otherwise what
/// does not fit, as words that follow "the controller": `reads 'light', a sensor ...`. (A
/// primitive root makes no choices, and a derived fitness has nothing to count for it.)
pub fn controller_fits(controller: &ControllerFile, scenario: &Scenario) -> Result<(), String> {
    let root = &controller.root;
    scenario.check_sensors(&root.groups_read())?;
    if scenario.has_phases() && root.kind == NodeKind::Arbitrator {
        let children: Vec<String> = root.children.iter().map(|c| c.name.clone()).collect();
        scenario.phase_children(&children).map_err(|refusal| {
            format!("lacks a child its scenario's derived fitness asks for: {refusal}")
        })?;
    }
    Ok(())
}

/// Which evaluator runs a batch's samples. Both give bit-identical outcomes (a property test
/// holds them to it); the scalar one is the reference, one sample after another, and the
/// lockstep one (`episode::lockstep`) advances several samples of a genome together.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EvaluatorKind {
    /// One sample at a time: [`Evaluator::evaluate`].
    Scalar,
    /// `LANES` (eight) samples in lockstep: [`Evaluator::evaluate_lockstep`].
    #[default]
    Lockstep,
}

/// A validated (controller template, task) pair ready to evaluate genomes.
#[derive(Debug)]
pub struct BatchEvaluator {
    template: ControllerFile,
    evaluator: Evaluator,
    /// Number of genes the free node takes (0 when the template has no free node).
    n_free_genes: usize,
    kind: EvaluatorKind,
}

impl BatchEvaluator {
    /// Validates the template and the task once.
    pub fn new(template: ControllerFile, task: TaskConfig) -> Result<BatchEvaluator, BatchError> {
        template.validate()?;
        controller_fits(&template, &task.scenario).map_err(|problem| BatchError::Mismatch {
            node: template.root.name.clone(),
            problem,
        })?;
        let n_free_genes = template
            .free_node_topology()
            .map_or(0, |(_, topology)| topology.n_genes());
        Ok(BatchEvaluator {
            template,
            evaluator: Evaluator::new(task)?,
            n_free_genes,
            kind: EvaluatorKind::default(),
        })
    }

    /// The same batch evaluated by `kind`.
    pub fn with_kind(mut self, kind: EvaluatorKind) -> BatchEvaluator {
        self.kind = kind;
        self
    }

    /// Which evaluator runs the samples.
    pub fn kind(&self) -> EvaluatorKind {
        self.kind
    }

    /// The evaluator (task and shared geometry).
    pub fn evaluator(&self) -> &Evaluator {
        &self.evaluator
    }

    /// Genes the free node takes.
    pub fn n_free_genes(&self) -> usize {
        self.n_free_genes
    }

    /// Builds the controller for one genome (`None` for a template without a free node).
    pub fn controller(&self, genes: Option<&[f32]>) -> Result<Controller, ControllerError> {
        Controller::new(&self.template, genes)
    }

    /// Evaluates one genome on every sample, in order, with this batch's evaluator.
    pub fn evaluate_genome(
        &self,
        genes: Option<&[f32]>,
        samples: &[Sample],
    ) -> Result<Vec<Outcome>, ControllerError> {
        let mut controller = self.controller(genes)?;
        Ok(match self.kind {
            EvaluatorKind::Scalar => samples
                .iter()
                .map(|&sample| self.evaluator.evaluate(&mut controller, sample))
                .collect(),
            EvaluatorKind::Lockstep => {
                let dt = self.evaluator.task().params.robot.cycle_seconds;
                let mut lanes = LaneController::new(controller, dt);
                self.evaluator.evaluate_lockstep(&mut lanes, samples)
            }
        })
    }
}

/// The part of an [`Outcome`] that evolution and post-evaluation need, small enough to send
/// for every (genome, sample) pair.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SampleSummary {
    /// The task's fitness.
    pub fitness: f32,
    /// Whether the goal was reached.
    pub solved: bool,
    /// Whether the robot touched a wall at any time.
    pub collided: bool,
    /// Why the sample ended.
    #[serde(default)]
    pub ending: Ending,
    /// Furthest stage (rescue 0..3, else 1 when solved).
    pub stage: u8,
    /// Light configuration or start branch.
    pub variant: u32,
    /// Cycles run.
    pub cycles: u32,
    /// Rescue only: the root's choices per sub-task (f3's counts); zero for other tasks.
    #[serde(default)]
    pub sub_task_choices: SubTaskChoices,
    /// How the controller's nodes took turns; empty when not known.
    #[serde(default)]
    pub node_use: NodeUse,
    /// The behaviour descriptor, one value per quantity of the scenario's descriptor.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub descriptor: Vec<f32>,
}

impl SampleSummary {
    /// Checks that this summary is one the task could produce for `sample` on a controller
    /// of `n_nodes` nodes: every field in its range, and the fields consistent with each other.
    /// A summary that comes from elsewhere (a remote worker) is believed only after this.
    pub fn check(&self, task: &TaskConfig, n_nodes: usize, sample: &Sample) -> Result<(), String> {
        let (low, high) = task.fitness_range();
        if !(self.fitness.is_finite() && (low..=high).contains(&self.fitness)) {
            return Err(format!(
                "fitness {} is outside the task's range [{low}, {high}]",
                self.fitness
            ));
        }
        let max_cycles = task.max_cycles();
        if self.cycles > max_cycles {
            return Err(format!(
                "cycles {} exceeds the task's limit {max_cycles}",
                self.cycles
            ));
        }
        if self.solved != (self.ending == Ending::Solved)
            || (self.ending == Ending::Collision && !(self.collided && task.end_on_collision))
        {
            return Err(format!(
                "ending '{}' does not fit (solved: {}, collided: {}, the task ends on collisions: {})",
                self.ending.name(),
                self.solved,
                self.collided,
                task.end_on_collision
            ));
        }
        let max_stage = task.scenario.max_stage();
        if self.stage > max_stage || (self.solved && self.stage != max_stage) {
            return Err(format!(
                "stage {} does not fit (solved: {}, the task's last stage is {max_stage})",
                self.stage, self.solved
            ));
        }
        let n_variants = task.scenario.reported_variants();
        if self.variant >= n_variants {
            return Err(format!(
                "variant {} is out of range: the task has {n_variants}",
                self.variant
            ));
        }
        // Only a task with variants to ask for answers the one asked for (the turning tasks
        // report their corridor's shape, drawn whatever the sample says).
        if let Some(asked) = sample.variant
            && task.scenario.n_variants() > 1
            && asked != self.variant
        {
            return Err(format!(
                "variant {} answers a sample of variant {asked}",
                self.variant
            ));
        }
        let choices = &self.sub_task_choices;
        if !task.scenario.has_phases() && *choices != SubTaskChoices::default() {
            return Err("sub-task choices for a task without sub-tasks".into());
        }
        if choices.cycles.iter().map(|&c| u64::from(c)).sum::<u64>() > u64::from(self.cycles)
            || choices
                .correct
                .iter()
                .zip(&choices.cycles)
                .any(|(c, n)| c > n)
        {
            return Err(format!(
                "sub-task choices {choices:?} do not fit {} cycles",
                self.cycles
            ));
        }
        let ranges = task.scenario.descriptor_ranges();
        if self.descriptor.len() != ranges.len() {
            return Err(format!(
                "a descriptor of {} values, the task's has {}",
                self.descriptor.len(),
                ranges.len()
            ));
        }
        for (idx, (&value, (low, high))) in self.descriptor.iter().zip(ranges).enumerate() {
            if !(value.is_finite() && (low..=high).contains(&value)) {
                return Err(format!(
                    "descriptor value {idx} ({}) is {value}, outside its range [{low}, {high}]",
                    task.scenario.descriptor_names()[idx]
                ));
            }
        }
        let node_use = &self.node_use;
        if !node_use.active_cycles.is_empty() || !node_use.activations.is_empty() {
            if node_use.active_cycles.len() != n_nodes || node_use.activations.len() != n_nodes {
                return Err(format!(
                    "node use for {} and {} nodes, the controller has {n_nodes}",
                    node_use.active_cycles.len(),
                    node_use.activations.len()
                ));
            }
            let consistent = node_use
                .active_cycles
                .iter()
                .zip(&node_use.activations)
                .all(|(&active, &activations)| active <= self.cycles && activations <= active);
            if !consistent {
                return Err(format!(
                    "node use {node_use:?} does not fit {} cycles",
                    self.cycles
                ));
            }
        }
        Ok(())
    }
}

impl From<&Outcome> for SampleSummary {
    fn from(outcome: &Outcome) -> SampleSummary {
        SampleSummary {
            fitness: outcome.fitness,
            solved: outcome.solved,
            collided: outcome.collided,
            ending: outcome.ending,
            stage: outcome.stage,
            variant: outcome.variant,
            cycles: outcome.cycles,
            sub_task_choices: outcome.sub_task_choices,
            node_use: outcome.node_use.clone(),
            descriptor: outcome.descriptor.clone(),
        }
    }
}

impl BatchEvaluator {
    /// Evaluates one genome on every sample and keeps the summaries.
    pub fn evaluate_summaries(
        &self,
        genes: Option<&[f32]>,
        samples: &[Sample],
    ) -> Result<Vec<SampleSummary>, ControllerError> {
        Ok(self
            .evaluate_genome(genes, samples)?
            .iter()
            .map(SampleSummary::from)
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::network::controller::NodeSpec;
    use crate::sensors::frame::InputGroup;

    /// A two-level tree whose root sees every input group, over the children the task's
    /// phases ask for (two others when it has none), so it fits every task.
    fn template(task: &TaskConfig) -> ControllerFile {
        let inputs = vec![InputGroup::IR, InputGroup::LIGHT, InputGroup::NEAR_ROBOT];
        let child = |name: &str| {
            let spec = NodeSpec::primitive(name, vec![InputGroup::IR], 2);
            let n = spec.topology().n_genes();
            spec.with_genome((0..n).map(|i| (i % 7) as f32 - 3.0).collect())
        };
        let mut names = task.scenario.named_phase_children();
        if names.is_empty() {
            names = vec!["a", "b"];
        }
        ControllerFile::new(NodeSpec::arbitrator(
            "root",
            inputs,
            3,
            names.iter().map(|name| child(name)).collect(),
        ))
    }

    /// `check` must never refuse what the simulator itself produces: every task, random
    /// genomes, samples with and without a fixed variant.
    #[test]
    fn every_real_summary_passes_its_check() {
        for name in crate::scenario::Scenario::shipped_names() {
            let task = TaskConfig::shipped(name).unwrap();
            let evaluator = BatchEvaluator::new(template(&task), task.clone()).unwrap();
            let n_nodes = template(&task).node_paths().len();
            let n_genes = evaluator.n_free_genes();
            for genome_idx in 0..4u32 {
                let genes: Vec<f32> = (0..n_genes)
                    .map(|i| ((i as u32 * 31 + genome_idx * 17) % 21) as f32 - 10.0)
                    .collect();
                let fixed = task.scenario.n_variants() - 1;
                let samples = [
                    Sample::seeded(u64::from(genome_idx)),
                    Sample {
                        seed: 99,
                        variant: Some(fixed),
                    },
                ];
                let summaries = evaluator
                    .evaluate_summaries(Some(&genes), &samples)
                    .unwrap();
                for (summary, sample) in summaries.iter().zip(&samples) {
                    assert_eq!(
                        summary.check(&task, n_nodes, sample),
                        Ok(()),
                        "{name} {summary:?}",
                    );
                }
            }
        }
    }

    #[test]
    fn impossible_summaries_are_named() {
        let task = TaskConfig::shipped("solve_maze").unwrap();
        let sample = Sample {
            seed: 1,
            variant: Some(2),
        };
        let good = SampleSummary {
            fitness: 1.5,
            solved: true,
            ending: Ending::Solved,
            stage: 1,
            variant: 2,
            cycles: 500,
            descriptor: vec![0.5, -0.25],
            ..SampleSummary::default()
        };
        assert_eq!(good.check(&task, 4, &sample), Ok(()));
        // A change that makes the summary impossible, and what the refusal must say.
        type Damage = (fn(&mut SampleSummary), &'static str);
        let cases: [Damage; 12] = [
            (|s| s.fitness = 2.5, "fitness 2.5 is outside"),
            (
                |s| s.ending = Ending::Timeout,
                "ending 'timeout' does not fit (solved: true",
            ),
            (
                |s| {
                    s.solved = false;
                    s.stage = 0;
                    s.ending = Ending::Collision;
                },
                "ending 'collision' does not fit (solved: false, collided: false",
            ),
            (|s| s.fitness = f32::NAN, "fitness NaN"),
            (|s| s.cycles = 1001, "cycles 1001 exceeds"),
            (|s| s.stage = 0, "stage 0 does not fit"),
            (|s| s.variant = 3, "variant 3 answers a sample of variant 2"),
            (|s| s.variant = 4, "variant 4 is out of range"),
            (
                |s| s.sub_task_choices.cycles[0] = 1,
                "sub-task choices for a task without",
            ),
            (
                |s| s.descriptor.clear(),
                "a descriptor of 0 values, the task's has 2",
            ),
            (
                |s| s.descriptor[1] = f32::INFINITY,
                "descriptor value 1 (final.y) is inf, outside its range",
            ),
            (
                |s| s.descriptor[0] = 2.0e6,
                "descriptor value 0 (final.x) is 2000000, outside its range [-1000000, 1000000]",
            ),
        ];
        for (spoil, expected) in cases {
            let mut summary = good.clone();
            spoil(&mut summary);
            let error = summary.check(&task, 4, &sample).unwrap_err();
            assert!(error.starts_with(expected), "{error}");
        }
        let mut summary = good.clone();
        summary.node_use = NodeUse {
            active_cycles: vec![500, 10, 490],
            activations: vec![1, 11, 1],
        };
        assert!(
            summary
                .check(&task, 3, &sample)
                .unwrap_err()
                .contains("does not fit")
        );
        assert!(
            summary
                .check(&task, 4, &sample)
                .unwrap_err()
                .contains("the controller has 4")
        );
    }
}
