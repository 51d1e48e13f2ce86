"""hevo: hierarchical evolution of robot controllers, from Python.

The same engine the ``hevo`` command runs, bound with PyO3:

- ``Controller``: controller files, their trees and genomes as numpy arrays;
- ``Task``: a shipped scenario by name, or a scenario file, with settings overridden;
- ``evaluate``: many genomes (any float dtype; genes in ``GENE_RANGE``, or ``clip=True``) on
  the same samples, all cores, the GIL released; the numbers ``hevo eval --json`` prints, bit
  for bit, and each sample's outcome;
- ``trace``: one sample cycle by cycle as numpy arrays, and the replay picture;
- ``Env``, ``VectorEnv``: a task as an environment any policy drives (Gymnasium's
  conventions: observations the robot's sensor frame, actions its wheel outputs, reward the
  task's fitness at the end); ``VectorEnv`` steps N of them in Rust per call;
- ``run``: an experiment evolved by the resumable runner of ``hevo run``;
- ``Strategy``: hevo's search algorithms (the paper's GA, CMA-ES, novelty search, ...) with
  ask/tell over numpy, set up by an experiment file's ``[evolution]`` keys, saved and resumed
  bit for bit;
- ``Client``: a master's job service (submit, watch, jobs, fetch, cancel), and ``evaluate`` on
  the master's workers with the results of ``hevo.evaluate``, bit for bit.

Errors are ``HevoError`` subclasses carrying the messages the command line prints:
``ConfigError``, ``ControllerError``, ``RunError``, ``ClientError``.
"""

from ._hevo import (
    Client,
    ClientError,
    ConfigError,
    Controller,
    ControllerError,
    Env,
    Evaluation,
    GENE_RANGE,
    HevoError,
    JobWatch,
    RunError,
    Space,
    Strategy,
    Task,
    Trace,
    VectorEnv,
    __version__,
    bench_controller,
    evaluate,
    run,
    shipped_tasks,
    trace,
)

__all__ = [
    "Client",
    "ClientError",
    "ConfigError",
    "Controller",
    "ControllerError",
    "Env",
    "Evaluation",
    "GENE_RANGE",
    "HevoError",
    "JobWatch",
    "RunError",
    "Space",
    "Strategy",
    "Task",
    "Trace",
    "VectorEnv",
    "__version__",
    "bench_controller",
    "evaluate",
    "run",
    "shipped_tasks",
    "trace",
]
