"""hevo.Client.evaluate against a real master (`hevo serve` on 127.0.0.1 port 0, spot checks
on) and its workers (`hevo-worker`): the Evaluation `hevo.evaluate` returns, byte for byte,
with a worker killed while it holds a batch and another taking over; the master's refusals."""

import re
import signal
import threading
import time
import urllib.request

import numpy as np
import pytest

import hevo
from conftest import CLIENT_TOKEN, WORKER_TOKEN, cluster
from test_evaluate import assert_same_evaluation


def metrics(url):
    """The master's metrics as {name: value} (unlabelled lines only)."""
    text = urllib.request.urlopen(url, timeout=10).read().decode()
    return {
        match.group(1): float(match.group(2))
        for match in re.finditer(r"^(hevo_[a-z_]+) (\S+)$", text, flags=re.M)
    }


def wait_for(condition, what, seconds=120):
    """Polls `condition` until it is true; fails naming `what` after `seconds`."""
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.02)


def cluster_with(tmp_path, binaries, workers):
    """A master with metrics and spot checks, and `workers` workers."""
    return cluster(
        binaries, tmp_path, workers=workers,
        master_args=("--metrics-listen", "127.0.0.1:0", "--verify-share", "0.2"),
    )


@pytest.fixture
def one_worker(tmp_path, binaries):
    with cluster_with(tmp_path, binaries, 1) as running:
        yield running


@pytest.fixture
def two_workers(tmp_path, binaries):
    with cluster_with(tmp_path, binaries, 2) as running:
        yield running


def maze_batch(repo, n, seed):
    complete = hevo.Controller.load(repo / "controllers" / "solve_maze.json")
    template = complete.without_genome("solve_maze")
    rng = np.random.default_rng(seed)
    # float64 and partly out of range, as an optimiser hands them over.
    genomes = complete.genome("solve_maze")[None, :] + rng.normal(0, 1.0, (n, template.n_genes))
    return template, genomes


def test_equal_to_local_evaluate_with_a_worker_killed_mid_batch(repo, binaries, one_worker):
    # Enough batches that the one worker is still busy with them when the test looks.
    template, genomes = maze_batch(repo, 96, seed=2)
    task = hevo.Task("solve_maze")
    client = hevo.Client(one_worker.url, token=CLIENT_TOKEN)
    outcome = {}

    def evaluate():
        try:
            outcome["result"] = client.evaluate(template, genomes, task, samples=3, seed=7, clip=True)
        except Exception as error:  # handed to the test's thread
            outcome["error"] = error

    thread = threading.Thread(target=evaluate)
    thread.start()
    # One worker alone, so a leased batch is its own; stopped (SIGSTOP) so it cannot finish the
    # batch between the look and the kill, and killed only if it still holds one once stopped.
    (doomed,) = one_worker.workers

    def stopped_holding_a_batch():
        if metrics(one_worker.metrics_url).get("hevo_batches_leased", 0) < 1:
            return False
        doomed.send_signal(signal.SIGSTOP)
        # Results sent just before the stop reach the master within this pause.
        time.sleep(0.2)
        holding = metrics(one_worker.metrics_url).get("hevo_batches_leased", 0) >= 1
        if not holding:
            doomed.send_signal(signal.SIGCONT)
        return holding

    wait_for(stopped_holding_a_batch, "the worker to be stopped holding a batch")
    doomed.kill()
    one_worker.start_worker(binaries)
    thread.join(timeout=600)
    assert not thread.is_alive(), "Client.evaluate did not return"
    assert "error" not in outcome, outcome.get("error")
    remote = outcome["result"]
    # The killed worker's lease was taken back and its batch evaluated by the other.
    after = metrics(one_worker.metrics_url)
    assert after["hevo_lease_revocations_total"] + after["hevo_lease_expiries_total"] >= 1, after
    local = hevo.evaluate(template, genomes, task, samples=3, seed=7, clip=True)
    assert_same_evaluation(remote, local)
    assert len(remote) == 96 and remote.samples == 12


def test_small_batches_and_refusals(repo, two_workers):
    template, genomes = maze_batch(repo, 3, seed=3)
    task = hevo.Task("solve_maze", max_cycles=100)
    client = hevo.Client(two_workers.url, token=CLIENT_TOKEN)
    genomes = np.clip(genomes, -10, 10)
    assert_same_evaluation(
        client.evaluate(template, genomes, task, samples=1, seed=1),
        hevo.evaluate(template, genomes, task, samples=1, seed=1),
    )
    empty = client.evaluate(template, genomes[:0], task, samples=1)
    assert len(empty) == 0 and empty.sample_fitness.shape == (0, 4)
    # Checked here as hevo.evaluate checks, before anything is sent.
    genomes[1, 2] = 11.0
    with pytest.raises(hevo.ControllerError, match=r"genomes\[1, 2\]"):
        client.evaluate(template, genomes, task, samples=1)
    # Bounded like a job's generation: the master refuses, naming the field.
    many = np.zeros((20_000, template.n_genes))
    with pytest.raises(hevo.ClientError, match="INVALID_ARGUMENT: genomes: .*evaluations at once"):
        client.evaluate(template, many, task, samples=50)
    with pytest.raises(hevo.ClientError, match="UNAUTHENTICATED|PermissionDenied|token|role"):
        hevo.Client(two_workers.url, token=WORKER_TOKEN).evaluate(template, genomes[:1], task)
