"""Draw one sample of a controller with matplotlib from `hevo.trace`'s arrays: the walls, the
robot's path coloured by the primitive that drove it, and below it the sensor inputs and wheel
outputs per cycle.

    pip install "./python[examples]"          # the module with pycma and matplotlib
    python python/examples/draw_trace.py                       # the maze controller, variant 2
    python python/examples/draw_trace.py --controller controllers/rescue.json --task rescue \\
        --seed 1 --variant 3 --out rescue_trace.png
"""

import argparse
import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from matplotlib.transforms import Affine2D  # noqa: E402
import numpy as np  # noqa: E402

import hevo  # noqa: E402

REPO = pathlib.Path(__file__).resolve().parents[2]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", type=pathlib.Path, default=REPO / "controllers" / "solve_maze.json")
    parser.add_argument("--task", default="solve_maze")
    parser.add_argument("--seed", type=int, default=4)
    parser.add_argument("--variant", type=int, default=2)
    parser.add_argument("--out", type=pathlib.Path, default=pathlib.Path("trace.png"))
    args = parser.parse_args()

    controller = hevo.Controller.load(args.controller)
    trace = hevo.trace(controller, hevo.Task(args.task), seed=args.seed, variant=args.variant)

    figure, (world, signals) = plt.subplots(
        2, 1, figsize=(7, 9), gridspec_kw={"height_ratios": [3, 1]}
    )
    for cx, cy, hw, hh, angle in trace.walls:
        rectangle = Rectangle((cx - hw, cy - hh), 2 * hw, 2 * hh, color="0.3")
        rectangle.set_transform(Affine2D().rotate_around(cx, cy, angle) + world.transData)
        world.add_patch(rectangle)
    xy = trace.poses[:, 0, :2]
    drivers = trace.active_node
    for node in np.unique(drivers):
        mask = drivers == node
        world.scatter(xy[mask, 0], xy[mask, 1], s=2, label=trace.node_paths[node])
    if "teammate" in trace.robots:
        world.plot(trace.poses[:, 1, 0], trace.poses[:, 1, 1], color="0.6", lw=1, label="teammate")
    world.set_aspect("equal")
    world.autoscale()
    world.legend(loc="upper right", fontsize=8, markerscale=4)
    outcome = trace.outcome
    world.set_title(
        f"{trace.task}, seed {trace.seed}, variant {trace.variant}: "
        f"{outcome['ending']} after {outcome['cycles']} cycles, fitness {outcome['fitness']:.3f}"
    )

    cycles = np.arange(len(trace))
    for column, name in enumerate(trace.input_names[:4]):
        signals.plot(cycles, trace.inputs[:, column], lw=0.8, label=name)
    signals.plot(cycles, trace.outputs[:, 0], "k-", lw=1, label="wheel left")
    signals.plot(cycles, trace.outputs[:, 1], "k--", lw=1, label="wheel right")
    signals.set_xlabel("cycle")
    signals.legend(ncol=3, fontsize=7)
    figure.tight_layout()
    figure.savefig(args.out, dpi=120)
    print(f"{len(trace)} cycles -> {args.out}")


if __name__ == "__main__":
    main()
