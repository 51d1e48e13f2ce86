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
        """The robots of `poses`: `robot`, then `teammate` where the task has one."""
    @property
    def poses(self) -> npt.NDArray[np.float32]:
        """(cycles, robots, 3): x, y (metres), heading (radians) at the start of each cycle."""
    @property
    def inputs(self) -> npt.NDArray[np.float32]:
        """(cycles, 7) sensor inputs, columns as `input_names`."""
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
