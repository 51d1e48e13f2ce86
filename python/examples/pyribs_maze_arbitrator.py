"""MAP-Elites with pyribs on the double T-maze arbitrator over hevo's shipped primitives: a
GridArchive over hevo's behaviour descriptor (where the robot ended, `final.x` and `final.y`,
each the mean over a genome's samples: `Evaluation.descriptor`) and a GaussianEmitter, every
batch evaluated by `hevo.evaluate`, or by a master's workers with --master. Prints the
QD-score, the coverage and the best elite's post-evaluation, and draws the archive.

    pip install "./python[examples]"          # the module with pyribs and matplotlib
    python python/examples/pyribs_maze_arbitrator.py --out ribs-maze
    python python/examples/pyribs_maze_arbitrator.py --out tiny --iterations 20 --batch 16

An evaluation is one genome on one sample (one episode).
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from ribs.archives import GridArchive  # noqa: E402
from ribs.emitters import GaussianEmitter  # noqa: E402
from ribs.schedulers import Scheduler  # noqa: E402

import hevo  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]
SHIPPED = REPO / "controllers" / "solve_maze.json"


def arena_ranges(task: hevo.Task):
    """The descriptor's ranges: the extent of the maze's walls (x and y, metres), from a trace."""
    walls = hevo.trace(hevo.Controller.load(SHIPPED), task, seed=0).walls
    reach = np.maximum(walls[:, 2], walls[:, 3])  # half extents, whatever the rotation
    low = (walls[:, :2] - reach[:, None]).min(axis=0)
    high = (walls[:, :2] + reach[:, None]).max(axis=0)
    return [(float(low[0]), float(high[0])), (float(low[1]), float(high[1]))]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("ribs-maze"))
    parser.add_argument("--iterations", type=int, default=300)
    parser.add_argument("--batch", type=int, default=40, help="genomes per iteration")
    parser.add_argument("--samples", type=int, default=2, help="samples per light configuration")
    parser.add_argument("--bins", type=int, default=20, help="cells per descriptor dimension")
    parser.add_argument("--sigma", type=float, default=0.5, help="the emitter's Gaussian step")
    parser.add_argument("--post-samples", type=int, default=50, help="post-evaluation samples per variant")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--master", help="evaluate on this master's workers (hevo.Client)")
    parser.add_argument("--token", help="the master's client token (else HEVO_TOKEN)")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)

    task = hevo.Task("solve_maze")
    shipped = hevo.Controller.load(SHIPPED)
    template = shipped.without_genome("solve_maze")
    if args.master:
        evaluate = hevo.Client(args.master, token=args.token).evaluate
    else:
        evaluate = hevo.evaluate

    ranges = arena_ranges(task)
    archive = GridArchive(
        solution_dim=template.n_genes,
        dims=[args.bins, args.bins],
        ranges=ranges,
        # The maze's fitness is at least 0 (a timeout), so the QD-score is the elites' sum.
        qd_score_offset=0.0,
        seed=args.seed,
    )
    emitter = GaussianEmitter(
        archive,
        sigma=args.sigma,
        x0=np.zeros(template.n_genes),
        # A gene lies in hevo.GENE_RANGE: the emitter keeps its genomes there.
        bounds=[hevo.GENE_RANGE] * template.n_genes,
        batch_size=args.batch,
        seed=args.seed,
    )
    scheduler = Scheduler(archive, [emitter])
    per_genome = args.samples * task.n_variants
    for iteration in range(args.iterations):
        genomes = scheduler.ask()  # float64
        result = evaluate(template, genomes, task, samples=args.samples, seed=10_000 + iteration)
        scheduler.tell(result.fitness, result.descriptor)
        if iteration % max(1, args.iterations // 10) == 0 or iteration == args.iterations - 1:
            stats = archive.stats
            print(
                f"iteration {iteration + 1:>4} ({(iteration + 1) * args.batch * per_genome} "
                f"evaluations): QD-score {stats.qd_score:.2f}, coverage "
                f"{100 * stats.coverage:.1f}%, best {stats.obj_max:.3f}"
            )

    elites = archive.data()
    best = int(np.argmax(elites["objective"]))
    genes = elites["solution"][best]
    final = hevo.evaluate(template, genes[None, :], task, samples=args.post_samples, seed=999,
                          threads=args.threads)
    template.with_genome(genes).save(args.out / "ribs_best.json")
    stats = archive.stats
    print(
        f"archive: {stats.num_elites} elites of {args.bins * args.bins} cells, QD-score "
        f"{stats.qd_score:.2f}, coverage {100 * stats.coverage:.1f}%; the best elite's "
        f"post-evaluation solve rate {100 * final.solve_rate[0]:.1f}% ({final.samples} samples)"
    )

    grid = np.full((args.bins, args.bins), np.nan)
    index = archive.int_to_grid_index(elites["index"])
    grid[index[:, 1], index[:, 0]] = elites["objective"]
    figure, axes = plt.subplots(figsize=(5, 4.5))
    image = axes.imshow(grid, origin="lower", extent=[*ranges[0], *ranges[1]], cmap="viridis")
    figure.colorbar(image, label="fitness of the cell's elite")
    axes.set_xlabel(result.descriptor_names[0] + " (m)")
    axes.set_ylabel(result.descriptor_names[1] + " (m)")
    axes.set_title("where the arbitrators end (pyribs archive)")
    figure.tight_layout()
    figure.savefig(args.out / "ribs_archive.png", dpi=120)
    print(f"archive -> {args.out / 'ribs_archive.png'}")


if __name__ == "__main__":
    main()
