"""Type stubs of hevo's compiled module (hevo._hevo); the package hevo re-exports it all."""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, os.PathLike]

__version__: str
GENE_RANGE: Tuple[float, float]
"""(-10.0, 10.0): the range every gene lies in, both ends included (`evaluate` refuses genes
outside it unless `clip=True`)."""

class HevoError(Exception):
    """The base of every error hevo raises; its message is the one the `hevo` command prints."""

class ConfigError(HevoError):
    """A task, scenario file or experiment file that cannot be used (file, key, what was expected)."""

class ControllerError(HevoError):
    """A controller file or genome that cannot be used (file and node)."""

class RunError(HevoError):
    """An evaluation or run that could not finish."""

class ClientError(HevoError):
    """A master that refused a call or could not be reached."""

def shipped_tasks() -> List[str]:
    """The names of the shipped scenarios, which `Task(name)` takes besides a scenario file."""

class Controller:
    """A controller tree (`hevo.controller/1`): primitives and arbitrators, each a CTRNN with its genome."""

    @staticmethod
    def load(path: PathLike) -> Controller:
        """Reads a controller file (JSON); raises ControllerError naming the file and node."""
    @staticmethod
    def from_json(text: str) -> Controller:
        """Parses a controller from its JSON text."""
    def to_json(self) -> str:
        """The controller file's JSON text."""
    def save(self, path: PathLike) -> None:
        """Writes the controller file, atomically."""
    @property
    def node_paths(self) -> List[str]:
        """Every node's path in pre-order, root first (the node indices of traces)."""
    @property
    def free_node(self) -> Optional[str]:
        """The path of the node without a genome, if any: the node `evaluate` fills."""
    @property
    def n_genes(self) -> int:
        """Genes the free node takes: the width of `evaluate`'s genomes array (0 without one)."""
    @property
    def content_hash(self) -> str:
        """The content hash hevo's caches and fingerprints use."""
    def tree(self) -> Dict[str, Any]:
        """The tree as nested dicts: name, path, kind, inputs, hidden, topology, n_genes, has_genome, children."""
    def genome_length(self, node: Optional[str] = None) -> int:
        """The genome length of the node at `node` (a path; the root when omitted)."""
    def genome(self, node: Optional[str] = None) -> Optional[npt.NDArray[np.float32]]:
        """A copy of the node's genome (the root when omitted), or None for the free node."""
    def set_genome(self, genes: npt.ArrayLike, node: Optional[str] = None) -> None:
        """Sets the node's genome (the root when omitted; any float dtype, float64 rounded to
        the nearest float32); ControllerError when it does not fit."""
    def without_genome(self, node: Optional[str] = None) -> Controller:
        """A copy with the node's genome removed: a template for `evaluate`."""
    def with_genome(self, genes: npt.ArrayLike) -> Controller:
        """A copy of this template with its free node's genome filled in (any float dtype)."""

class Task:
    """A task: a scenario and every number of the model in force."""

    def __init__(self, name: Union[str, os.PathLike], **overrides: Any) -> None:
        """A shipped scenario (`shipped_tasks()`) or a scenario file (a path ending in .toml),
        with settings overridden like an experiment node's `task_config` table:
        `Task("follow_wall", max_cycles=500, robot={"v_max": 0.08})`."""
    @property
    def name(self) -> str: ...
    @property
    def max_cycles(self) -> int: ...
    @property
    def n_variants(self) -> int: ...
    @property
    def variant_names(self) -> List[str]: ...
    def settings(self) -> Dict[str, Any]:
        """Every setting as a dict (the task's wire form)."""

class Evaluation:
    """The results of `evaluate`, one row per genome: the numbers of `hevo eval --json`."""

    fitness: npt.NDArray[np.float64]
    """`mean_fitness` per genome, shape (n,)."""
    solve_rate: npt.NDArray[np.float64]
    collision_rate: npt.NDArray[np.float64]
    mean_cycles: npt.NDArray[np.float64]
    per_variant: npt.NDArray[np.float64]
    """Solve rate per variant, shape (n, n_variants); (n, 0) for a task with one variant."""
    per_stage: npt.NDArray[np.float64]
    """Share of samples that reached each stage, shape (n, len(stage_names))."""
    per_phase: npt.NDArray[np.float64]
    """Share of right choices per phase of a derived fitness (NaN: no sample reached it)."""
    descriptor: npt.NDArray[np.float64]
    """The behaviour descriptor, each value the mean over the samples, shape
    (n, len(descriptor_names)): what a strategy is told in `hevo run`."""
    sample_fitness: npt.NDArray[np.float32]
    """Each sample's fitness, shape (n, samples); columns in the order of `sample_seeds`."""
    sample_solved: npt.NDArray[np.bool_]
    sample_collided: npt.NDArray[np.bool_]
    sample_cycles: npt.NDArray[np.uint32]
    sample_stage: npt.NDArray[np.uint8]
    sample_variant: npt.NDArray[np.uint32]
    sample_ending: npt.NDArray[np.uint8]
    """Why each sample ended, shape (n, samples): an index into `ending_names`."""
    sample_descriptor: npt.NDArray[np.float32]
    """Each sample's behaviour descriptor, shape (n, samples, len(descriptor_names))."""
    sample_seeds: npt.NDArray[np.uint64]
    """The samples' seeds, shape (samples,): `trace(controller, task, seed, variant)` replays one."""
    variant_names: List[str]
    stage_names: List[str]
    phase_names: List[str]
    descriptor_names: List[str]
    """The descriptor's quantities: the scenario's `[descriptor]`, ["final.x", "final.y"] by default."""
    ending_names: List[str]
    """["solved", "collision", "wrong_branch", "timeout"]: what `sample_ending`'s codes stand for."""
    samples: int
    """Samples each genome ran (samples per variant times variants)."""
    def __len__(self) -> int: ...

def evaluate(
    template: Controller,
    genomes: npt.ArrayLike,
    task: Task,
    samples: int = 50,
    seed: int = 0,
    threads: Optional[int] = None,
    clip: bool = False,
) -> Evaluation:
    """Evaluates each row of `genomes` ((n, template.n_genes), any float dtype: float64 rounds
    to the nearest float32) as the template's free node, on `samples` samples per variant drawn
    from `seed`, on every core with the GIL released: per genome what `hevo eval --samples S
    --seed K --json` prints, bit for bit, and each sample's outcome. Genes outside GENE_RANGE
    are clipped with `clip=True`, else refused (ControllerError naming the row and gene); NaN
    and infinity are refused either way."""

class Strategy:
    """One of hevo's search algorithms ("ga", "cmaes", "novelty", ...) with ask/tell over numpy.
    The settings are an experiment file's `[evolution]` table: `settings` as a dict or TOML
    text, `algorithm` and keyword keys over it, with the file's keys, defaults and messages
    (ConfigError naming `evolution.KEY`)."""

    def __init__(
        self,
        algorithm: Optional[str] = None,
        *,
        n_genes: int,
        seed: int = 0,
        settings: Optional[Union[Dict[str, Any], str]] = None,
        **keys: Any,
    ) -> None: ...
    @property
    def algorithm(self) -> str: ...
    @property
    def n_genes(self) -> int: ...
    @property
    def seed(self) -> int: ...
    @property
    def generation(self) -> int:
        """Generations told so far."""
    @property
    def best(self) -> Optional[Tuple[npt.NDArray[np.float64], float]]:
        """(genes, the fitness they were told with) of the strategy's best; None before a tell."""
    @property
    def archive(self) -> Optional[Dict[str, Any]]:
        """MAP-Elites' archive: cells, filled, coverage, qd_score, best, and per elite (in
        cell order) cell, fitness, descriptor (n, d) and genes (n, n_genes) arrays; None for
        the other algorithms."""
    def settings(self) -> Dict[str, Any]:
        """The settings table as given."""
    def ask(self) -> npt.NDArray[np.float64]:
        """The genomes to evaluate next, float64 (n, n_genes), each gene a float32 value
        exactly, within the settings' gene_range; the same until `tell`."""
    def tell(self, fitness: npt.ArrayLike, descriptors: Optional[npt.ArrayLike] = None) -> None:
        """The results of `ask()`'s genomes in order: fitness (n,), descriptors (n, d), any
        float dtype, larger fitness better. NaN, infinity or a wrong shape: ValueError naming
        the row, and nothing changes."""
    def state(self) -> bytes:
        """The whole state as JSON text: `Strategy.from_state` continues it bit for bit."""
    @staticmethod
    def from_state(state: Union[bytes, str]) -> Strategy: ...

def bench_controller(task: Task, seed: int = 1) -> Controller:
    """The controller `hevo bench` measures `task` with, random genes drawn from `seed`."""

class Trace:
    """One traced sample; arrays have one row per control cycle."""

    @property
    def task(self) -> str: ...
    @property
    def seed(self) -> int: ...
    @property
    def variant(self) -> int: ...
    @property
    def outcome(self) -> Dict[str, Any]:
        """fitness, solved, collided, ending, cycles, stage, variant, node_use."""
    @property
    def node_paths(self) -> List[str]: ...
    @property
    def robots(self) -> List[str]:
        """The robots of `poses`: `robot`, then `teammate` where the task has one, then a
        team's other robots by group and index (`swarm_0`, `swarm_1`, ...)."""
    @property
    def poses(self) -> npt.NDArray[np.float32]:
        """(cycles, robots, 3): x, y (metres), heading (radians) at the start of each cycle."""
    @property
    def inputs(self) -> npt.NDArray[np.float32]:
        """(cycles, 17) sensor inputs, columns as `input_names`."""
    @property
    def input_names(self) -> List[str]: ...
    @property
    def outputs(self) -> npt.NDArray[np.float32]:
        """(cycles, 2) wheel outputs: left, right, in [0, 1]."""
    @property
    def active_path(self) -> npt.NDArray[np.int16]:
        """(cycles, depth) active node indices, root first, padded with -1."""
    @property
    def active_node(self) -> npt.NDArray[np.int16]:
        """(cycles,) the node that drove the wheels."""
    @property
    def collided(self) -> npt.NDArray[np.bool_]: ...
    @property
    def lit_lights(self) -> npt.NDArray[np.uint32]: ...
    @property
    def sub_task(self) -> npt.NDArray[np.uint8]: ...
    @property
    def walls(self) -> npt.NDArray[np.float32]:
        """(n, 5) rectangles: centre x, centre y, half width, half height, rotation."""
    def to_svg(
        self, path: Optional[PathLike] = None, rays: Sequence[int] = (), animate: bool = False
    ) -> str:
        """The picture `hevo replay` draws; written to `path` when given."""
    def to_csv(self, path: Optional[PathLike] = None) -> str:
        """The table `hevo replay --trace-out FILE.csv` writes."""
    def to_json(self, path: Optional[PathLike] = None) -> str:
        """The document `hevo replay --trace-out FILE.json` writes."""
    def __len__(self) -> int: ...

def trace(
    controller: Controller, task: Task, seed: int = 0, variant: Optional[int] = None
) -> Trace:
    """One sample of a complete controller, as `hevo replay --seed SEED --light-config VARIANT`."""

class Space:
    """The bounds of observations or actions, as Gymnasium's `Box` gives them (without
    Gymnasium): `gymnasium.spaces.Box(space.low, space.high, dtype=space.dtype)` makes one."""

    @property
    def shape(self) -> Tuple[int, ...]: ...
    low: npt.NDArray[np.float32]
    """Each element's lowest value, shape `shape`."""
    high: npt.NDArray[np.float32]
    """Each element's highest value, shape `shape`."""
    @property
    def dtype(self) -> str:
        """`"float32"`."""

class Env:
    """One sample of a task at a time as an environment, with Gymnasium's conventions.
    Observations: the robot's sensor frame, float32 (17,) in [0, 1], columns as
    `observation_names`. Actions: the two wheel outputs (left, right) in [0, 1] (0 full speed
    backwards, 0.5 still, 1 full speed forwards; `trace.outputs`), any float dtype, clipped to
    the range; NaN and infinity raise ValueError. Reward: 0 until the end, then the task's
    fitness. `terminated` when the task ends the sample (solved, collision, wrong branch),
    `truncated` at its cycle limit. Episode k after `reset(seed=s)` runs the sample of seed
    `derive_seed(s, [k])`, named in every info as `sample_seed`.

    Every info (the reset's and each step's) also says where everything besides the robot is,
    each key only in a scenario with such bodies (absent, not empty, without): `team_poses`
    (a team's other robots, float64 (n, 3): x, y in metres, heading in radians, in the order
    of `Trace.robots`), `mover_positions` and `box_positions` (centres, float64 (n, 2)),
    `item_positions` (float64 (n, 2): where an item lies, its carrier's centre while carried,
    where it was delivered once delivered) with `item_carried` and `item_delivered` (bool
    (n,)). After a step they are where things stand for the next cycle; at the end, where
    they ended."""

    observation_space: Space
    action_space: Space
    def __init__(self, task: Task, seed: Optional[int] = None) -> None:
        """`seed` seeds the episodes as `reset(seed=...)` does (entropy when None)."""
    def reset(
        self, seed: Optional[int] = None, options: Optional[Dict[str, Any]] = None
    ) -> Tuple[npt.NDArray[np.float32], Dict[str, Any]]:
        """Starts an episode: `(observation, info)`; info has `sample_seed`, `variant` and
        the positions at the start.
        `seed` restarts the episodes from that seed; `options={"sample_seed": s, "variant": v}`
        runs that sample exactly, as `trace(controller, task, seed=s, variant=v)` does."""
    def step(
        self, action: npt.ArrayLike
    ) -> Tuple[npt.NDArray[np.float32], float, bool, bool, Dict[str, Any]]:
        """One control cycle: `(observation, reward, terminated, truncated, info)`. At the end,
        info holds the outcome: fitness, solved, collided, ending, stage, variant, cycles,
        sample_seed; the observation is the last cycle's frame. Every info holds the positions
        after the step. RunError before `reset()` and after the end."""
    @property
    def observation_names(self) -> List[str]:
        """The observation's columns (`trace.input_names`)."""
    @property
    def max_episode_steps(self) -> int:
        """The task's cycle limit."""
    @property
    def running(self) -> bool:
        """Whether an episode is running."""
    def close(self) -> None: ...

class VectorEnv:
    """`n_envs` environments stepped together in Rust, the GIL released, with Gymnasium's
    vector conventions: `Env`'s arrays with a leading `n_envs` axis (rewards float64). Autoreset
    in Gymnasium's next-step mode: the step after an episode's end starts the next one, returns
    its first observation with reward 0, and ignores that environment's action. Environment i
    is seeded `seed + i`: it runs the episodes of `Env(task, seed + i)`."""

    num_envs: int
    single_observation_space: Space
    single_action_space: Space
    observation_space: Space
    action_space: Space
    def __init__(self, task: Task, n_envs: int, seed: Optional[int] = None) -> None: ...
    def reset(
        self, seed: Union[int, Sequence[int], None] = None, options: Optional[Dict[str, Any]] = None
    ) -> Tuple[npt.NDArray[np.float32], Dict[str, Any]]:
        """Starts an episode in every environment: `(observations (n_envs, 17), info)`, info
        with `sample_seed` and `variant` arrays and their masks, and the positions at the
        start (see `step`). `seed`: an int (environment i
        seeded `seed + i`) or one seed per environment; no options."""
    def step(
        self, actions: npt.ArrayLike
    ) -> Tuple[
        npt.NDArray[np.float32],
        npt.NDArray[np.float64],
        npt.NDArray[np.bool_],
        npt.NDArray[np.bool_],
        Dict[str, Any],
    ]:
        """One control cycle of every environment, `actions` (n_envs, 2) of any float dtype:
        `(observations, rewards, terminated, truncated, info)`. info: the outcome of each
        episode that ended (fitness, solved, collided, ending, stage, variant, cycles,
        sample_seed) and the `sample_seed` and `variant` of each that began, every key with
        its mask (`_fitness`, ...). In a scenario with a team, movers, boxes or items, also
        every environment's positions: `Env`'s keys with a leading n_envs axis, every mask
        set (where an episode ended or began, for one that did). Otherwise empty when none
        ended or began."""
    @property
    def observation_names(self) -> List[str]: ...
    @property
    def max_episode_steps(self) -> int: ...
    def close(self) -> None: ...
    def __len__(self) -> int: ...

def run(
    experiment: PathLike,
    out: PathLike,
    node: Optional[str] = None,
    threads: Optional[int] = None,
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
    runs: Optional[int] = None,
    generations: Optional[int] = None,
    seed: Optional[int] = None,
) -> List[Dict[str, Any]]:
    """Evolves an experiment file into `out` as `hevo run` does, resuming what is there; Ctrl-C
    stops it (KeyboardInterrupt) and the same call resumes it. Returns each node's summary."""

class JobWatch(Iterator[Dict[str, Any]]):
    """The events of a job until it ends; the last is the final `status`."""

    def __next__(self) -> Dict[str, Any]: ...
    def close(self) -> None: ...

class Client:
    """A master's job service."""

    def __init__(
        self,
        url: str,
        token: Optional[str] = None,
        token_file: Optional[PathLike] = None,
        tls_ca: Optional[PathLike] = None,
    ) -> None: ...
    def submit(
        self,
        experiment: PathLike,
        node: Optional[str] = None,
        runs: Optional[int] = None,
        generations: Optional[int] = None,
        seed: Optional[int] = None,
    ) -> str:
        """Submits an experiment file; returns the job id."""
    def watch(self, job: str) -> JobWatch:
        """Follows a job until it ends, reconnecting across master restarts."""
    def jobs(self) -> List[Dict[str, Any]]: ...
    def fetch(self, job: str, out: PathLike) -> Dict[str, Any]:
        """Writes a job's result files under `out`; the status dict with `files`."""
    def cancel(self, job: str) -> Dict[str, Any]: ...
