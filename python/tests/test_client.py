"""hevo.Client against a real master (`hevo serve` on 127.0.0.1 port 0) and worker
(`hevo-worker`): submit, watch to the end, jobs, fetch (the files a local `hevo run` writes,
bit for bit), cancel, and the errors."""

import filecmp
import textwrap

import pytest

import hevo
from conftest import CLIENT_TOKEN, WORKER_TOKEN, cluster

EXPERIMENT = textwrap.dedent(
    """
    [experiment]
    name = "python-client"
    seed = 3

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
    cycles = 80
    generations = 3
    runs = 1
    """
)


@pytest.fixture
def master(tmp_path, binaries):
    """A master and one worker; yields the master's URL."""
    with cluster(binaries, tmp_path) as running:
        yield running.url


def test_submit_watch_jobs_fetch(master, tmp_path, hevo_cli):
    experiment = tmp_path / "experiment.toml"
    experiment.write_text(EXPERIMENT)
    client = hevo.Client(master, token=CLIENT_TOKEN)
    job = client.submit(experiment)
    events = list(client.watch(job))
    assert events[-1]["event"] == "status"
    assert events[-1]["state"] == "succeeded", events[-1]
    assert any(event["event"] == "generation" for event in events)
    jobs = client.jobs()
    assert [j["job_id"] for j in jobs] == [job]
    assert jobs[0]["experiment_name"] == "python-client"
    fetched = client.fetch(job, tmp_path / "fetched")
    assert fetched["state"] == "succeeded" and fetched["files"] > 0
    hevo_cli("run", experiment, "--out", tmp_path / "local")
    local = sorted(p.relative_to(tmp_path / "local") for p in (tmp_path / "local").rglob("*") if p.is_file())
    remote = sorted(p.relative_to(tmp_path / "fetched") for p in (tmp_path / "fetched").rglob("*") if p.is_file())
    assert local == remote
    for relative in local:
        assert filecmp.cmp(tmp_path / "local" / relative, tmp_path / "fetched" / relative, shallow=False)


def test_cancel_and_refusals(master, tmp_path):
    experiment = tmp_path / "experiment.toml"
    experiment.write_text(EXPERIMENT.replace("generations = 3", "generations = 100000"))
    client = hevo.Client(master, token=CLIENT_TOKEN)
    job = client.submit(experiment)
    assert client.cancel(job)["state"] in ("cancelled", "succeeded")
    final = list(client.watch(job))[-1]
    assert final["state"] == "cancelled"
    with pytest.raises(hevo.ClientError, match="NOT_FOUND|no job"):
        client.cancel("no-such-job")
    with pytest.raises(hevo.ClientError, match="UNAUTHENTICATED|token"):
        hevo.Client(master, token="wrong-token").jobs()
    with pytest.raises(hevo.ClientError):
        hevo.Client(master, token=WORKER_TOKEN).jobs()
    with pytest.raises(hevo.ConfigError):
        hevo.Client("http://[not a url", token=CLIENT_TOKEN)
