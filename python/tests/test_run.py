"""hevo.run: the runner of `hevo run` (the same files, bit for bit), its progress events, and
Ctrl-C: the run stops cleanly and the same call resumes it to the files of an uninterrupted
run."""

import filecmp
import os
import pathlib
import signal
import subprocess
import sys
import textwrap

import pytest

import hevo

EXPERIMENT = textwrap.dedent(
    """
    [experiment]
    name = "python-run"
    seed = 5

    [evolution]
    population = 6
    elites = 2
    post_evaluation_samples = 2

    [[node]]
    name = "follow_wall"
    kind = "primitive"
    inputs = ["ir"]
    hidden = 2
    task = "follow_wall"
    samples = 2
    cycles = CYCLES
    generations = GENERATIONS
    runs = 1
    """
)


def experiment_file(tmp_path, generations, cycles=60):
    path = tmp_path / f"experiment-{generations}-{cycles}.toml"
    path.write_text(
        EXPERIMENT.replace("GENERATIONS", str(generations)).replace("CYCLES", str(cycles))
    )
    return path


def same_tree(a: pathlib.Path, b: pathlib.Path):
    files_a = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    files_b = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert files_a == files_b
    for relative in files_a:
        assert filecmp.cmp(a / relative, b / relative, shallow=False), relative


def test_the_same_files_as_hevo_run(tmp_path, hevo_cli):
    experiment = experiment_file(tmp_path, 3)
    events = []
    summaries = hevo.run(experiment, out=tmp_path / "python", threads=2, progress=events.append)
    hevo_cli("run", experiment, "--out", tmp_path / "cli", "--threads", 1)
    same_tree(tmp_path / "python", tmp_path / "cli")
    assert [s["node"] for s in summaries] == ["follow_wall"]
    kinds = [event["event"] for event in events]
    assert kinds[0] == "node_started" and kinds[-1] == "node_finished"
    assert kinds.count("generation") == 3
    generation = next(event for event in events if event["event"] == "generation")
    assert set(generation) >= {"node", "run", "generation", "best", "mean", "cycles"}


def test_an_exception_in_the_callback_stops_the_run_and_a_rerun_resumes(tmp_path):
    experiment = experiment_file(tmp_path, 4)
    out = tmp_path / "stopped"

    def stop_after_two(event):
        if event["event"] == "generation" and event["generation"] == 1:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        hevo.run(experiment, out=out, progress=stop_after_two)
    resumed = []
    hevo.run(experiment, out=out, progress=resumed.append)
    generations = [e["generation"] for e in resumed if e["event"] == "generation"]
    assert generations and generations[0] >= 2, generations
    hevo.run(experiment, out=tmp_path / "straight")
    same_tree(out, tmp_path / "straight")


def test_ctrl_c_stops_cleanly_and_a_rerun_resumes(tmp_path):
    # Long enough (about 10 ms a generation) that the signal comes while it runs.
    experiment = experiment_file(tmp_path, 300, cycles=800)
    out = tmp_path / "interrupted"
    script = textwrap.dedent(
        f"""
        import signal, sys, hevo
        # Ctrl-C as a terminal delivers it, whatever the test runner's own SIGINT disposition
        # (a runner started in the background inherits SIGINT ignored).
        signal.signal(signal.SIGINT, signal.default_int_handler)
        def show(event):
            if event["event"] == "generation":
                print("generation", event["generation"], flush=True)
        try:
            hevo.run({str(experiment)!r}, out={str(out)!r}, threads=1, progress=show)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(3)
        """
    )
    child = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=os.environ.copy()
    )
    try:
        assert child.stdout.readline().startswith("generation")
        child.send_signal(signal.SIGINT)
        rest = child.stdout.read()
        assert child.wait(timeout=60) == 3, rest
    finally:
        child.kill()
    assert "interrupted" in rest
    resumed = []
    hevo.run(experiment, out=out, progress=resumed.append)
    first = next(e["generation"] for e in resumed if e["event"] == "generation")
    assert first >= 1
    hevo.run(experiment, out=tmp_path / "straight")
    same_tree(out, tmp_path / "straight")


def test_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[experiment]\nname = 'x'\nseed = 1\nsurprise = 2\n")
    with pytest.raises(hevo.ConfigError, match="bad.toml"):
        hevo.run(bad, out=tmp_path / "out")
    with pytest.raises(hevo.ConfigError, match="no node named 'nope'"):
        hevo.run(experiment_file(tmp_path, 1), out=tmp_path / "out", node="nope")
