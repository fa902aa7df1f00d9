"""Evolve and Runs pages' API: every library model evolves by favourites into the shared archive."""

from __future__ import annotations

import time

import numpy as np
import pytest
from fastapi.testclient import TestClient

from morphogen.models.library import LIBRARY
from morphogen.search.archive import Archive
from morphogen.search.fitness import HUMAN_LAMBDA
from morphogen.web.app import create_app


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as c:
        yield c, archive


def wait(client, run, states, timeout=120.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        status = client.get(f"/api/evolve/{run}").json()
        if status["state"] in states or status["state"] == "error":
            return status
        time.sleep(0.05)
    raise AssertionError(f"run {run} never reached {states}: {status}")


@pytest.mark.parametrize("name", sorted(LIBRARY))
@pytest.mark.slow
def test_every_library_model_evolves_by_favourites(setup, name):
    client, archive = setup
    defaults = client.get(f"/api/evolve/setup/{name}").json()
    assert defaults["genes"], name
    r = client.post("/api/evolve", json={
        "model": {"library": name}, "population": 2, "generations": 1, "size": 16,
        "steps": 20, "fitness": "user",
    })
    assert r.status_code == 200, r.text
    run = r.json()["run"]
    status = wait(client, run, ("choose",))
    assert status["state"] == "choose", status
    assert len(status["images"]) == 2
    assert client.get(status["images"][1]).headers["content-type"] == "image/png"
    shown = status["params"]  # the gene values each picture shows on hover
    assert client.post(f"/api/evolve/{run}/select", json={"indices": [5]}).status_code == 400
    client.post(f"/api/evolve/{run}/select", json={"indices": [1]}).raise_for_status()
    status = wait(client, run, ("done",))
    assert status["state"] == "done", status
    # Skaggs eq. 3.9: the chosen share lambda of the fitness, the others 1 - lambda
    rows = Archive(archive, create=False).individuals(run, 1)
    genes = [g["name"] for g in defaults["genes"]]
    assert [list(p) for p in shown] == [genes, genes]
    np.testing.assert_allclose([[p[g] for g in genes] for p in shown],
                               [row["genome"] for row in rows], rtol=1e-6)
    fitness = [row["fitness"] for row in rows]
    lam = HUMAN_LAMBDA
    assert fitness == pytest.approx([1 - lam, lam], rel=1e-6)
    listed = {r["id"]: r for r in client.get("/api/runs").json()["runs"]}
    assert listed[run]["status"] == "done" and listed[run]["model"] == name


@pytest.mark.slow
def test_two_generations_breed_from_the_favourites_and_runs_page_browses_them(setup, tmp_path):
    client, _ = setup
    r = client.post("/api/evolve", json={"model": {"library": "gray-scott"}, "population": 4,
                                         "generations": 2, "size": 16, "steps": 30})
    run = r.json()["run"]
    assert wait(client, run, ("choose",))["gen"] == 1
    client.post(f"/api/evolve/{run}/select", json={"indices": [1, 3]}).raise_for_status()
    status = wait(client, run, ("choose",))
    assert status["gen"] == 2
    client.post(f"/api/evolve/{run}/select", json={"indices": [0]}).raise_for_status()
    assert wait(client, run, ("done",))["state"] == "done"
    detail = client.get(f"/api/runs/{run}").json()
    assert [g["gen"] for g in detail["history"]] == [1, 2]
    assert client.get(detail["history"][1]["sheet"]).content[:4] == b"\x89PNG"
    assert detail["fitness_plot"] is None  # favourites' selection weights are not a fitness
    best = detail["best"][0]
    assert best["fitness"] == pytest.approx(HUMAN_LAMBDA)  # the single favourite of gen 2
    assert set(best["params"]) == {"F", "k"}
    assert detail["explore"]["model"] == {"library": "gray-scott"}
    gen2 = client.get(f"/api/runs/{run}/generations/2").json()["individuals"]
    assert len(gen2) == 4
    # an individual opens in Explore with its parameters, and its run file runs in the CLI
    live = client.post("/api/live", json={**detail["explore"], "params": best["params"]})
    assert live.status_code == 200, live.text
    path = tmp_path / "ind.json"
    path.write_bytes(client.get(best["config"]).content)
    from morphogen.cli.main import main as cli

    assert cli(["simulate", "--config", str(path), "--out", str(tmp_path / "o")]) == 0
    # files outside the run directory are never served
    for rel in ("../index.sqlite", "../../etc/passwd", "config.txt"):
        assert client.get(f"/api/runs/{run}/files/{rel}").status_code in (400, 404)


@pytest.mark.slow
def test_automatic_fitness_reports_progress_and_stop_works(setup):
    client, _ = setup
    r = client.post("/api/evolve", json={"model": {"library": "gray-scott"}, "population": 3,
                                         "generations": 50, "size": 16, "steps": 500,
                                         "fitness": "dirichlet"})
    run = r.json()["run"]
    seen = set()
    end = time.monotonic() + 60
    while time.monotonic() < end:
        s = client.get(f"/api/evolve/{run}").json()
        seen.add(s["gen"])
        if s["gen"] >= 2:
            break
        time.sleep(0.05)
    client.post(f"/api/evolve/{run}/stop").raise_for_status()
    s = wait(client, run, ("stopped", "done"))
    assert s["state"] == "stopped" and {1, 2} <= seen
    assert client.get("/api/evolve/unknown").status_code == 400


def test_map_elites_refuses_favourites_in_one_line(setup):
    client, _ = setup
    for strategy in ("map-elites", "cvt-map-elites"):
        r = client.post("/api/evolve", json={"model": {"library": "gray-scott"}, "population": 4,
                                             "generations": 2, "size": 16, "steps": 20,
                                             "fitness": "user", "strategy": strategy})
        assert r.status_code == 400
        error = r.json()["error"]
        assert "\n" not in error and "MAP-Elites" in error and "automatic fitness" in error


@pytest.mark.slow
def test_status_carries_the_settings_and_a_stopped_choice_keeps_its_pictures(setup):
    """A reloaded page restores the run's own settings from its status; a run stopped while
    its favourites were being chosen still shows that generation's pictures."""
    client, _ = setup
    genes = [{"name": "F", "low": 0.02, "high": 0.03, "sigma": 0.001}]
    body = {"model": {"library": "gray-scott"}, "population": 3, "generations": 4, "size": 16,
            "steps": 20, "dt": 0.5, "seed": 5, "init": "noise", "fitness": "user",
            "strategy": "ga", "genes": genes}
    run = client.post("/api/evolve", json=body).json()["run"]
    status = wait(client, run, ("choose",))
    settings = status["settings"]
    assert settings == {"kind": "params", "model": {"library": "gray-scott"}, "strategy": "ga",
                        "fitness": "user", "population": 3, "generations": 4, "size": 16,
                        "steps": 20, "dt": 0.5, "seed": 5, "init": "noise", "genes": genes}
    # what opens an individual in Explore (the parameters that are not genes: none set here)
    assert status["explore"] == {"model": {"library": "gray-scott"}, "init": "noise", "seed": 5,
                                 "size": 16, "params": {}}
    client.post(f"/api/evolve/{run}/stop").raise_for_status()
    stopped = wait(client, run, ("stopped",))
    assert stopped["state"] == "stopped" and stopped["gen"] == 1
    assert stopped["images"] == status["images"] and len(stopped["params"]) == 3
    assert client.get(stopped["images"][2]).content[:4] == b"\x89PNG"
    assert stopped["settings"] == settings


def test_network_runs_list_only_valid_networks_and_label_uniform_fields(tmp_path):
    """Invalid networks (left the bounds or blew up) are counted, never listed among the
    fittest; a fittest network whose activator ends flat is marked uniform."""
    from morphogen.search.fitness import INVALID
    from morphogen.web.limits import Limits
    from morphogen.web.network_runs import start_network_run

    archive = Archive(tmp_path / "index.sqlite")
    run = start_network_run({"mode": "rates", "population": 4, "size": 8, "generations": 1},
                            Limits(), archive)
    s = run.settings
    pop = type(s.template)(*(np.stack([np.asarray(x)] * 4) for x in s.template))
    n = len(s.spec.species)
    final = np.zeros((4, n, 8, 8), np.float32)
    final[1] = 0.7  # uniform
    final[2] = np.random.default_rng(0).uniform(0, 2, (n, 8, 8))  # patterned
    run._final = final
    run._show(1, pop, np.array([INVALID, 0.0, 0.5, INVALID], np.float32))
    status = run.to_json()
    assert [b["idx"] for b in status["best"]] == [2, 1] and status["invalid"] == 2
    assert [b["uniform"] for b in status["best"]] == [False, True]
    assert all(b["fitness"] is not None and b["fitness"] > INVALID for b in status["best"])
    assert status["settings"] == {"kind": "rates", "population": 4, "generations": 1, "seed": 0,
                                  "size": 8, "dt": 0.1, "t_start": 100.0, "interval": 25.0,
                                  "rounds": 3}
    # a generation with no valid network lists none and counts them all
    run._show(2, pop, np.full(4, INVALID, np.float32))
    assert run.to_json()["best"] == [] and run.to_json()["invalid"] == 4


def test_a_run_waiting_for_favourites_comes_back_after_a_server_restart(tmp_path):
    """The server stops while a favourites run waits for a choice; a new server on the same
    archive takes the run up again when its page asks: the same generation, the same
    individuals, waiting for the choice, and the choice breeds the next generation."""
    archive = tmp_path / "index.sqlite"
    body = {"model": {"library": "gray-scott"}, "population": 3, "generations": 2,
            "size": 16, "steps": 20, "fitness": "user", "seed": 4}
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as first:
        run = first.post("/api/evolve", json=body).json()["run"]
        before = wait(first, run, ("choose",))
        assert before["gen"] == 1
    # a new server: nothing in memory, the archive says "running"
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as second:
        after = wait(second, run, ("choose",))
        assert after["gen"] == 1 and after["images"] == before["images"]
        np.testing.assert_allclose([list(p.values()) for p in after["params"]],
                                   [list(p.values()) for p in before["params"]], rtol=1e-6)
        second.post(f"/api/evolve/{run}/select", json={"indices": [2]}).raise_for_status()
        assert wait(second, run, ("choose",))["gen"] == 2
        # a run the archive does not know, or one not waiting for favourites, is not taken up
        assert second.get("/api/evolve/nosuchrun").status_code == 400
