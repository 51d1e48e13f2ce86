"""MAP-Elites with pyribs on the double T-maze arbitrator over hevo's shipped primitives: a
GridArchive over hevo's behaviour descriptor (where the robot ended, `final.x` and `final.y`,
each the mean over a genome's samples: `Evaluation.descriptor`) and a GaussianEmitter, every
batch evaluated by `hevo.evaluate`, or by a master's workers with --master; then hevo's own
MAP-Elites (`hevo.Strategy("map_elites")`) on the same grid, batch, Gaussian step and
evaluation seeds. Prints both archives' QD-score and coverage side by side and each best
elite's post-evaluation, and draws both archives.

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

    # hevo's MAP-Elites on the same budget: the same grid, batch and Gaussian step, random
    # genomes first (N(0, sigma^2), as pyribs' emitter draws around x0 = 0 while its archive
    # is empty), and the same evaluation seeds.
    strategy = hevo.Strategy(
        "map_elites", n_genes=template.n_genes, seed=args.seed, population=args.batch,
        map_elites_bins=[args.bins, args.bins], map_elites_ranges=[list(r) for r in ranges],
        map_elites_variation="gaussian", map_elites_sigma=args.sigma, initial_sigma=args.sigma,
        map_elites_initial=args.batch,
    )
    for iteration in range(args.iterations):
        result = evaluate(template, strategy.ask(), task, samples=args.samples,
                          seed=10_000 + iteration)
        strategy.tell(result.fitness, result.descriptor)

    elites = archive.data()
    ribs_genes = elites["solution"][int(np.argmax(elites["objective"]))]
    hevo_archive = strategy.archive
    hevo_genes = hevo_archive["genes"][int(np.argmax(hevo_archive["fitness"]))]
    stats = archive.stats
    rows = [
        ("pyribs", stats.num_elites, stats.qd_score, stats.coverage, ribs_genes),
        ("hevo", hevo_archive["filled"], hevo_archive["qd_score"], hevo_archive["coverage"],
         hevo_genes),
    ]
    cells = args.bins * args.bins
    print(f"same budget: {args.iterations * args.batch * per_genome} evaluations each")
    for name, filled, qd_score, coverage, genes in rows:
        final = hevo.evaluate(template, genes[None, :], task, samples=args.post_samples,
                              seed=999, threads=args.threads)
        template.with_genome(genes).save(args.out / f"{name}_best.json")
        print(
            f"{name + ' archive:':<16}{filled} elites of {cells} cells, QD-score {qd_score:.2f}, "
            f"coverage {100 * coverage:.1f}%; the best elite's post-evaluation solve rate "
            f"{100 * final.solve_rate[0]:.1f}% ({final.samples} samples)"
        )

    figure, all_axes = plt.subplots(1, 2, figsize=(10, 4.5), sharey=True)
    bins = archive.int_to_grid_index(elites["index"])
    hevo_bins = np.stack([hevo_archive["cell"] // args.bins, hevo_archive["cell"] % args.bins], 1)
    for axes, (name, grid_bins, fitness) in zip(all_axes, [
        ("pyribs", bins, elites["objective"]),
        ("hevo", hevo_bins, hevo_archive["fitness"]),
    ]):
        grid = np.full((args.bins, args.bins), np.nan)
        grid[grid_bins[:, 1], grid_bins[:, 0]] = fitness
        image = axes.imshow(grid, origin="lower", extent=[*ranges[0], *ranges[1]],
                            cmap="viridis")
        axes.set_xlabel(result.descriptor_names[0] + " (m)")
        axes.set_title(f"{name}'s archive")
    all_axes[0].set_ylabel(result.descriptor_names[1] + " (m)")
    figure.colorbar(image, ax=all_axes, label="fitness of the cell's elite")
    figure.savefig(args.out / "archives.png", dpi=120)
    print(f"archives -> {args.out / 'archives.png'}")


if __name__ == "__main__":
    main()
