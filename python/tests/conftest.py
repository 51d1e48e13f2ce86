"""Shared fixtures of hevo's Python tests: the repository, the real `hevo` and `hevo-worker`
binaries (built by scripts/python-tests.sh; HEVO_TEST_BIN_DIR points elsewhere, as for the
Rust end-to-end tests), and a helper that runs `hevo` and returns what it printed."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def _binary_dir() -> pathlib.Path:
    explicit = os.environ.get("HEVO_TEST_BIN_DIR")
    if explicit:
        return pathlib.Path(explicit)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "debug"


@pytest.fixture(scope="session")
def repo() -> pathlib.Path:
    return REPO


@pytest.fixture(scope="session")
def binaries() -> dict:
    """The `hevo` and `hevo-worker` executables. A missing one fails the test: the comparisons
    with the command line are what these tests are for."""
    directory = _binary_dir()
    found = {name: directory / name for name in ("hevo", "hevo-worker")}
    for name, path in found.items():
        if not path.is_file():
            pytest.fail(
                f"{path} does not exist: run `cargo build -p hevo-cli -p hevo-worker` "
                "or set HEVO_TEST_BIN_DIR (scripts/python-tests.sh does both)"
            )
    return found


@pytest.fixture(scope="session")
def hevo_cli(binaries):
    """Runs `hevo ARGS...`; returns the completed process (text output)."""

    def run(*args, check=True):
        completed = subprocess.run(
            [str(binaries["hevo"]), *map(str, args)],
            capture_output=True,
            text=True,
            cwd=REPO,
            timeout=300,
        )
        if check and completed.returncode != 0:
            raise AssertionError(
                f"hevo {' '.join(map(str, args))} failed ({completed.returncode}):\n{completed.stderr}"
            )
        return completed

    return run
