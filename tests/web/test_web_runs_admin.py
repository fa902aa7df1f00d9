"""Runs page API: resume a stopped run where it stopped, delete a run (inside the archive's
folder only, never while it runs)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from morphogen.search.archive import Archive
from morphogen.web.app import create_app
from tests.web.test_web_evolve import wait


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as c:
        yield c, archive


@pytest.mark.slow
def test_a_stopped_run_resumes_at_its_next_generation_and_deletes(setup, tmp_path):
    client, path = setup
    r = client.post("/api/evolve", json={"model": {"library": "gray-scott"}, "population": 2,
                                         "generations": 3, "size": 16, "steps": 20})
    run = r.json()["run"]
    assert wait(client, run, ("choose",))["gen"] == 1
    client.post(f"/api/evolve/{run}/select", json={"indices": [0]}).raise_for_status()
    assert wait(client, run, ("choose",))["gen"] == 2
    # while it runs it can be neither resumed nor deleted
    assert "already running" in client.post(f"/api/runs/{run}/resume").json()["error"]
    assert "stop it" in client.delete(f"/api/runs/{run}").json()["error"]
    client.post(f"/api/evolve/{run}/stop").raise_for_status()
    assert wait(client, run, ("stopped",))["state"] == "stopped"
    archive = Archive(path, create=False)
    assert archive.run(run)["status"] == "stopped" and len(archive.generations(run)) == 1
    # resumed, it continues with generation 2 (not from the start) and the page can follow it
    r = client.post(f"/api/runs/{run}/resume")
    assert r.status_code == 200, r.text
    status = wait(client, run, ("choose",))
    assert status["gen"] == 2 and len(status["images"]) == 2
    client.post(f"/api/evolve/{run}/stop").raise_for_status()
    wait(client, run, ("stopped",))
    # a run recorded elsewhere (e.g. `morphogen evolve --out DIR`) is not deleted from here
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    archive.create_run("outside-1", elsewhere, archive.run(run)["config"])
    r = client.delete("/api/runs/outside-1")
    assert r.status_code == 400 and "outside the archive's folder" in r.json()["error"]
    assert elsewhere.is_dir()
    # deleting removes the rows and the directory
    directory = archive.run(run)["dir"]
    assert client.delete(f"/api/runs/{run}").json() == {"deleted": run}
    assert run not in {r["id"] for r in client.get("/api/runs").json()["runs"]}
    assert not archive.individuals(run) and not archive.generations(run)
    from pathlib import Path

    assert not Path(directory).exists()
    assert client.delete(f"/api/runs/{run}").status_code == 400


def test_a_finished_run_is_not_resumed(setup):
    client, _ = setup
    r = client.post("/api/evolve", json={"model": {"library": "gray-scott"}, "population": 2,
                                         "generations": 1, "size": 16, "steps": 20})
    run = r.json()["run"]
    wait(client, run, ("choose",))
    client.post(f"/api/evolve/{run}/select", json={"indices": [1]}).raise_for_status()
    assert wait(client, run, ("done",))["state"] == "done"
    r = client.post(f"/api/runs/{run}/resume")
    assert r.status_code == 400 and "finished all 1 generations" in r.json()["error"]
