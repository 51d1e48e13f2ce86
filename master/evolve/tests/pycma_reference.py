# The reference numbers of hevo-evolve's CMA-ES test (src/cmaes.rs, PYCMA_MEDIAN_EVALUATIONS): the
# evaluations pycma needs to bring a generation's best below 1e-8, on the same functions and
# settings: x0 = 0, sigma0 = 0.5, Hansen's default popsize, seeds 1-10. Run with `pip install
# cma numpy` and `python3 master/evolve/tests/pycma_reference.py` (several minutes).
import warnings

warnings.filterwarnings("ignore")
import cma
import numpy as np


def sphere(x):
    return float(np.sum((np.asarray(x) - 1.0) ** 2))


def rosenbrock(x):
    x = np.asarray(x)
    return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))


for name, f, dimensions, popsize in [
    ("sphere", sphere, 10, 10),
    ("rosenbrock", rosenbrock, 10, 10),
    ("sphere", sphere, 40, 15),
    ("rosenbrock", rosenbrock, 40, 15),
]:
    counts = []
    for seed in range(1, 11):
        options = {"popsize": popsize, "seed": seed, "verbose": -9, "tolfun": 0, "tolx": 0,
                   "tolfunhist": 0, "maxfevals": 400000}
        es = cma.CMAEvolutionStrategy(np.zeros(dimensions), 0.5, options)
        evaluations = None
        while evaluations is None and es.countevals < 400000:
            xs = es.ask()
            values = [f(x) for x in xs]
            if min(values) < 1e-8:
                evaluations = es.countevals + len(xs)
            es.tell(xs, values)
        counts.append(evaluations)
    counts = sorted(c if c is not None else float("inf") for c in counts)
    print(name, dimensions, counts, "median", counts[len(counts) // 2], flush=True)
