# The reference numbers of hevo-evolve's CMA-ES test (src/cmaes.rs, PYCMA_MEDIAN_EVALUATIONS): the
# evaluations pycma needs to bring a generation's best below 1e-8, on the same functions and
# settings: 10 dimensions, popsize 10, x0 = 0, sigma0 = 0.5, seeds 1-10. Run with `pip install
# cma numpy` and `python3 master/evolve/tests/pycma_reference.py`.
import warnings
warnings.filterwarnings("ignore")
import cma, numpy as np
def sphere(x): return float(np.sum((np.asarray(x) - 1.0) ** 2))
def rosenbrock(x):
    x = np.asarray(x); return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))
for name, f in [("sphere", sphere), ("rosenbrock", rosenbrock)]:
    counts = []
    for seed in range(1, 11):
        es = cma.CMAEvolutionStrategy(np.zeros(10), 0.5, {"popsize": 10, "seed": seed, "verbose": -9, "ftarget": 1e-8, "tolfun": 0, "tolx": 0, "tolfunhist": 0, "maxfevals": 100000})
        evaluations = None
        while evaluations is None and es.countevals < 100000:
            xs = es.ask(); values = [f(x) for x in xs]
            if min(values) < 1e-8: evaluations = es.countevals + len(xs)
            es.tell(xs, values)
        counts.append(evaluations)
    counts = sorted(c if c is not None else float("inf") for c in counts)
    print(name, counts, "median", counts[len(counts) // 2])
