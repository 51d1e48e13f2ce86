"""Throughput of `hevo.VectorEnv` driven by a numpy linear policy, against `hevo.evaluate` on
the same task, both on one core. A benchmark, not a test: run it on a quiet machine with a
release build of the module,

    pip install ./python                      # maturin builds release by default
    python python/benchmarks/env_throughput.py --task solve_maze

The process is pinned to one CPU (`--cpu`) and numpy's thread pools to one thread, so "one
core" holds for both sides. The environment side steps `n_envs` episodes per call with the
policy `sigmoid(obs @ W + b)` computed by numpy (the time numpy takes counts), and counts
environment steps (control cycles) per second. The evaluate side is `hevo.evaluate` with
`threads=1` on perturbed copies of the shipped maze controller's arbitrator genome, and counts
the control cycles of its samples per second. The ratio is evaluate's cycles per second over
the environment's steps per second (the issue asks for at most 3).
"""

import os

# Before numpy loads: one thread in its pools.
for variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(variable, "1")

import argparse  # noqa: E402
import pathlib  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import hevo  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]


def env_steps_per_second(task, n_envs: int, seconds: float, seed: int) -> float:
    env = hevo.VectorEnv(task, n_envs, seed=seed)
    rng = np.random.default_rng(seed)
    weights = rng.normal(0, 1, (len(env.observation_names), 2)).astype(np.float32)
    bias = rng.normal(0, 0.5, 2).astype(np.float32)
    obs, _ = env.reset()
    steps = 0
    started = time.perf_counter()
    while time.perf_counter() - started < seconds:
        for _ in range(50):
            actions = 1.0 / (1.0 + np.exp(-(obs @ weights + bias)))
            obs, _rewards, _terminated, _truncated, _info = env.step(actions)
        steps += 50 * n_envs
    return steps / (time.perf_counter() - started)


def evaluate_cycles_per_second(task, seconds: float, seed: int) -> float:
    maze = hevo.Controller.load(REPO / "controllers" / "solve_maze.json")
    template = maze.without_genome("solve_maze")
    genes = maze.genome("solve_maze")
    cycles, generation = 0, 0
    started = time.perf_counter()
    while time.perf_counter() - started < seconds:
        rng = np.random.default_rng(seed + generation)
        genomes = genes[None, :] + rng.normal(0, 0.3, (16, len(genes)))
        result = hevo.evaluate(template, genomes, task, samples=4, seed=generation, threads=1,
                               clip=True)
        cycles += int(result.sample_cycles.sum())
        generation += 1
    return cycles / (time.perf_counter() - started)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="solve_maze")
    parser.add_argument("--n-envs", default="16,64,256,1024",
                        help="comma-separated environment counts")
    parser.add_argument("--seconds", type=float, default=5.0, help="per measurement")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--cpu", type=int, default=0, help="the CPU to pin the process to")
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.cpu})
    task = hevo.Task(args.task)
    evaluate = statistics.median(
        evaluate_cycles_per_second(task, args.seconds, repeat) for repeat in range(args.repeats)
    )
    print(f"hevo.evaluate, threads=1: {evaluate:,.0f} cycles/s (median of {args.repeats})")
    for n_envs in (int(n) for n in args.n_envs.split(",")):
        env = statistics.median(
            env_steps_per_second(task, n_envs, args.seconds, repeat)
            for repeat in range(args.repeats)
        )
        print(f"hevo.VectorEnv, {n_envs:5d} envs, numpy linear policy: {env:,.0f} steps/s; "
              f"evaluate / env = {evaluate / env:.2f}")


if __name__ == "__main__":
    main()
