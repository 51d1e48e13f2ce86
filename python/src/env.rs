//! `hevo.Env` and `hevo.VectorEnv`: a task as an environment any policy can drive, with
//! Gymnasium's conventions (`reset(seed, options) -> (obs, info)`, `step(action) -> (obs,
//! reward, terminated, truncated, info)`). Each episode is one sample of the task, run by
//! sim-core's `Episode`, the evaluator's own control loop: observations are the robot's sensor
//! frame (the inputs `hevo.trace` records), actions the two wheel outputs, and the reward the
//! task's fitness at the end. `VectorEnv` steps N episodes in Rust per call, the GIL released,
//! and resets an ended one at its next step (Gymnasium's next-step autoreset).
//!
//! Samples: a lane seeded `s` runs episode k on the sample of seed `derive_seed(s, [k])`, its
//! variant drawn from that seed, as `hevo.trace(controller, task, seed=...)` runs it; every
//! info names the sample's seed, so any episode can be traced or evaluated again.
//!
//! Positions: every info shows, after every reset and step, where everything besides the
//! robot is (a team's other robots, movers, boxes, items), each key only in a scenario that
//! has such bodies, so a single-robot task's info is as it was; `VectorEnv`'s with a leading
//! environment axis and Gymnasium's masks.

use crate::genomes::{Floats, float_array, floats_2d};
use crate::task::Task;
use crate::{ConfigError, RunError};
use hevo_sim_core::{
    CycleItem, Ending, Episode, Evaluator, N_FLAT, Outcome, Pose, Sample, SensorFrame, WHEEL_RANGE,
    derive_seed,
};
use numpy::ndarray::{Array1, Array2, ArrayD, IxDyn};
use numpy::{PyArray1, PyArray2, PyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::sync::{Mutex, MutexGuard};

/// Each lane's episode; `None` before the first reset and after an episode ended.
type Episodes<'e> = Vec<Option<Episode<'e>>>;

self_cell::self_cell!(
    /// A task's evaluator and the lanes' episodes, which borrow it.
    struct Lanes {
        owner: Evaluator,
        #[covariant]
        dependent: Episodes,
    }
    impl {Debug}
);

/// Where a lane's samples come from.
#[derive(Debug, Clone, Copy)]
struct LaneSeed {
    /// The lane's seed, as `reset(seed=...)` set it.
    seed: u64,
    /// Episodes started from `seed` so far.
    episodes: u64,
    /// The sample of the lane's current (or last) episode.
    sample: Sample,
}

impl LaneSeed {
    fn new(seed: u64) -> LaneSeed {
        LaneSeed {
            seed,
            episodes: 0,
            sample: Sample::seeded(0),
        }
    }

    /// The next episode's sample: the `episodes`-th of the lane's seed.
    fn next_sample(&mut self) -> Sample {
        self.sample = Sample::seeded(derive_seed(self.seed, &[self.episodes]));
        self.episodes += 1;
        self.sample
    }
}

/// A seed from the operating system's entropy, as Gymnasium draws one when given none.
fn entropy_seed() -> u64 {
    use std::hash::BuildHasher;
    std::collections::hash_map::RandomState::new().hash_one(0x6865_766f_u64)
}

/// What ended in a step: the lane, its outcome and its sample.
#[derive(Debug)]
struct Ended {
    lane: usize,
    outcome: Outcome,
    sample: Sample,
}

/// Where everything besides the focal robot is at one moment of an episode: what `Env`'s info
/// shows per cycle.
#[derive(Debug, Default)]
struct Positions {
    /// A team's other robots, group by group.
    team: Vec<Pose>,
    /// The movers' centres, by mover.
    movers: Vec<[f32; 2]>,
    /// The boxes' centres, by box.
    boxes: Vec<[f32; 2]>,
    /// The items, by item.
    items: Vec<CycleItem>,
}

impl Positions {
    /// `episode`'s now, in a scenario of `n_movers` movers (its bodies list movers first).
    fn of(episode: &Episode<'_>, n_movers: usize) -> Positions {
        let mut movers = episode.body_centres();
        let boxes = movers.split_off(n_movers.min(movers.len()));
        Positions {
            team: episode.team_poses(),
            movers,
            boxes,
            items: episode.item_places(),
        }
    }
}

/// Sets info's position keys from each lane's positions (`lanes`; all of one scenario, so of
/// one size), each key only for a scenario with such bodies: `team_poses` (n, 3: x, y,
/// heading), `mover_positions`, `box_positions`, `item_positions` (n, 2: x, y), and with the
/// items `item_carried` and `item_delivered` (n,); float64 and bool. `batched` (`VectorEnv`)
/// puts a leading lane axis on each and adds its mask (`_team_poses`, ..., every lane set);
/// else `lanes` is the one environment's.
fn set_positions_info(
    info: &Bound<'_, PyDict>,
    lanes: &[Positions],
    batched: bool,
) -> PyResult<()> {
    let Some(first) = lanes.first() else {
        return Ok(());
    };
    let py = info.py();
    let set = |key: &str, array: Bound<'_, PyAny>| -> PyResult<()> {
        info.set_item(key, array)?;
        if batched {
            info.set_item(
                format!("_{key}"),
                PyArray1::from_vec(py, vec![true; lanes.len()]),
            )?;
        }
        Ok(())
    };
    // `(lanes, n, ...row)` batched, else `(n, ...row)`.
    let shape = |n: usize, row: &[usize]| -> Vec<usize> {
        let lead = if batched {
            vec![lanes.len(), n]
        } else {
            vec![n]
        };
        lead.into_iter().chain(row.iter().copied()).collect()
    };
    if !first.team.is_empty() {
        let flat: Vec<f64> = lanes
            .iter()
            .flat_map(|lane| &lane.team)
            .flat_map(|pose| [pose.x, pose.y, pose.heading].map(f64::from))
            .collect();
        set(
            "team_poses",
            shaped(py, &shape(first.team.len(), &[3]), flat)?,
        )?;
    }
    let centres = |pick: fn(&Positions) -> &Vec<[f32; 2]>| -> Vec<f64> {
        lanes
            .iter()
            .flat_map(pick)
            .flat_map(|centre| centre.map(f64::from))
            .collect()
    };
    if !first.movers.is_empty() {
        let flat = centres(|lane| &lane.movers);
        set(
            "mover_positions",
            shaped(py, &shape(first.movers.len(), &[2]), flat)?,
        )?;
    }
    if !first.boxes.is_empty() {
        let flat = centres(|lane| &lane.boxes);
        set(
            "box_positions",
            shaped(py, &shape(first.boxes.len(), &[2]), flat)?,
        )?;
    }
    if !first.items.is_empty() {
        let n = first.items.len();
        let items = || lanes.iter().flat_map(|lane| &lane.items);
        let flat: Vec<f64> = items().flat_map(|item| item.at.map(f64::from)).collect();
        set("item_positions", shaped(py, &shape(n, &[2]), flat)?)?;
        let carried: Vec<bool> = items().map(|item| item.carried).collect();
        set("item_carried", shaped(py, &shape(n, &[]), carried)?)?;
        let delivered: Vec<bool> = items().map(|item| item.delivered).collect();
        set("item_delivered", shaped(py, &shape(n, &[]), delivered)?)?;
    }
    Ok(())
}

/// `flat` as a numpy array of `shape`.
fn shaped<'py, T: numpy::Element>(
    py: Python<'py>,
    shape: &[usize],
    flat: Vec<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let array = ArrayD::from_shape_vec(IxDyn(shape), flat)
        .map_err(|error| RunError::new_err(format!("internal: positions' shape: {error}")))?;
    Ok(PyArrayDyn::from_owned_array(py, array).into_any())
}

/// The environments' state: the evaluator, one episode per lane, and each lane's seeds and
/// last observation (what an ended episode shows until it is reset).
#[derive(Debug)]
struct Core {
    lanes: Lanes,
    seeds: Vec<LaneSeed>,
    frames: Vec<SensorFrame>,
}

impl Core {
    fn new(task: &Task, seeds: Vec<u64>) -> PyResult<Core> {
        let scenario = &task.config.scenario;
        if scenario.has_evolved_team() {
            // Its other robots would run copies of a controller the environment does not have.
            return Err(ConfigError::new_err(format!(
                "{}: the team's `evolved` robots ([[robots]]) run copies of an evaluated \
                 controller, which an environment stepped from Python has none of; evaluate \
                 controllers on it with hevo.evaluate",
                scenario.origin
            )));
        }
        let evaluator = Evaluator::new(task.config.clone())
            .map_err(|error| ConfigError::new_err(crate::message(&error)))?;
        let n_lanes = seeds.len();
        Ok(Core {
            lanes: Lanes::new(evaluator, |_| (0..n_lanes).map(|_| None).collect()),
            seeds: seeds.into_iter().map(LaneSeed::new).collect(),
            frames: vec![SensorFrame::default(); n_lanes],
        })
    }

    fn evaluator(&self) -> &Evaluator {
        self.lanes.borrow_owner()
    }

    fn n_variants(&self) -> u32 {
        self.evaluator().task().scenario.n_variants()
    }

    /// Starts `sample` in `lane` (the lane's next one when `None`), ending what ran there.
    fn start(&mut self, lane: usize, sample: Option<Sample>) -> Sample {
        let sample = match sample {
            Some(sample) => {
                self.seeds[lane].sample = sample;
                sample
            }
            None => self.seeds[lane].next_sample(),
        };
        let frame = self.lanes.with_dependent_mut(|evaluator, episodes| {
            let episode = Episode::new(evaluator, sample);
            let frame = *episode.frame();
            episodes[lane] = Some(episode);
            frame
        });
        self.frames[lane] = frame;
        sample
    }

    fn running(&self, lane: usize) -> bool {
        self.lanes.borrow_dependent()[lane].is_some()
    }

    /// Where everything besides the focal robot is in `lane`'s running episode (nothing once
    /// it ended).
    fn positions(&self, lane: usize) -> Positions {
        let n_movers = self.evaluator().task().scenario.movers.len();
        self.lanes.borrow_dependent()[lane]
            .as_ref()
            .map_or_else(Positions::default, |episode| {
                Positions::of(episode, n_movers)
            })
    }

    /// One cycle of `lane`'s running episode; its outcome if it ended there. The wheels are
    /// finite (checked by the caller), so a running episode takes them. `positions` receives
    /// where everything besides the focal robot is after the cycle (where it ended, if it
    /// ended), when asked for (`Env`'s info).
    fn step(
        &mut self,
        lane: usize,
        wheels: [f32; 2],
        positions: Option<&mut Positions>,
    ) -> Result<Option<Ended>, String> {
        let sample = self.seeds[lane].sample;
        let n_movers = self.evaluator().task().scenario.movers.len();
        let (frame, outcome) = self.lanes.with_dependent_mut(|_, episodes| {
            let Some(episode) = episodes[lane].as_mut() else {
                return Err(
                    "no episode is running: call reset() first (after an episode ended too)"
                        .to_string(),
                );
            };
            let ended = episode.step(wheels).map_err(|error| error.to_string())?;
            let frame = *episode.frame();
            if let Some(positions) = positions {
                *positions = Positions::of(episode, n_movers);
            }
            let outcome = match ended {
                Some(_) => episodes[lane].take().and_then(Episode::into_outcome),
                None => None,
            };
            Ok((frame, outcome))
        })?;
        self.frames[lane] = frame;
        Ok(outcome.map(|outcome| Ended {
            lane,
            outcome,
            sample,
        }))
    }

    fn lock(core: &Mutex<Core>) -> PyResult<MutexGuard<'_, Core>> {
        core.lock()
            .map_err(|_| RunError::new_err("the environment failed in an earlier call"))
    }
}

/// The wheel outputs of `action`, each a finite float (clipped to [`WHEEL_RANGE`] by the
/// episode); `name` names the action in errors.
fn wheels_of(values: [f64; 2], name: &str) -> PyResult<[f32; 2]> {
    let mut wheels = [0.0f32; 2];
    for (wheel_idx, (&value, wheel)) in values.iter().zip(&mut wheels).enumerate() {
        if !value.is_finite() {
            return Err(PyValueError::new_err(format!(
                "{name}[{wheel_idx}] ({} wheel) is {value:?}: actions must be finite",
                if wheel_idx == 0 { "left" } else { "right" }
            )));
        }
        // Rounds to the nearest f32, as genomes are rounded.
        *wheel = value as f32;
    }
    Ok(wheels)
}

/// `actions` (any float dtype, shape `(n_lanes, 2)`) as each lane's wheels, every value
/// checked before any lane steps.
fn actions_of(actions: &Bound<'_, PyAny>, n_lanes: usize) -> PyResult<Vec<[f32; 2]>> {
    let array = float_array(actions, "actions", |shape| {
        if shape == [n_lanes, 2] {
            Ok(())
        } else {
            Err(PyValueError::new_err(format!(
                "actions must have shape ({n_lanes}, 2), a left and a right wheel output per \
                 environment; got shape {shape:?}"
            )))
        }
    })?;
    let rows: Vec<[f64; 2]> = match floats_2d(array)? {
        Floats::Single(single) => single
            .as_array()
            .rows()
            .into_iter()
            .map(|row| [f64::from(row[0]), f64::from(row[1])])
            .collect(),
        Floats::Double(double) => double
            .as_array()
            .rows()
            .into_iter()
            .map(|row| [row[0], row[1]])
            .collect(),
    };
    rows.into_iter()
        .enumerate()
        .map(|(lane, row)| wheels_of(row, &format!("actions[{lane}]")))
        .collect()
}

/// A single `action` (any float dtype, two values) as wheel outputs.
fn action_of(action: &Bound<'_, PyAny>) -> PyResult<[f32; 2]> {
    let row = float_array(action, "action", |shape| {
        if shape == [2] {
            Ok(())
        } else {
            Err(PyValueError::new_err(format!(
                "action must have shape (2,), a left and a right wheel output; got shape \
                 {shape:?}"
            )))
        }
    })?
    .call_method1("reshape", (1, 2))?;
    let values = match floats_2d(row)? {
        Floats::Single(single) => {
            let row = single.as_array();
            [f64::from(row[[0, 0]]), f64::from(row[[0, 1]])]
        }
        Floats::Double(double) => {
            let row = double.as_array();
            [row[[0, 0]], row[[0, 1]]]
        }
    };
    wheels_of(values, "action")
}

fn ending_name(ending: Ending) -> &'static str {
    match ending {
        Ending::Solved => "solved",
        Ending::Collision => "collision",
        Ending::WrongBranch => "wrong_branch",
        Ending::Timeout => "timeout",
    }
}

/// (terminated, truncated) for an ending: the cycle limit truncates, every other ending
/// terminates.
fn end_flags(ending: Ending) -> (bool, bool) {
    (ending != Ending::Timeout, ending == Ending::Timeout)
}

/// The bounds of observations or actions, as Gymnasium's `Box` space gives them: `shape`,
/// `low`, `high` (float32 arrays of that shape) and `dtype`. Without Gymnasium installed;
/// `gymnasium.spaces.Box(space.low, space.high, dtype=space.dtype)` makes the Gymnasium one.
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Space {
    shape: Vec<usize>,
    /// Each element's lowest value: float32, `shape`.
    #[pyo3(get)]
    low: Py<PyAny>,
    /// Each element's highest value: float32, `shape`.
    #[pyo3(get)]
    high: Py<PyAny>,
    lowest: f32,
    highest: f32,
}

impl Space {
    /// `shape` with every element in [lowest, highest].
    fn new(py: Python<'_>, shape: Vec<usize>, lowest: f32, highest: f32) -> PyResult<Space> {
        let filled = |value: f32| -> PyResult<Py<PyAny>> {
            let n: usize = shape.iter().product();
            let flat = PyArray1::from_vec(py, vec![value; n]);
            Ok(flat.call_method1("reshape", (shape.clone(),))?.unbind())
        };
        Ok(Space {
            low: filled(lowest)?,
            high: filled(highest)?,
            shape,
            lowest,
            highest,
        })
    }
}

#[pymethods]
impl Space {
    /// The shape of a value, a tuple.
    #[getter]
    fn shape<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(py, &self.shape)
    }

    /// The dtype of values: `"float32"`.
    #[getter]
    fn dtype(&self) -> &'static str {
        "float32"
    }

    fn __repr__(&self) -> String {
        let shape: Vec<String> = self.shape.iter().map(usize::to_string).collect();
        let trailing = if self.shape.len() == 1 { "," } else { "" };
        format!(
            "Space(shape=({}{trailing}), low={}, high={}, dtype=float32)",
            shape.join(", "),
            self.lowest,
            self.highest
        )
    }
}

/// The names of the observation's columns: every registered sensor's inputs, in frame order.
fn observation_names() -> Vec<&'static str> {
    SensorFrame::INPUT_NAMES.to_vec()
}

/// The options `reset` takes: `sample_seed` and `variant` (`Env` only).
fn reset_sample(
    options: Option<&Bound<'_, PyDict>>,
    core: &mut Core,
    single: bool,
) -> PyResult<Option<Sample>> {
    let Some(options) = options else {
        return Ok(None);
    };
    let mut sample_seed = None;
    let mut variant = None;
    for (key, value) in options.iter() {
        let key: String = key.extract()?;
        match key.as_str() {
            "sample_seed" if single => sample_seed = Some(value.extract::<u64>()?),
            "variant" if single => variant = Some(value.extract::<u32>()?),
            _ => {
                let known = if single {
                    "the options are 'sample_seed' and 'variant'"
                } else {
                    "VectorEnv.reset takes no options"
                };
                return Err(ConfigError::new_err(format!(
                    "reset: unknown option '{key}'; {known}"
                )));
            }
        }
    }
    let n_variants = core.n_variants();
    if let Some(variant) = variant
        && variant >= n_variants
    {
        return Err(ConfigError::new_err(format!(
            "reset: variant {variant} is out of range: task {} has {n_variants} variant(s) (0..{})",
            core.evaluator().task().name(),
            n_variants - 1
        )));
    }
    Ok(match (sample_seed, variant) {
        (None, None) => None,
        (Some(seed), variant) => Some(Sample { seed, variant }),
        // A variant alone: the lane's next seed, in that variant.
        (None, variant) => Some(Sample {
            seed: core.seeds[0].next_sample().seed,
            variant,
        }),
    })
}

fn frame_array<'py>(py: Python<'py>, frame: &SensorFrame) -> Bound<'py, PyArray1<f32>> {
    PyArray1::from_slice(py, &frame.inputs)
}

/// One sample of a task as an environment, with Gymnasium's conventions. Observations are the
/// robot's sensor frame, float32 `(n_obs,)`, each in [0, 1], columns as `observation_names`
/// (a sensor the task's robot lacks reads 0); actions are the two wheel outputs (left, right)
/// in [0, 1] (0 full speed backwards, 0.5 still, 1 full speed forwards, as a controller's
/// outputs and `trace.outputs`), clipped to it, NaN and infinity refused. The reward is 0
/// until the episode ends, then the task's fitness; `terminated` when the task ended it
/// (solved, collision, wrong branch), `truncated` at the task's cycle limit.
///
/// Every info also says where everything besides the robot is, each key only in a scenario
/// with such bodies (absent, not empty, without): `team_poses` (a team's other robots, float64
/// `(n, 3)`: x, y in metres, heading in radians, in the order of `trace.robots`),
/// `mover_positions` and `box_positions` (centres, float64 `(n, 2)`), `item_positions`
/// (float64 `(n, 2)`: where an item lies, its carrier's centre while carried, where it was
/// delivered once delivered) with `item_carried` and `item_delivered` (bool `(n,)`).
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct Env {
    core: Mutex<Core>,
    /// The bounds of an observation: `Space` of shape `(n_obs,)` in [0, 1].
    #[pyo3(get)]
    observation_space: Py<Space>,
    /// The bounds of an action: `Space` of shape `(2,)` in [0, 1].
    #[pyo3(get)]
    action_space: Py<Space>,
}

#[pymethods]
impl Env {
    /// An environment of `task`'s samples. `seed` seeds the episodes as `reset(seed=...)`
    /// does (from the operating system's entropy when `None`, as Gymnasium does).
    #[new]
    #[pyo3(signature = (task, seed=None))]
    fn new(py: Python<'_>, task: &Task, seed: Option<u64>) -> PyResult<Env> {
        let core = Core::new(task, vec![seed.unwrap_or_else(entropy_seed)])?;
        Ok(Env {
            core: Mutex::new(core),
            observation_space: Py::new(py, Space::new(py, vec![N_FLAT], 0.0, 1.0)?)?,
            action_space: Py::new(py, Space::new(py, vec![2], WHEEL_RANGE.0, WHEEL_RANGE.1)?)?,
        })
    }

    /// Starts an episode: `(observation, info)`. `seed` restarts the episodes from that seed
    /// (the first episode after `reset(seed=s)` is always the same sample); without it, the
    /// next episode of the current seed. `options={"sample_seed": s, "variant": v}` runs that
    /// sample exactly (as `hevo.trace(controller, task, seed=s, variant=v)`; `variant` drawn
    /// from the seed when omitted). info: `sample_seed`, `variant`, and the positions at the
    /// start (see `Env`).
    #[pyo3(signature = (seed=None, options=None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<u64>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyDict>)> {
        let mut core = Core::lock(&self.core)?;
        if let Some(seed) = seed {
            core.seeds[0] = LaneSeed::new(seed);
        }
        let sample = reset_sample(options, &mut core, true)?;
        let sample = core.start(0, sample);
        let info = PyDict::new(py);
        info.set_item("sample_seed", sample.seed)?;
        let variant = core.lanes.borrow_dependent()[0]
            .as_ref()
            .map_or(0, Episode::variant);
        info.set_item("variant", variant)?;
        set_positions_info(&info, &[core.positions(0)], false)?;
        Ok((frame_array(py, &core.frames[0]), info))
    }

    /// One control cycle with `action` (left, right wheel outputs; any float dtype):
    /// `(observation, reward, terminated, truncated, info)`. When the episode ends, info holds
    /// its outcome (`fitness`, `solved`, `collided`, `ending`, `stage`, `variant`, `cycles`,
    /// `sample_seed`) and the observation is its last cycle's frame (nothing is sensed after
    /// the end); step again only after `reset()`. Every info holds the positions after the
    /// step (where they ended, at the end; see `Env`).
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &self,
        py: Python<'py>,
        action: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray1<f32>>,
        f64,
        bool,
        bool,
        Bound<'py, PyDict>,
    )> {
        let wheels = action_of(action)?;
        let mut core = Core::lock(&self.core)?;
        let mut positions = Positions::default();
        let ended = core
            .step(0, wheels, Some(&mut positions))
            .map_err(RunError::new_err)?;
        let obs = frame_array(py, &core.frames[0]);
        let info = PyDict::new(py);
        set_positions_info(&info, &[positions], false)?;
        let Some(ended) = ended else {
            return Ok((obs, 0.0, false, false, info));
        };
        let outcome = &ended.outcome;
        info.set_item("fitness", outcome.fitness)?;
        info.set_item("solved", outcome.solved)?;
        info.set_item("collided", outcome.collided)?;
        info.set_item("ending", ending_name(outcome.ending))?;
        info.set_item("stage", outcome.stage)?;
        info.set_item("variant", outcome.variant)?;
        info.set_item("cycles", outcome.cycles)?;
        info.set_item("sample_seed", ended.sample.seed)?;
        let (terminated, truncated) = end_flags(outcome.ending);
        Ok((obs, f64::from(outcome.fitness), terminated, truncated, info))
    }

    /// The names of the observation's columns (`trace.input_names`).
    #[getter]
    fn observation_names(&self) -> Vec<&'static str> {
        observation_names()
    }

    /// The task's cycle limit: an episode is truncated after this many steps.
    #[getter]
    fn max_episode_steps(&self) -> PyResult<u32> {
        Ok(Core::lock(&self.core)?.evaluator().task().max_cycles())
    }

    /// Whether an episode is running (reset and not yet ended).
    #[getter]
    fn running(&self) -> PyResult<bool> {
        Ok(Core::lock(&self.core)?.running(0))
    }

    /// Nothing to release; for Gymnasium's interface.
    fn close(&self) {}

    fn __repr__(&self) -> PyResult<String> {
        let core = Core::lock(&self.core)?;
        Ok(format!(
            "Env('{}', seed {})",
            core.evaluator().task().name(),
            core.seeds[0].seed
        ))
    }
}

/// Per-lane arrays of one vector step.
#[derive(Debug)]
struct VectorStep {
    obs: Vec<f32>,
    rewards: Vec<f64>,
    terminated: Vec<bool>,
    truncated: Vec<bool>,
    ended: Vec<Ended>,
    /// Lanes that began an episode in this step (autoreset), with its sample and variant.
    started: Vec<(usize, Sample, u32)>,
    /// Each lane's positions after the step (where its episode ended, or began).
    positions: Vec<Positions>,
}

impl Core {
    /// One step of every lane: an ended lane starts its next episode (its action unused),
    /// every other lane runs a cycle.
    fn step_lanes(&mut self, actions: &[[f32; 2]]) -> Result<VectorStep, String> {
        let n_lanes = self.seeds.len();
        let mut step = VectorStep {
            obs: Vec::with_capacity(n_lanes * N_FLAT),
            rewards: vec![0.0; n_lanes],
            terminated: vec![false; n_lanes],
            truncated: vec![false; n_lanes],
            ended: Vec::new(),
            started: Vec::new(),
            positions: Vec::with_capacity(n_lanes),
        };
        for (lane, &wheels) in actions.iter().enumerate() {
            if self.running(lane) {
                let mut positions = Positions::default();
                let ended = self.step(lane, wheels, Some(&mut positions))?;
                step.positions.push(positions);
                if let Some(ended) = ended {
                    step.rewards[lane] = f64::from(ended.outcome.fitness);
                    (step.terminated[lane], step.truncated[lane]) = end_flags(ended.outcome.ending);
                    step.ended.push(ended);
                }
            } else {
                let sample = self.start(lane, None);
                let variant = self.lanes.borrow_dependent()[lane]
                    .as_ref()
                    .map_or(0, Episode::variant);
                step.started.push((lane, sample, variant));
                step.positions.push(self.positions(lane));
            }
            step.obs.extend_from_slice(&self.frames[lane].inputs);
        }
        Ok(step)
    }
}

/// Sets `info[key]` to `values` (one per lane, `default` where none) and `info["_" + key]` to
/// the mask of lanes that have one: Gymnasium's vector info.
fn set_lane_info<'py, T: numpy::Element + Copy>(
    info: &Bound<'py, PyDict>,
    key: &str,
    n_lanes: usize,
    default: T,
    values: impl IntoIterator<Item = (usize, T)>,
) -> PyResult<()> {
    let py = info.py();
    let mut column = vec![default; n_lanes];
    let mut mask = vec![false; n_lanes];
    for (lane, value) in values {
        column[lane] = value;
        mask[lane] = true;
    }
    info.set_item(key, PyArray1::from_vec(py, column))?;
    info.set_item(format!("_{key}"), PyArray1::from_vec(py, mask))?;
    Ok(())
}

/// `n_envs` samples of a task stepped together in Rust, the GIL released: Gymnasium's vector
/// conventions, `Env`'s observations, actions and rewards with a leading `n_envs` axis
/// (observations float32 `(n_envs, n_obs)`, actions `(n_envs, 2)` of any float dtype, rewards
/// float64, terminated and truncated bool `(n_envs,)`). Autoreset is Gymnasium's next-step
/// mode: the step after the one an episode ended in starts that environment's next episode,
/// returns its first observation with reward 0, terminated and truncated False, and ignores
/// its action. Environment i is seeded `seed + i`, as Gymnasium's vector environments seed
/// theirs, so it runs the samples of `Env(task, seed + i)`.
#[pyclass(module = "hevo", frozen)]
#[derive(Debug)]
pub struct VectorEnv {
    core: Mutex<Core>,
    /// The number of environments.
    #[pyo3(get)]
    num_envs: usize,
    /// The bounds of one environment's observation: shape `(n_obs,)`.
    #[pyo3(get)]
    single_observation_space: Py<Space>,
    /// The bounds of one environment's action: shape `(2,)`.
    #[pyo3(get)]
    single_action_space: Py<Space>,
    /// The bounds of the batched observations: shape `(num_envs, n_obs)`.
    #[pyo3(get)]
    observation_space: Py<Space>,
    /// The bounds of the batched actions: shape `(num_envs, 2)`.
    #[pyo3(get)]
    action_space: Py<Space>,
}

/// Lane `lane`'s seed when the environments are seeded `seed`.
fn lane_seed(seed: u64, lane: usize) -> u64 {
    seed.wrapping_add(lane as u64)
}

#[pymethods]
impl VectorEnv {
    /// `n_envs` environments of `task`, environment i seeded `seed + i` (`seed` from the
    /// operating system's entropy when `None`).
    #[new]
    #[pyo3(signature = (task, n_envs, seed=None))]
    fn new(py: Python<'_>, task: &Task, n_envs: usize, seed: Option<u64>) -> PyResult<VectorEnv> {
        // Each lane holds a world and its sensors' state: a bound keeps a typo from taking
        // the machine's memory.
        const MAX_ENVS: usize = 1 << 16;
        if !(1..=MAX_ENVS).contains(&n_envs) {
            return Err(PyValueError::new_err(format!(
                "n_envs is {n_envs}; it must be between 1 and {MAX_ENVS}"
            )));
        }
        let seed = seed.unwrap_or_else(entropy_seed);
        let seeds = (0..n_envs).map(|lane| lane_seed(seed, lane)).collect();
        let core = Core::new(task, seeds)?;
        let space = |shape: Vec<usize>, (low, high): (f32, f32)| -> PyResult<Py<Space>> {
            Py::new(py, Space::new(py, shape, low, high)?)
        };
        Ok(VectorEnv {
            core: Mutex::new(core),
            num_envs: n_envs,
            single_observation_space: space(vec![N_FLAT], (0.0, 1.0))?,
            single_action_space: space(vec![2], WHEEL_RANGE)?,
            observation_space: space(vec![n_envs, N_FLAT], (0.0, 1.0))?,
            action_space: space(vec![n_envs, 2], WHEEL_RANGE)?,
        })
    }

    /// Starts an episode in every environment: `(observations, info)`. `seed` (an int: seed
    /// `seed + i` for environment i; or a list of `n_envs` seeds) restarts the episodes from
    /// those seeds; without it, each environment's next episode. info: `sample_seed` (uint64)
    /// and `variant` (uint32), `(n_envs,)` each, with their masks `_sample_seed`, `_variant`,
    /// and the positions at the start (see `step`).
    #[pyo3(signature = (seed=None, options=None))]
    fn reset<'py>(
        &self,
        py: Python<'py>,
        seed: Option<&Bound<'py, PyAny>>,
        options: Option<&Bound<'py, PyDict>>,
    ) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyDict>)> {
        let seeds: Option<Vec<u64>> = match seed {
            None => None,
            Some(seed) if seed.is_none() => None,
            Some(seed) => Some(match seed.extract::<u64>() {
                Ok(seed) => (0..self.num_envs)
                    .map(|lane| lane_seed(seed, lane))
                    .collect(),
                Err(_) => {
                    let seeds: Vec<u64> = seed.extract().map_err(|_| {
                        PyValueError::new_err(
                            "seed must be an int, a list of one int per environment, or None",
                        )
                    })?;
                    if seeds.len() != self.num_envs {
                        return Err(PyValueError::new_err(format!(
                            "seed is a list of {} seeds; it needs one per environment ({})",
                            seeds.len(),
                            self.num_envs
                        )));
                    }
                    seeds
                }
            }),
        };
        let mut guard = Core::lock(&self.core)?;
        reset_sample(options, &mut guard, false)?;
        let core: &mut Core = &mut guard;
        let started = py.detach(|| {
            (0..core.seeds.len())
                .map(|lane| {
                    if let Some(seeds) = &seeds {
                        core.seeds[lane] = LaneSeed::new(seeds[lane]);
                    }
                    let sample = core.start(lane, None);
                    let variant = core.lanes.borrow_dependent()[lane]
                        .as_ref()
                        .map_or(0, Episode::variant);
                    (lane, sample, variant)
                })
                .collect::<Vec<_>>()
        });
        let obs: Vec<f32> = core.frames.iter().flat_map(|frame| frame.inputs).collect();
        let obs = Array2::from_shape_vec((self.num_envs, N_FLAT), obs)
            .map_err(|error| RunError::new_err(format!("internal: observation shape: {error}")))?;
        let info = PyDict::new(py);
        started_info(&info, self.num_envs, &started)?;
        let positions: Vec<Positions> = (0..self.num_envs)
            .map(|lane| core.positions(lane))
            .collect();
        set_positions_info(&info, &positions, true)?;
        Ok((PyArray2::from_owned_array(py, obs), info))
    }

    /// One control cycle of every environment with `actions` (`(n_envs, 2)`, any float
    /// dtype): `(observations, rewards, terminated, truncated, info)`. info holds, for the
    /// environments whose episode ended in this step, its outcome (`fitness`, `solved`,
    /// `collided`, `ending`, `stage`, `variant`, `cycles`, `sample_seed`), and for those that
    /// began one (autoreset), its `sample_seed` and `variant`; each key with its mask
    /// (`_fitness`, ...), as Gymnasium's vector environments give infos. In a scenario with a
    /// team, movers, boxes or items, every info also holds each environment's positions (as
    /// `Env`'s, with a leading `n_envs` axis, every mask set: where an episode ended, for one
    /// that ended; where it began, for one that began); otherwise it is empty when nothing
    /// ended or began.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &self,
        py: Python<'py>,
        actions: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f32>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyArray1<bool>>,
        Bound<'py, PyDict>,
    )> {
        let wheels = actions_of(actions, self.num_envs)?;
        let mut guard = Core::lock(&self.core)?;
        let core: &mut Core = &mut guard;
        if (0..self.num_envs).all(|lane| !core.running(lane)) && core.seeds[0].episodes == 0 {
            return Err(RunError::new_err(
                "no episode is running: call reset() first",
            ));
        }
        let step = py
            .detach(|| core.step_lanes(&wheels))
            .map_err(RunError::new_err)?;
        let obs = Array2::from_shape_vec((self.num_envs, N_FLAT), step.obs)
            .map_err(|error| RunError::new_err(format!("internal: observation shape: {error}")))?;
        let info = PyDict::new(py);
        if !step.ended.is_empty() {
            ended_info(&info, self.num_envs, &step.ended, &step.started)?;
        } else if !step.started.is_empty() {
            started_info(&info, self.num_envs, &step.started)?;
        }
        set_positions_info(&info, &step.positions, true)?;
        Ok((
            PyArray2::from_owned_array(py, obs),
            PyArray1::from_owned_array(py, Array1::from_vec(step.rewards)),
            PyArray1::from_vec(py, step.terminated),
            PyArray1::from_vec(py, step.truncated),
            info,
        ))
    }

    /// The names of the observation's columns (`trace.input_names`).
    #[getter]
    fn observation_names(&self) -> Vec<&'static str> {
        observation_names()
    }

    /// The task's cycle limit: an episode is truncated after this many steps.
    #[getter]
    fn max_episode_steps(&self) -> PyResult<u32> {
        Ok(Core::lock(&self.core)?.evaluator().task().max_cycles())
    }

    /// Nothing to release; for Gymnasium's interface.
    fn close(&self) {}

    fn __len__(&self) -> usize {
        self.num_envs
    }

    fn __repr__(&self) -> PyResult<String> {
        let core = Core::lock(&self.core)?;
        Ok(format!(
            "VectorEnv('{}', {} environments, seed {})",
            core.evaluator().task().name(),
            self.num_envs,
            core.seeds[0].seed
        ))
    }
}

/// The info of lanes that began an episode: `sample_seed` and `variant` with their masks.
fn started_info(
    info: &Bound<'_, PyDict>,
    n_lanes: usize,
    started: &[(usize, Sample, u32)],
) -> PyResult<()> {
    let seeds = started.iter().map(|&(lane, sample, _)| (lane, sample.seed));
    set_lane_info(info, "sample_seed", n_lanes, 0u64, seeds)?;
    let variants = started.iter().map(|&(lane, _, variant)| (lane, variant));
    set_lane_info(info, "variant", n_lanes, 0u32, variants)
}

/// The info of a step in which episodes ended: their outcomes, and the `sample_seed` and
/// `variant` of the episodes that began (no lane both ends and begins in one step).
fn ended_info(
    info: &Bound<'_, PyDict>,
    n_lanes: usize,
    ended: &[Ended],
    started: &[(usize, Sample, u32)],
) -> PyResult<()> {
    let py = info.py();
    let of = |pick: fn(&Ended) -> f32| ended.iter().map(move |e| (e.lane, pick(e)));
    set_lane_info(info, "fitness", n_lanes, 0.0f32, of(|e| e.outcome.fitness))?;
    let flags = |pick: fn(&Ended) -> bool| ended.iter().map(move |e| (e.lane, pick(e)));
    set_lane_info(info, "solved", n_lanes, false, flags(|e| e.outcome.solved))?;
    set_lane_info(
        info,
        "collided",
        n_lanes,
        false,
        flags(|e| e.outcome.collided),
    )?;
    let stages = ended.iter().map(|e| (e.lane, e.outcome.stage));
    set_lane_info(info, "stage", n_lanes, 0u8, stages)?;
    let cycles = ended.iter().map(|e| (e.lane, e.outcome.cycles));
    set_lane_info(info, "cycles", n_lanes, 0u32, cycles)?;
    let seeds = ended
        .iter()
        .map(|e| (e.lane, e.sample.seed))
        .chain(started.iter().map(|&(lane, sample, _)| (lane, sample.seed)));
    set_lane_info(info, "sample_seed", n_lanes, 0u64, seeds)?;
    let variants = ended
        .iter()
        .map(|e| (e.lane, e.outcome.variant))
        .chain(started.iter().map(|&(lane, _, variant)| (lane, variant)));
    set_lane_info(info, "variant", n_lanes, 0u32, variants)?;
    // Endings as strings: a numpy array of Python str, "" where none.
    let mut endings = vec![""; n_lanes];
    let mut mask = vec![false; n_lanes];
    for e in ended {
        endings[e.lane] = ending_name(e.outcome.ending);
        mask[e.lane] = true;
    }
    let numpy = py.import("numpy")?;
    info.set_item("ending", numpy.getattr("array")?.call1((endings,))?)?;
    info.set_item("_ending", PyArray1::from_vec(py, mask))?;
    Ok(())
}
