# The reference numbers of hevo-evolve's CMA-ES tests (src/cmaes.rs, PYCMA_MEDIAN_EVALUATIONS and
# PYCMA_IPOP_MEDIAN_EVALUATIONS): the evaluations pycma needs to bring a generation's best below a
# target, on the same functions and settings, seeds 1-10. Run with `pip install cma numpy` and
# `python3 master/evolve/tests/pycma_reference.py` (tens of minutes; `--long` adds Rastrigin in 40
# dimensions to 1e-8, which takes hours).
#
# Without restarts: x0 = 0, sigma0 = 0.5, Hansen's default popsize, target 1e-8.
# With IPOP restarts (pycma's `restarts=9, incpopsize=2`, written out so every restart's
# evaluations count): x0 = 0, sigma0 = 2, the first popsize Hansen's default, doubled at each
# restart, the restart's seed 100 x seed + restart.
import sys
import warnings

warnings.filterwarnings("ignore")
import cma
import numpy as np


def sphere(x):
    return float(np.sum((np.asarray(x) - 1.0) ** 2))


def rosenbrock(x):
    x = np.asarray(x)
    return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))


def rastrigin(x):
    y = np.asarray(x) - 1.0
    return float(10 * len(y) + np.sum(y * y - 10 * np.cos(2 * np.pi * y)))


def without_restarts(f, dimensions, popsize, seed, diagonal):
    options = {"popsize": popsize, "seed": seed, "verbose": -9, "tolfun": 0, "tolx": 0,
               "tolfunhist": 0, "maxfevals": 400000, "CMA_diagonal": diagonal}
    es = cma.CMAEvolutionStrategy(np.zeros(dimensions), 0.5, options)
    while es.countevals < 400000:
        xs = es.ask()
        values = [f(x) for x in xs]
        if min(values) < 1e-8:
            return es.countevals + len(xs)
        es.tell(xs, values)
    return None


def with_ipop_restarts(f, dimensions, popsize, seed, diagonal, target, max_evaluations=3000000):
    used = 0
    for restart in range(10):
        options = {"popsize": popsize * 2 ** restart, "seed": 100 * seed + restart,
                   "verbose": -9, "maxfevals": max_evaluations - used, "CMA_diagonal": diagonal}
        es = cma.CMAEvolutionStrategy(np.zeros(dimensions), 2.0, options)
        while not es.stop():
            xs = es.ask()
            values = [f(x) for x in xs]
            if min(values) < target:
                return used + es.countevals + len(xs)
            es.tell(xs, values)
        used += es.countevals
        if used >= max_evaluations:
            return None
    return None


def report(label, counts):
    counts = sorted(c if c is not None else float("inf") for c in counts)
    print(label, counts, "median", counts[len(counts) // 2], flush=True)


for name, f, dimensions, popsize, diagonal in [
    ("sphere", sphere, 10, 10, False),
    ("rosenbrock", rosenbrock, 10, 10, False),
    ("sphere", sphere, 40, 15, False),
    ("rosenbrock", rosenbrock, 40, 15, False),
    ("sphere", sphere, 10, 10, True),
    ("sphere", sphere, 40, 15, True),
]:
    counts = [without_restarts(f, dimensions, popsize, seed, diagonal) for seed in range(1, 11)]
    report(f"{name} {dimensions} diagonal={diagonal}", counts)

ipop = [
    (10, 10, False, 1e-8),
    (10, 10, True, 1e-8),
    (40, 15, False, 10.0),
    (40, 15, True, 10.0),
]
if "--long" in sys.argv:
    ipop.append((40, 15, False, 1e-8))
for dimensions, popsize, diagonal, target in ipop:
    counts = [with_ipop_restarts(rastrigin, dimensions, popsize, seed, diagonal, target)
              for seed in range(1, 11)]
    report(f"rastrigin {dimensions} diagonal={diagonal} ipop target={target}", counts)
