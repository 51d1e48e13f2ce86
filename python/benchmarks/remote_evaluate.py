"""Wall time of `hevo.Client.evaluate` on a master with local workers against `hevo.evaluate`
on as many threads, on the same genomes and samples (checked equal, byte for byte, on every
repeat). A benchmark, not a test: what it shows is the remote path's overhead (the request,
the dispatcher's batches over gRPC, the results streamed back) on one machine; on a cluster the
workers are other machines.

    cargo build -p hevo-cli -p hevo-worker    # or --release, with --bin-dir target/release
    python python/benchmarks/remote_evaluate.py --workers 2

The master and the workers (one thread each) are started on 127.0.0.1 as the tests start them
(`python/tests/conftest.py`'s `cluster`).
"""

import argparse
import pathlib
import statistics
import sys
import tempfile
import time

import numpy as np

import hevo

REPO = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python" / "tests"))
from conftest import CLIENT_TOKEN, cluster  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=2, help="workers, and hevo.evaluate's threads")
    parser.add_argument("--genomes", type=int, default=100)
    parser.add_argument("--samples", type=int, default=5, help="samples per light configuration")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--bin-dir", type=pathlib.Path, default=REPO / "target" / "debug")
    args = parser.parse_args()
    binaries = {name: args.bin_dir / name for name in ("hevo", "hevo-worker")}

    maze = hevo.Controller.load(REPO / "controllers" / "solve_maze.json")
    template = maze.without_genome("solve_maze")
    rng = np.random.default_rng(0)
    genomes = maze.genome("solve_maze")[None, :] + rng.normal(0, 0.5, (args.genomes, template.n_genes))
    task = hevo.Task("solve_maze")
    with tempfile.TemporaryDirectory() as directory, cluster(
        binaries, pathlib.Path(directory), workers=args.workers
    ) as running:
        client = hevo.Client(running.url, token=CLIENT_TOKEN)
        # The workers connect while this first, small call waits for them.
        client.evaluate(template, genomes[:4], task, samples=1, clip=True)
        local, remote = [], []
        for _ in range(args.repeats):
            start = time.perf_counter()
            here = hevo.evaluate(template, genomes, task, samples=args.samples, seed=1,
                                 threads=args.workers, clip=True)
            local.append(time.perf_counter() - start)
            start = time.perf_counter()
            there = client.evaluate(template, genomes, task, samples=args.samples, seed=1, clip=True)
            remote.append(time.perf_counter() - start)
            for name in ("fitness", "sample_fitness", "sample_cycles", "per_variant"):
                assert getattr(here, name).tobytes() == getattr(there, name).tobytes(), name
    print(f"{args.genomes} genomes x {here.samples} samples, {int(here.sample_cycles.sum()):,} cycles, "
          f"{args.repeats} repeats, results equal byte for byte")
    for label, times in ((f"hevo.evaluate, {args.workers} threads", local),
                         (f"Client.evaluate, {args.workers} workers x 1 thread", remote)):
        print(f"{label}: median {statistics.median(times):.2f} s ({', '.join(f'{t:.2f}' for t in times)})")


if __name__ == "__main__":
    main()
