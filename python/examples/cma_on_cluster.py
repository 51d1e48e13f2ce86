"""pycma's CMA-ES evolving the double T-maze arbitrator over the shipped primitives
(controllers/solve_maze.json), with every generation evaluated by the cluster's workers through
`hevo.Client.evaluate`: the optimiser runs here (a script or a notebook), the episodes on every
worker the master has. The genomes go over as pycma makes them, float64 and unbounded; clip=True
keeps them in hevo's gene range. The last generation is evaluated once more here, with
`hevo.evaluate`, to show the two give the same numbers.

    pip install "./python[examples]"          # the module with pycma and matplotlib
    hevo serve --listen 0.0.0.0:50051 --token-file clients --worker-token-file workers &
    hevo-worker --master http://HOST:50051 &        # on every machine, HEVO_TOKEN=<worker token>
    python python/examples/cma_on_cluster.py --master http://HOST:50051 --token-file clients
"""

import argparse
import pathlib

import cma
import numpy as np

import hevo

REPO = pathlib.Path(__file__).resolve().parents[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--master", required=True, help="the master's URL")
    parser.add_argument("--token", default=None, help="a client token (else --token-file or HEVO_TOKEN)")
    parser.add_argument("--token-file", default=None)
    parser.add_argument("--generations", type=int, default=30)
    parser.add_argument("--population", type=int, default=24)
    parser.add_argument("--samples", type=int, default=2, help="samples per light configuration")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("cma_cluster_best.json"))
    args = parser.parse_args()

    client = hevo.Client(args.master, token=args.token, token_file=args.token_file)
    task = hevo.Task("solve_maze")
    template = hevo.Controller.load(REPO / "controllers" / "solve_maze.json").without_genome("solve_maze")
    strategy = cma.CMAEvolutionStrategy(
        np.zeros(template.n_genes), 2.0,
        {"popsize": args.population, "seed": args.seed, "verbose": -9},
    )
    best_genes, best_fitness = None, -np.inf
    for generation in range(args.generations):
        candidates = np.array(strategy.ask())           # float64, (population, n_genes)
        result = client.evaluate(
            template, candidates, task, samples=args.samples, seed=generation, clip=True
        )
        strategy.tell(list(candidates), list(-result.fitness))   # CMA-ES minimises
        winner = int(np.argmax(result.fitness))
        if result.fitness[winner] > best_fitness:
            best_genes, best_fitness = np.clip(candidates[winner], *hevo.GENE_RANGE), result.fitness[winner]
        print(
            f"generation {generation:3}: best {result.fitness[winner]:.3f}, "
            f"mean {result.fitness.mean():.3f}, solved {100 * result.solve_rate[winner]:.0f}% "
            f"({len(candidates)} genomes x {result.samples} samples on the cluster)"
        )

    local = hevo.evaluate(template, candidates, task, samples=args.samples, seed=generation, clip=True)
    same = all(
        getattr(local, name).tobytes() == getattr(result, name).tobytes()
        for name in ("fitness", "solve_rate", "per_variant", "sample_fitness", "sample_cycles")
    )
    print(f"last generation evaluated here too: the same numbers as the cluster's: {same}")
    template.with_genome(best_genes).save(args.out)
    print(f"best fitness {best_fitness:.3f} -> {args.out}")


if __name__ == "__main__":
    main()
