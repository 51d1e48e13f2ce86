"""The examples of docs/python.md run as written: the "A first look" block, from the
repository's root (its paths are relative to it), writing its picture into a temporary
directory."""

import pathlib
import re
import subprocess
import sys

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "python.md"


def python_blocks():
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_first_look_runs(repo, tmp_path):
    first = python_blocks()[0]
    assert "hevo.evaluate(" in first and "hevo.trace(" in first
    # The picture goes to the temporary directory, not into the checkout.
    script = first.replace('"maze.svg"', repr(str(tmp_path / "maze.svg")))
    completed = subprocess.run(
        [sys.executable, "-c", script], cwd=repo, capture_output=True, text=True, timeout=600
    )
    assert completed.returncode == 0, completed.stderr
    lines = completed.stdout.splitlines()
    assert lines[-1].startswith("(") and ", 2, 3)" in lines[-1], lines
    assert (tmp_path / "maze.svg").stat().st_size > 1000
