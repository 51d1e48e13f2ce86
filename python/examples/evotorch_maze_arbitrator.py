"""EvoTorch on the double T-maze arbitrator over hevo's shipped primitives: an EvoTorch
`Problem` whose batches are evaluated by `hevo.evaluate`, or by a master's workers with
--master (`hevo.Client.evaluate`, the same numbers), searched by EvoTorch's SNES.

    pip install "./python[evotorch]"          # the module with EvoTorch (and PyTorch)
    python python/examples/evotorch_maze_arbitrator.py --generations 50
    python python/examples/evotorch_maze_arbitrator.py --master http://master:50051 --token-file t

The adapter is two parts: `HevoFitness`, plain numpy (genomes in, fitness out, fresh samples
for every batch), and `hevo_problem`, the EvoTorch `Problem` around it. EvoTorch and PyTorch
are imported only by the second, so the first works, and is tested, without them.
"""

import argparse
import pathlib

import numpy as np

import hevo

REPO = pathlib.Path(__file__).resolve().parents[2]
SHIPPED = REPO / "controllers" / "solve_maze.json"


class HevoFitness:
    """Genomes (n, n_genes) of any float dtype to their fitness (n,), float64: each batch on
    `samples` fresh samples per variant (seeded `first_seed`, then one more per batch), by
    `evaluate` (`hevo.evaluate`, or a `hevo.Client`'s `evaluate`). Genes stray outside
    hevo.GENE_RANGE are clipped to it, as an unbounded Gaussian search needs."""

    def __init__(self, template, task, samples, evaluate=hevo.evaluate, first_seed=10_000):
        self.template, self.task, self.samples = template, task, samples
        self.evaluate = evaluate
        self.next_seed = first_seed
        self.last = None  # the last batch's whole Evaluation (descriptors, per-sample outcomes)

    def __call__(self, genomes):
        self.last = self.evaluate(self.template, np.asarray(genomes), self.task,
                                  samples=self.samples, seed=self.next_seed, clip=True)
        self.next_seed += 1
        return self.last.fitness


def hevo_problem(fitness: HevoFitness, initial_bounds=(-1.0, 1.0)):
    """An EvoTorch Problem maximising `fitness` over genomes of the template's free node."""
    import torch
    from evotorch import Problem

    class HevoProblem(Problem):
        def __init__(self):
            super().__init__(
                "max",
                solution_length=fitness.template.n_genes,
                initial_bounds=initial_bounds,
                bounds=hevo.GENE_RANGE,
                dtype=torch.float64,
            )

        def _evaluate_batch(self, solutions):
            values = solutions.values.detach().cpu().numpy()
            solutions.set_evals(torch.as_tensor(fitness(values), dtype=torch.float64))

    return HevoProblem()


def main():
    from evotorch.algorithms import SNES

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--generations", type=int, default=50)
    parser.add_argument("--population", type=int, default=20)
    parser.add_argument("--samples", type=int, default=2, help="samples per light configuration")
    parser.add_argument("--post-samples", type=int, default=50)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("evotorch_best.json"))
    parser.add_argument("--master", help="evaluate on this master's workers (hevo.Client)")
    parser.add_argument("--token-file", help="the master's client token (else HEVO_TOKEN)")
    args = parser.parse_args()

    task = hevo.Task("solve_maze")
    template = hevo.Controller.load(SHIPPED).without_genome("solve_maze")
    evaluate = (hevo.Client(args.master, token_file=args.token_file).evaluate
                if args.master else hevo.evaluate)
    fitness = HevoFitness(template, task, args.samples, evaluate)
    searcher = SNES(hevo_problem(fitness), stdev_init=1.0, popsize=args.population)
    for generation in range(args.generations):
        searcher.step()
        print(f"generation {generation + 1}: best {float(fitness.last.fitness.max()):.3f}")
    genes = searcher.status["center"].detach().cpu().numpy()
    final = hevo.evaluate(template, genes[None, :], task, samples=args.post_samples, seed=999,
                          clip=True)
    template.with_genome(np.clip(genes, *hevo.GENE_RANGE)).save(args.out)
    print(f"the search's centre: post-evaluation solve rate {100 * final.solve_rate[0]:.1f}% "
          f"({final.samples} samples) -> {args.out}")


if __name__ == "__main__":
    main()
