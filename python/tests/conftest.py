"""Shared fixtures of hevo's Python tests: the repository, the real `hevo` and `hevo-worker`
binaries (built by scripts/python-tests.sh; HEVO_TEST_BIN_DIR points elsewhere, as for the
Rust end-to-end tests), a helper that runs `hevo` and returns what it printed, and a master
with workers on 127.0.0.1 port 0."""

import contextlib
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


CLIENT_TOKEN = "python-client-token"
WORKER_TOKEN = "python-worker-token"


class Cluster:
    """A running master (`url`, `metrics_url` when asked for) and its workers' processes."""

    def __init__(self, url, metrics_url, workers, directory):
        self.url = url
        self.metrics_url = metrics_url
        self.workers = workers
        self.directory = directory

    def start_worker(self, binaries):
        """One more `hevo-worker` of one thread, `py0`, `py1`, ... (killed with the cluster)."""
        k = len(self.workers)
        self.workers.append(subprocess.Popen(
            [str(binaries["hevo-worker"]), "--master", self.url, "--threads", "1", "--name", f"py{k}"],
            env={"HEVO_TOKEN": WORKER_TOKEN, "PATH": "/usr/bin:/bin"},
            stdout=subprocess.DEVNULL, stderr=open(self.directory / f"worker{k}.log", "w"),
        ))
        return self.workers[-1]


@contextlib.contextmanager
def cluster(binaries, directory, workers=1, master_args=()):
    """`hevo serve` on 127.0.0.1 port 0 with client and worker tokens, and `workers`
    `hevo-worker` processes of one thread each (logs in `directory`); all killed afterwards."""
    (directory / "clients").write_text(CLIENT_TOKEN + "\n")
    (directory / "workers").write_text(WORKER_TOKEN + "\n")
    log = open(directory / "master.log", "w")
    serve = subprocess.Popen(
        [
            str(binaries["hevo"]), "serve", "--listen", "127.0.0.1:0",
            "--state-dir", str(directory / "state"),
            "--token-file", str(directory / "clients"),
            "--worker-token-file", str(directory / "workers"),
            *map(str, master_args),
        ],
        stdout=subprocess.PIPE, stderr=log, text=True,
    )
    started = []
    try:
        first = serve.stdout.readline().strip()
        assert first.startswith("listening on "), (first, (directory / "master.log").read_text())
        url = "http://" + first[len("listening on "):]
        metrics_url = None
        if "--metrics-listen" in master_args:
            second = serve.stdout.readline().strip()
            assert second.startswith("metrics on "), second
            metrics_url = "http://" + second[len("metrics on "):] + "/metrics"
        running = Cluster(url, metrics_url, started, directory)
        for _ in range(workers):
            running.start_worker(binaries)
        yield running
    finally:
        for process in (*started, serve):
            process.kill()
            process.wait()
        log.close()
