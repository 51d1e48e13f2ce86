"""Evolve the double T-maze arbitrator over hevo's shipped primitives with hevo's own CMA-ES,
driven from Python through `hevo.Strategy` around `hevo.evaluate`, beside pycma's CMA-ES
(`cma_maze_arbitrator.py`'s loop) at the same number of evaluations, on the same samples. Both
results are then post-evaluated on the same fresh samples, and the best fitness per evaluation
spent is plotted for both.

hevo's strategy is saved after every generation (`strategy.state()`, in OUT/hevo_cmaes.state):
run the same command again after an interruption, or with more --evaluations, and it continues
from there, asking for exactly the genomes an uninterrupted run asks for.

    pip install "./python[examples]"          # the module with pycma and matplotlib
    python python/examples/hevo_cmaes_maze_arbitrator.py --out hevo-cmaes
    python python/examples/hevo_cmaes_maze_arbitrator.py --out tiny --evaluations 3000

An evaluation is one genome on one sample (one episode), the unit both algorithms spend.
"""

import argparse
import json
import os
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hevo  # noqa: E402
from cma_maze_arbitrator import SHIPPED, generation_seed, run_cma  # noqa: E402


def write_atomically(path: pathlib.Path, data: bytes):
    """So that an interruption leaves the old file or the new one, never half of one."""
    partial = path.with_name(path.name + ".partial")
    partial.write_bytes(data)
    os.replace(partial, path)


def run_hevo_cmaes(template: hevo.Controller, task: hevo.Task, args):
    """hevo's CMA-ES, each generation's genomes on the samples pycma's get in the same
    generation; resumed from OUT/hevo_cmaes.state when there is one. Returns (evaluations
    spent, best fitness) per generation and the strategy's best genome."""
    per_variant = max(1, args.samples // task.n_variants)
    per_genome = per_variant * task.n_variants
    state_path = args.out / "hevo_cmaes.state"
    curve_path = args.out / "hevo_cmaes_curve.json"
    if state_path.exists():
        strategy = hevo.Strategy.from_state(state_path.read_bytes())
        curve = json.loads(curve_path.read_text())[: strategy.generation]
        print(f"hevo CMA-ES resumed at generation {strategy.generation}")
    else:
        # An experiment file's [evolution] keys: the same names, defaults and checks.
        strategy = hevo.Strategy(
            "cmaes",
            n_genes=template.n_genes,
            seed=args.seed,
            population=args.population,
            initial_sigma=1.0,
        )
        curve = []
    while (strategy.generation + 1) * args.population * per_genome <= args.evaluations:
        genomes = strategy.ask()  # float64, within the gene range [-10, 10]
        result = hevo.evaluate(
            template,
            genomes,
            task,
            samples=per_variant,
            seed=generation_seed(strategy.generation),
            threads=args.threads,
        )
        strategy.tell(result.fitness)  # larger is better, as hevo's fitness is
        spent = strategy.generation * args.population * per_genome
        curve.append((spent, float(result.fitness.max())))
        curve_path.write_text(json.dumps(curve))
        write_atomically(state_path, strategy.state())
    if strategy.best is None:
        raise SystemExit("--evaluations is smaller than one CMA-ES generation")
    return curve, strategy.best[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("hevo-cmaes"))
    parser.add_argument("--evaluations", type=int, default=60_000, help="episodes per algorithm")
    parser.add_argument("--population", type=int, default=20)
    parser.add_argument("--samples", type=int, default=6, help="episodes per genome per generation")
    parser.add_argument("--post-samples", type=int, default=50, help="post-evaluation samples per variant")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--without-pycma", action="store_true", help="hevo's CMA-ES alone")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    task = hevo.Task("solve_maze")
    template = hevo.Controller.load(SHIPPED).without_genome("solve_maze")
    runs = {"hevo CMA-ES": run_hevo_cmaes(template, task, args)}
    if not args.without_pycma:
        runs["pycma"] = run_cma(template, task, args)

    finals = hevo.evaluate(
        template,
        np.stack([genes for _, genes in runs.values()]),
        task,
        samples=args.post_samples,
        seed=999,
        threads=args.threads,
    )
    figure, axes = plt.subplots(figsize=(7, 4))
    for row, (name, (curve, genes)) in enumerate(runs.items()):
        template.with_genome(genes).save(args.out / f"{name.split()[0].lower()}_best.json")
        print(
            f"{name:12} {curve[-1][0]:>8} evaluations: "
            f"post-evaluation solve rate {100 * finals.solve_rate[row]:5.1f}%, "
            f"mean fitness {finals.fitness[row]:.3f} ({finals.samples} samples)"
        )
        x, y = zip(*curve)
        axes.plot(x, y, label=f"{name} (post-evaluation {100 * finals.solve_rate[row]:.0f}% solved)")
    axes.set_xlabel("evaluations (episodes)")
    axes.set_ylabel("best fitness of the generation")
    axes.set_title("solve_maze arbitrator: hevo's CMA-ES and pycma's")
    axes.legend()
    figure.tight_layout()
    figure.savefig(args.out / "hevo_cmaes.png", dpi=120)
    print(f"plot -> {args.out / 'hevo_cmaes.png'}")


if __name__ == "__main__":
    main()
