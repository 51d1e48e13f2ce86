"""The examples in python/examples/ run, at tiny settings, and write what they say
(`cma_on_cluster.py` against a real master with two workers), and what they import comes with
the module or one of its extras (`examples`; `evotorch`, whose example runs only where it
is installed)."""

import ast
import importlib.util
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest

import hevo
from conftest import CLIENT_TOKEN, cluster

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def test_the_examples_extra_has_what_the_examples_import():
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((EXAMPLES.parent / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    requirements = project["dependencies"] + [r for extra in extras.values() for r in extra]
    provided = {re.split(r"[<>=!~ \[;]", requirement)[0] for requirement in requirements}
    # What a package brings that an example imports by its own name.
    provided |= {"torch"} if "evotorch" in provided else set()
    for example in EXAMPLES.glob("*.py"):
        tree = ast.parse(example.read_text())
        imported = {alias.name.split(".")[0] for node in ast.walk(tree)
                    if isinstance(node, ast.Import) for alias in node.names}
        imported |= {node.module.split(".")[0] for node in ast.walk(tree)
                     if isinstance(node, ast.ImportFrom) and node.level == 0}
        # An example may take a function from another (python/examples/ is its sys.path[0]).
        siblings = {path.stem for path in EXAMPLES.glob("*.py")}
        outside = {name for name in imported
                   if name not in sys.stdlib_module_names and name != "hevo" and name not in siblings}
        # The examples' packages install modules of their own names (cma, matplotlib, ribs).
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


def test_hevo_cmaes_beside_pycma_and_resumed(tmp_path):
    tiny = ["--population", 6, "--samples", 4, "--post-samples", 1, "--threads", 2]
    out = run_example("hevo_cmaes_maze_arbitrator.py", "--out", tmp_path / "both",
                      "--evaluations", 72, *tiny)
    assert "hevo CMA-ES" in out and "pycma" in out
    assert (tmp_path / "both" / "hevo_cmaes.png").stat().st_size > 1000
    assert hevo.Controller.load(tmp_path / "both" / "hevo_best.json").free_node is None
    # Two generations, then one more: the state is the one three straight generations leave.
    split = tmp_path / "split"
    run_example("hevo_cmaes_maze_arbitrator.py", "--out", split, "--evaluations", 48,
                "--without-pycma", *tiny)
    out = run_example("hevo_cmaes_maze_arbitrator.py", "--out", split, "--evaluations", 72,
                      "--without-pycma", *tiny)
    assert "resumed at generation 2" in out, out
    state = (split / "hevo_cmaes.state").read_bytes()
    assert hevo.Strategy.from_state(state).generation == 3
    assert state == (tmp_path / "both" / "hevo_cmaes.state").read_bytes()


def test_pyribs_map_elites_over_hevo_s_descriptors_beside_hevo_s_own(tmp_path):
    pytest.importorskip("ribs")
    out = run_example(
        "pyribs_maze_arbitrator.py", "--out", tmp_path, "--iterations", 3, "--batch", 8,
        "--samples", 1, "--bins", 5, "--post-samples", 1, "--threads", 2,
    )
    assert "same budget: 96 evaluations each" in out, out
    # Both archives spread over more than one cell: hevo's descriptors reached each of them.
    for name in ["pyribs", "hevo"]:
        found = re.search(rf"{name} archive: +(\d+) elites of 25 cells, QD-score [0-9.]+, "
                          r"coverage [0-9.]+%", out)
        assert found and int(found.group(1)) >= 2, out
        assert hevo.Controller.load(tmp_path / f"{name}_best.json").free_node is None
    assert (tmp_path / "archives.png").stat().st_size > 1000


def load_example(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_evotorch_adapter_s_fitness_is_hevo_evaluate_s(repo):
    # The numpy half of the adapter, which needs neither EvoTorch nor PyTorch.
    example = load_example("evotorch_maze_arbitrator")
    task = hevo.Task("solve_maze", max_cycles=100)
    template = hevo.Controller.load(repo / "controllers" / "solve_maze.json").without_genome("solve_maze")
    genomes = np.random.default_rng(3).normal(0, 4, (5, template.n_genes))  # some beyond 10
    fitness = example.HevoFitness(template, task, samples=1, first_seed=40)
    first, second = fitness(genomes), fitness(genomes)
    for seed, got in ((40, first), (41, second)):
        expected = hevo.evaluate(template, genomes, task, samples=1, seed=seed, clip=True)
        assert got.dtype == np.float64 and got.tobytes() == expected.fitness.tobytes()
    assert fitness.last.descriptor.shape == (5, 2)


def test_the_evotorch_example(tmp_path):
    # EvoTorch brings PyTorch, too heavy for the test environment: this runs only where the
    # `evotorch` extra is installed.
    pytest.importorskip("evotorch")
    out = run_example("evotorch_maze_arbitrator.py", "--generations", 2, "--population", 6,
                      "--samples", 1, "--post-samples", 1, "--out", tmp_path / "best.json")
    assert out.count("generation ") == 2, out
    assert hevo.Controller.load(tmp_path / "best.json").free_node is None


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
