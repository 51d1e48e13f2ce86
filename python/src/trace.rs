//! `hevo.trace`: one sample of a complete controller, cycle by cycle, as `hevo replay` runs it
//! (the same evaluator, seed and variant), as numpy arrays: the poses of every robot, the
//! sensor inputs the controller read, its wheel outputs, the active node path; and the replay
//! picture of `hevo replay` (`to_svg`) and its table (`to_csv`, `to_json`, as
//! `hevo replay --trace-out` writes them).

use crate::controller::Controller;
use crate::task::Task;
use crate::{ConfigError, ControllerError, RunError};
use hevo_sim_core::Controller as Network;
use hevo_sim_core::SensorFrame;
use hevo_sim_core::{Evaluator, Sample};
use numpy::ndarray::{Array2, Array3};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use std::path::PathBuf;

/// One traced sample. Arrays have one row per control cycle (`len(trace)` rows).
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Trace {
    trace: hevo_sim_core::Trace,
    evaluator: Evaluator,
    node_paths: Vec<String>,
}

impl Trace {
    fn column<T: numpy::Element + Copy>(
        &self,
        py: Python<'_>,
        pick: impl Fn(&hevo_sim_core::TraceCycle) -> T,
    ) -> Py<PyArray1<T>> {
        let values: Vec<T> = self.trace.cycles.iter().map(pick).collect();
        PyArray1::from_vec(py, values).unbind()
    }

    fn rows<T: numpy::Element + Copy, const N: usize>(
        &self,
        py: Python<'_>,
        pick: impl Fn(&hevo_sim_core::TraceCycle) -> [T; N],
    ) -> PyResult<Py<PyArray2<T>>> {
        let values: Vec<T> = self.trace.cycles.iter().flat_map(pick).collect();
        let array = Array2::from_shape_vec((self.trace.cycles.len(), N), values)
            .map_err(|error| RunError::new_err(format!("internal: trace shape: {error}")))?;
        Ok(PyArray2::from_owned_array(py, array).unbind())
    }
}

#[pymethods]
impl Trace {
    /// The scenario's name.
    #[getter]
    fn task(&self) -> String {
        self.trace.scenario.clone()
    }

    /// The sample's seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.trace.sample.seed
    }

    /// The variant the sample ran (light configuration, start branch).
    #[getter]
    fn variant(&self) -> u32 {
        self.trace.outcome.variant
    }

    /// The outcome as `hevo eval` counts it: fitness, solved, collided, ending, cycles, stage,
    /// variant, node use.
    #[getter]
    fn outcome<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let value = serde_json::to_value(&self.trace.outcome)
            .map_err(|error| RunError::new_err(error.to_string()))?;
        crate::json_to_python(py, &value)
    }

    /// The controller's node paths; `active_path` and `active_node` index them.
    #[getter]
    fn node_paths(&self) -> Vec<String> {
        self.node_paths.clone()
    }

    /// The robots of `poses`, in order: `robot`, then `teammate` where the task has one, then
    /// a team's other robots (`[[robots]]`) by group and index in it: `swarm_0`, `swarm_1`, ...
    #[getter]
    fn robots(&self) -> Vec<String> {
        let teammate = self.has_teammate().then(|| "teammate".to_string());
        std::iter::once("robot".to_string())
            .chain(teammate)
            .chain(self.trace.team_member_names())
            .collect()
    }

    /// Poses at the start of each cycle (when the sensors were read): float32
    /// (cycles, robots, 3), x and y in metres and heading in radians, robots as `robots`.
    #[getter]
    fn poses(&self, py: Python<'_>) -> PyResult<Py<PyArray3<f32>>> {
        let robots = self.robots().len();
        let has_teammate = self.has_teammate();
        let mut values = Vec::with_capacity(self.trace.cycles.len() * robots * 3);
        for cycle in &self.trace.cycles {
            values.extend([cycle.robot.x, cycle.robot.y, cycle.robot.heading]);
            if has_teammate {
                // NaN for a cycle without the teammate (it exists in every cycle or none).
                values.extend(
                    cycle
                        .teammate
                        .map_or([f32::NAN; 3], |mate| [mate.x, mate.y, mate.heading]),
                );
            }
            values.extend(
                cycle
                    .team
                    .iter()
                    .flat_map(|pose| [pose.x, pose.y, pose.heading]),
            );
        }
        let array = Array3::from_shape_vec((self.trace.cycles.len(), robots, 3), values)
            .map_err(|error| RunError::new_err(format!("internal: trace shape: {error}")))?;
        Ok(PyArray3::from_owned_array(py, array).unbind())
    }

    /// The sensor inputs, float32 (cycles, inputs), columns as `input_names`: the four IR
    /// proximities, the two light inputs, near-robot, then the range-and-bearing board's four
    /// sectors and count, then the item sensor's four sectors and carrying; each in [0, 1]. A sensor the task's robot lacks reads 0.
    #[getter]
    fn inputs(&self, py: Python<'_>) -> PyResult<Py<PyArray2<f32>>> {
        self.rows(py, |cycle| cycle.frame.inputs)
    }

    /// The columns of `inputs`, every registered sensor's inputs in frame order.
    #[getter]
    fn input_names(&self) -> Vec<&'static str> {
        SensorFrame::INPUT_NAMES.to_vec()
    }

    /// The network outputs that drove the wheels, float32 (cycles, 2): left, right, in [0, 1].
    #[getter]
    fn outputs(&self, py: Python<'_>) -> PyResult<Py<PyArray2<f32>>> {
        self.rows(py, |cycle| cycle.wheels)
    }

    /// The active node path per cycle, root first: int16 (cycles, depth), indices into
    /// `node_paths`, padded with -1 where the path is shorter than the deepest one.
    #[getter]
    fn active_path(&self, py: Python<'_>) -> PyResult<Py<PyArray2<i16>>> {
        let depth = self
            .trace
            .cycles
            .iter()
            .map(|cycle| cycle.active_path.len())
            .max()
            .unwrap_or(0);
        let mut values = Vec::with_capacity(self.trace.cycles.len() * depth);
        for cycle in &self.trace.cycles {
            for level in 0..depth {
                values.push(
                    cycle
                        .active_path
                        .get(level)
                        .map_or(-1, |&node| i16::try_from(node).unwrap_or(i16::MAX)),
                );
            }
        }
        let array = Array2::from_shape_vec((self.trace.cycles.len(), depth), values)
            .map_err(|error| RunError::new_err(format!("internal: trace shape: {error}")))?;
        Ok(PyArray2::from_owned_array(py, array).unbind())
    }

    /// The node that drove the wheels per cycle (the last of the active path): int16 (cycles,).
    #[getter]
    fn active_node(&self, py: Python<'_>) -> Py<PyArray1<i16>> {
        self.column(py, |cycle| {
            cycle
                .active_path
                .last()
                .map_or(-1, |&node| i16::try_from(node).unwrap_or(i16::MAX))
        })
    }

    /// Whether the cycle's move was undone by a collision: bool (cycles,).
    #[getter]
    fn collided(&self, py: Python<'_>) -> Py<PyArray1<bool>> {
        self.column(py, |cycle| cycle.collided)
    }

    /// Bit i set when light i was lit in the cycle: uint32 (cycles,).
    #[getter]
    fn lit_lights(&self, py: Python<'_>) -> Py<PyArray1<u32>> {
        self.column(py, |cycle| cycle.lit_lights)
    }

    /// The rescue's sub-task in force (0 exit room, 1 solve maze, 2 return), else 0: uint8
    /// (cycles,).
    #[getter]
    fn sub_task(&self, py: Python<'_>) -> Py<PyArray1<u8>> {
        self.column(py, |cycle| cycle.sub_task)
    }

    /// Walls and obstacles, float32 (n, 5): each rectangle's centre x and y, half width and
    /// half height along its own axes, and rotation (radians), in metres.
    #[getter]
    fn walls(&self, py: Python<'_>) -> PyResult<Py<PyArray2<f32>>> {
        let values: Vec<f32> = self
            .trace
            .rects
            .iter()
            .flat_map(|rect| {
                [
                    rect.center[0],
                    rect.center[1],
                    rect.half_extents[0],
                    rect.half_extents[1],
                    rect.angle,
                ]
            })
            .collect();
        let array = Array2::from_shape_vec((self.trace.rects.len(), 5), values)
            .map_err(|error| RunError::new_err(format!("internal: trace shape: {error}")))?;
        Ok(PyArray2::from_owned_array(py, array).unbind())
    }

    /// The replay picture `hevo replay` draws, as SVG text; with `path`, also written there.
    /// `rays` draws the IR cones at those cycles; `animate` makes the robot move.
    #[pyo3(signature = (path=None, rays=Vec::new(), animate=false))]
    fn to_svg(&self, path: Option<PathBuf>, rays: Vec<u32>, animate: bool) -> PyResult<String> {
        let options = hevo_viz::ReplayOptions {
            node_names: self.node_paths.clone(),
            rays_at_cycles: rays,
            animate,
            title: None,
            robot_radius: self.evaluator.task().params.robot.radius,
            caption: None,
        };
        let svg =
            hevo_viz::replay_svg(&self.trace, &options, &|pose| self.evaluator.ir_cones(pose));
        if let Some(path) = path {
            write(&path, &svg)?;
        }
        Ok(svg)
    }

    /// The table `hevo replay --trace-out FILE.csv` writes, one row per cycle; with `path`,
    /// also written there.
    #[pyo3(signature = (path=None))]
    fn to_csv(&self, path: Option<PathBuf>) -> PyResult<String> {
        let text = hevo_viz::trace_table::trace_csv(&self.trace, &self.node_paths);
        if let Some(path) = path {
            write(&path, &text)?;
        }
        Ok(text)
    }

    /// The document `hevo replay --trace-out FILE.json` writes; with `path`, also written there.
    #[pyo3(signature = (path=None))]
    fn to_json(&self, path: Option<PathBuf>) -> PyResult<String> {
        let text = hevo_viz::trace_table::trace_json(&self.trace, &self.node_paths)
            .map_err(|error| RunError::new_err(error.to_string()))?;
        if let Some(path) = path {
            write(&path, &text)?;
        }
        Ok(text)
    }

    fn __len__(&self) -> usize {
        self.trace.cycles.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Trace('{}', seed {}, variant {}, {} cycles, {:?})",
            self.trace.scenario,
            self.trace.sample.seed,
            self.trace.outcome.variant,
            self.trace.cycles.len(),
            self.trace.outcome.ending
        )
    }
}

impl Trace {
    fn has_teammate(&self) -> bool {
        self.trace
            .cycles
            .iter()
            .any(|cycle| cycle.teammate.is_some())
    }
}

fn write(path: &std::path::Path, text: &str) -> PyResult<()> {
    hevo_engine::store::write_atomic(path, text.as_bytes())
        .map_err(|error| RunError::new_err(format!("cannot write {}: {error}", path.display())))
}

/// Runs one sample of a complete controller on `task`, recording every cycle, as
/// `hevo replay CONTROLLER --task T --seed SEED [--light-config VARIANT]` does. `variant`
/// fixes the light configuration (or start branch) instead of drawing it from the seed.
#[pyfunction]
#[pyo3(signature = (controller, task, seed=0, variant=None))]
pub fn trace(
    py: Python<'_>,
    controller: &Controller,
    task: &Task,
    seed: u64,
    variant: Option<u32>,
) -> PyResult<Trace> {
    let file = controller.file.clone();
    if let Some((node, _)) = file.free_node_topology() {
        return Err(ControllerError::new_err(format!(
            "node '{node}' has no genome; a controller to trace must be complete"
        )));
    }
    let task = task.config.clone();
    let n_variants = task.scenario.n_variants();
    if let Some(k) = variant
        && k >= n_variants
    {
        return Err(ConfigError::new_err(format!(
            "variant {k} is out of range: task {} has {n_variants} configuration(s) (0..{})",
            task.name(),
            n_variants - 1
        )));
    }
    hevo_sim_core::controller_fits(&file, &task.scenario)
        .map_err(|problem| ControllerError::new_err(format!("the controller {problem}")))?;
    let mut network = Network::new(&file, None)
        .map_err(|error| ControllerError::new_err(crate::message(&error)))?;
    let evaluator =
        Evaluator::new(task).map_err(|error| ConfigError::new_err(crate::message(&error)))?;
    let node_paths = (0..network.n_nodes())
        .map(|i| network.node_path(i).unwrap_or("?").to_string())
        .collect();
    let trace = py.detach(|| evaluator.evaluate_traced(&mut network, Sample { seed, variant }));
    Ok(Trace {
        trace,
        evaluator,
        node_paths,
    })
}
