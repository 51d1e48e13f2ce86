"""The examples in python/examples/ run, at tiny settings, and write what they say
(`cma_on_cluster.py` against a real master with two workers), and what they import comes with
the module or its `examples` extra."""

import ast
import pathlib
import re
import subprocess
import sys

import pytest

import hevo
from conftest import CLIENT_TOKEN, cluster

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def test_the_examples_extra_has_what_the_examples_import():
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((EXAMPLES.parent / "pyproject.toml").read_text())["project"]
    provided = {re.split(r"[<>=!~ \[;]", requirement)[0] for requirement in
                project["dependencies"] + project["optional-dependencies"]["examples"]}
    for example in EXAMPLES.glob("*.py"):
        tree = ast.parse(example.read_text())
        imported = {alias.name.split(".")[0] for node in ast.walk(tree)
                    if isinstance(node, ast.Import) for alias in node.names}
        imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                     if isinstance(node, ast.ImportFrom) and node.level == 0}
        outside = {name for name in imported
                   if name not in sys.stdlib_module_names and name != "hevo"}
        # The examples' packages install modules of their own names (cma, matplotlib).
        missing = outside - provided
        assert not missing, f"{example.name} imports {sorted(missing)}, not in the examples extra"


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


def test_cma_on_a_cluster(tmp_path, binaries):
    with cluster(binaries, tmp_path, workers=2) as running:
        out = run_example(
            "cma_on_cluster.py", "--master", running.url, "--token", CLIENT_TOKEN,
            "--generations", 3, "--population", 8, "--samples", 1,
            "--out", tmp_path / "best.json",
        )
    assert out.count("on the cluster)") == 3, out
    assert "the same numbers as the cluster's: True" in out, out
    best = hevo.Controller.load(tmp_path / "best.json")
    assert best.free_node is None


def test_linear_policy_on_the_vector_env():
    out = run_example(
        "linear_policy_env.py", "--iterations", 2, "--population", 4, "--episodes", 2,
        "--max-cycles", 60,
    )
    assert out.count("iteration") == 2, out
    assert "the policy on 50 new samples of exit_room: mean fitness" in out, out
