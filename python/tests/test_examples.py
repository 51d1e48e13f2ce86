"""The examples in python/examples/ run, at tiny settings, and write what they say."""

import pathlib
import subprocess
import sys

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def run_example(name, *args):
    completed = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert completed.returncode == 0, completed.stderr
    return completed.stdout


def test_cma_against_hevos_ea(tmp_path):
    out = run_example(
        "cma_maze_arbitrator.py", "--out", tmp_path, "--evaluations", 240,
        "--population", 10, "--samples", 3, "--post-samples", 2, "--threads", 2,
    )
    assert "hevo EA" in out and "CMA-ES" in out
    assert (tmp_path / "cma_vs_ea.png").stat().st_size > 1000
    assert (tmp_path / "cma_best.json").is_file() and (tmp_path / "ea_best.json").is_file()


def test_draw_trace(tmp_path):
    out = run_example("draw_trace.py", "--out", tmp_path / "trace.png")
    assert "cycles" in out
    assert (tmp_path / "trace.png").stat().st_size > 1000
