"""Evolve the double T-maze arbitrator over hevo's shipped primitives (follow wall, turn left,
turn right, from controllers/solve_maze.json) two ways at the same number of evaluations:
pycma's CMA-ES with `hevo.evaluate` as its fitness function, and hevo's own evolutionary
algorithm through `hevo.run`. Both final controllers are then post-evaluated on the same fresh
samples, and the best fitness per evaluation spent is plotted for both.

    pip install "./python[examples]"          # the module with pycma and matplotlib
    python python/examples/cma_maze_arbitrator.py --out cma-vs-ea
    python python/examples/cma_maze_arbitrator.py --out tiny --evaluations 3000   # a quick look

An evaluation is one genome on one sample (one episode), the unit both algorithms spend.
"""

import argparse
import json
import pathlib
import textwrap

import cma
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import hevo  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
SHIPPED = REPO / "controllers" / "solve_maze.json"


def hevo_experiment(out: pathlib.Path, args) -> pathlib.Path:
    """An experiment file whose one node is the shipped maze arbitrator's topology over its
    shipped children (written beside it as fixed controller files), evolved by hevo's EA."""
    shipped = json.loads(SHIPPED.read_text())
    root = shipped["root"]
    children = []
    for child in root["children"]:
        path = out / f"{child['name']}.json"
        path.write_text(json.dumps({"schema": shipped["schema"], "root": child}, indent=2))
        children.append(f'{{ file = "{path.name}" }}')
    generations = max(1, args.evaluations // (args.population * args.samples))
    text = textwrap.dedent(
        f"""
        [experiment]
        name = "ea_maze_arbitrator"
        seed = {args.seed}

        [evolution]
        population = {args.population}
        elites = {args.population // 5}
        post_evaluation_samples = 1

        [[node]]
        name = "solve_maze"
        kind = "arbitrator"
        inputs = {json.dumps(root["inputs"])}
        hidden = {root["hidden"]}
        children = [{", ".join(children)}]
        task = "solve_maze"
        samples = {args.samples}
        generations = {generations}
        runs = 1
        """
    )
    path = out / "ea_maze_arbitrator.toml"
    path.write_text(text)
    return path


def run_hevo_ea(out: pathlib.Path, args):
    """hevo's EA: returns (evaluations spent, best fitness) per generation and the best genome."""
    experiment = hevo_experiment(out, args)
    curve = []
    spent = 0

    def progress(event):
        nonlocal spent
        if event["event"] == "generation":
            spent += args.population * args.samples
            curve.append((spent, event["best"]))

    hevo.run(experiment, out=out / "ea-runs", threads=args.threads, progress=progress)
    best = hevo.Controller.load(out / "ea-runs" / "solve_maze" / "best.json")
    return curve, best.genome("solve_maze")


def generation_seed(generation: int) -> int:
    """The seed of a CMA-ES generation's samples: fresh samples every generation."""
    return 10_000 + generation


def run_cma(template: hevo.Controller, task: hevo.Task, args):
    """CMA-ES: each generation's candidates on fresh samples (per variant, so
    `samples // n_variants` of each of the maze's light configurations)."""
    per_variant = max(1, args.samples // task.n_variants)
    per_candidate = per_variant * task.n_variants
    popsize = args.population
    strategy = cma.CMAEvolutionStrategy(
        np.zeros(template.n_genes),
        1.0,
        # A gene of a stored genome lies in [-10, 10].
        {"popsize": popsize, "seed": args.seed + 1, "verbose": -9, "bounds": [-10, 10]},
    )
    curve = []
    spent = 0
    generation = 0
    best_genes, best_fitness = None, -np.inf
    while spent + popsize * per_candidate <= args.evaluations:
        candidates = np.asarray(strategy.ask(), dtype=np.float32)
        result = hevo.evaluate(
            template,
            candidates,
            task,
            samples=per_variant,
            seed=generation_seed(generation),
            threads=args.threads,
        )
        # CMA-ES minimises.
        strategy.tell(list(candidates.astype(np.float64)), list(-result.fitness))
        spent += popsize * per_candidate
        generation += 1
        winner = int(np.argmax(result.fitness))
        curve.append((spent, float(result.fitness[winner])))
        if result.fitness[winner] > best_fitness:
            best_genes, best_fitness = candidates[winner], result.fitness[winner]
    if best_genes is None:
        raise SystemExit("--evaluations is smaller than one CMA-ES generation")
    return curve, best_genes


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("cma-vs-ea"))
    parser.add_argument("--evaluations", type=int, default=60_000, help="episodes per algorithm")
    parser.add_argument("--population", type=int, default=20)
    parser.add_argument("--samples", type=int, default=6, help="episodes per genome per generation")
    parser.add_argument("--post-samples", type=int, default=50, help="post-evaluation samples per variant")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=None)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    task = hevo.Task("solve_maze")
    template = hevo.Controller.load(SHIPPED).without_genome("solve_maze")
    ea_curve, ea_genes = run_hevo_ea(args.out, args)
    cma_curve, cma_genes = run_cma(template, task, args)

    finals = hevo.evaluate(
        template,
        np.stack([ea_genes, cma_genes]).astype(np.float32),
        task,
        samples=args.post_samples,
        seed=999,
        threads=args.threads,
    )
    labels = ["hevo EA", "CMA-ES"]
    files = ["ea_best.json", "cma_best.json"]
    for name, genes, row in zip(labels, (ea_genes, cma_genes), range(2)):
        template.with_genome(genes).save(args.out / files[row])
        print(
            f"{name:8} {ea_curve[-1][0] if row == 0 else cma_curve[-1][0]:>8} evaluations: "
            f"post-evaluation solve rate {100 * finals.solve_rate[row]:5.1f}%, "
            f"mean fitness {finals.fitness[row]:.3f} ({finals.samples} samples)"
        )

    figure, axes = plt.subplots(figsize=(7, 4))
    for (name, curve), row in zip(zip(labels, (ea_curve, cma_curve)), range(2)):
        x, y = zip(*curve)
        axes.plot(x, y, label=f"{name} (post-evaluation {100 * finals.solve_rate[row]:.0f}% solved)")
    axes.set_xlabel("evaluations (episodes)")
    axes.set_ylabel("best fitness of the generation")
    axes.set_title("solve_maze arbitrator over the shipped primitives")
    axes.legend()
    figure.tight_layout()
    figure.savefig(args.out / "cma_vs_ea.png", dpi=120)
    print(f"plot -> {args.out / 'cma_vs_ea.png'}")


if __name__ == "__main__":
    main()
