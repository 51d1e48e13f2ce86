//! Batch evaluation: the one function every worker (in-process or remote) calls. A batch is a
//! controller template (a controller file whose free node gets each genome's genes), a task and
//! a list of samples shared by all genomes; the result is one outcome per (genome, sample).
//! Built once per batch and shared by reference between the worker's threads.

use crate::controller::{Controller, ControllerError, ControllerFile};
use crate::evaluate::{Evaluator, NodeUse, Outcome, Policy, Sample, SubTaskChoices, TaskError};
use crate::frame::SensorFrame;
use crate::task::TaskConfig;

impl Policy for Controller {
    fn reset(&mut self) {
        Controller::reset(self);
    }

    #[inline]
    fn step(&mut self, frame: &SensorFrame, dt: f32) -> [f32; 2] {
        let wheels = Controller::step(self, frame, dt);
        [wheels.left, wheels.right]
    }

    fn root_choice(&self) -> Option<usize> {
        Controller::root_choice(self)
    }

    fn active_path(&self) -> &[usize] {
        Controller::active_path(self)
    }

    fn n_nodes(&self) -> usize {
        Controller::n_nodes(self)
    }
}

/// Why a batch cannot be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The task configuration is invalid.
    #[error(transparent)]
    Task(#[from] TaskError),
    /// The controller template or a genome does not fit.
    #[error(transparent)]
    Controller(#[from] ControllerError),
}

/// A validated (controller template, task) pair ready to evaluate genomes.
#[derive(Debug)]
pub struct BatchEvaluator {
    template: ControllerFile,
    evaluator: Evaluator,
    /// Number of genes the free node takes (0 when the template has no free node).
    n_free_genes: usize,
}

impl BatchEvaluator {
    /// Validates the template and the task once.
    pub fn new(template: ControllerFile, task: TaskConfig) -> Result<BatchEvaluator, BatchError> {
        template.validate()?;
        let n_free_genes = template
            .free_node_topology()
            .map_or(0, |(_, topology)| topology.n_genes());
        Ok(BatchEvaluator {
            template,
            evaluator: Evaluator::new(task)?,
            n_free_genes,
        })
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

    /// Evaluates one genome on every sample, in order.
    pub fn evaluate_genome(
        &self,
        genes: Option<&[f32]>,
        samples: &[Sample],
    ) -> Result<Vec<Outcome>, ControllerError> {
        let mut controller = self.controller(genes)?;
        Ok(samples
            .iter()
            .map(|&sample| self.evaluator.evaluate(&mut controller, sample))
            .collect())
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
}

impl From<&Outcome> for SampleSummary {
    fn from(outcome: &Outcome) -> SampleSummary {
        SampleSummary {
            fitness: outcome.fitness,
            solved: outcome.solved,
            collided: outcome.collided,
            stage: outcome.stage,
            variant: outcome.variant,
            cycles: outcome.cycles,
            sub_task_choices: outcome.sub_task_choices,
            node_use: outcome.node_use.clone(),
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
        let mut controller = self.controller(genes)?;
        Ok(samples
            .iter()
            .map(|&sample| SampleSummary::from(&self.evaluator.evaluate(&mut controller, sample)))
            .collect())
    }
}

/// A stable content hash of a task configuration (FNV-1a over its canonical JSON), so workers
/// can cache evaluators by (template hash, task hash).
pub fn task_content_hash(task: &TaskConfig) -> String {
    let json = serde_json::to_string(task).unwrap_or_default();
    crate::hash::fnv1a_hex(json.as_bytes())
}
