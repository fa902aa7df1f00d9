"""The Evolve page's reaction-network mode through its API: a small run lands in the archive, shows
its fittest networks (drawing and activator pattern) and opens one in Explore; bad settings are
one-line errors."""

from __future__ import annotations

import io
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image

from morphogen.search.archive import Archive
from morphogen.search.networks.evolve import load_state
from morphogen.web.app import create_app
from morphogen.web.network_runs import SHOWN

SMALL = {"mode": "network", "population": 5, "generations": 1, "size": 8, "dt": 0.5,
         "t_start": 5, "interval": 5, "rounds": 2, "seed": 1}
"""A run of a few seconds; with this seed four of its five random networks are invalid and one
is valid, its activator ending uniform."""


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as c:
        c.archive = archive
        yield c


def _png(client, url):
    r = client.get(url)
    assert r.status_code == 200 and r.headers["content-type"] == "image/png", url
    return Image.open(io.BytesIO(r.content))


@pytest.mark.slow
def test_network_run_shows_its_fittest_networks_and_opens_one_in_explore(client):
    r = client.post("/api/evolve/networks", json=SMALL)
    assert r.status_code == 200, r.text
    run = r.json()["run"]
    assert r.json()["kind"] == "networks" and r.json()["total"] == 1
    end = time.monotonic() + 120
    while (status := client.get(f"/api/evolve/{run}").json())["state"] == "running":
        assert time.monotonic() < end, status
        time.sleep(0.1)
    assert status["state"] == "done", status
    assert status["gen"] == 1 and status["progress"] == 1.0

    # the shown individuals are the last generation's fittest valid ones, as archived, best
    # first; the invalid ones (fitness -1) are counted, not shown
    archive = Archive(client.archive, create=False)
    rows = archive.individuals(run, 1)
    assert len(rows) == 5
    valid = sorted((row["fitness"] for row in rows if row["fitness"] > -1.0), reverse=True)
    fitness = valid[:SHOWN]
    best = status["best"]
    assert len(best) == min(SHOWN, len(valid)) >= 1 and status["invalid"] == 5 - len(valid)
    shown = [b["fitness"] for b in best]
    np.testing.assert_allclose(shown, fitness, atol=1e-4)
    _, history, done, _ = load_state(Path(archive.run(run)["dir"]) / "state.npz")
    assert done == 1
    np.testing.assert_allclose(history[-1][[b["idx"] for b in best]], shown, atol=1e-4)

    top = best[0]
    assert top["uniform"] is True  # labelled on the page: a flat picture is no pattern
    assert _png(client, top["pattern"]).size == (128, 128)  # 8 cells, 16 pixels each
    assert _png(client, top["network"]).size[0] > 300
    assert top["reactions"] and all("k =" in line for line in top["reactions"])
    # Explore runs the exported network: the pasted model parses and a live session starts
    explore = top["explore"]
    assert explore["init"] == "noise" and explore["size"] == 16  # Explore's smallest grid
    model = client.post("/api/models/parse", json=explore["model"])
    assert model.status_code == 200, model.text
    assert [s["name"] if isinstance(s, dict) else s for s in model.json()["species"]] == \
        ["A", "B", "C"]
    live = client.post("/api/live", json=explore)
    assert live.status_code == 200, live.text
    client.delete(f"/api/live/{live.json()['id']}")
    # the run is a `morphogen networks` run: favourites are refused, the Runs list has it
    assert client.post(f"/api/evolve/{run}/select", json={"indices": [0]}).status_code == 400
    assert run in {r["id"] for r in client.get("/api/runs").json()["runs"]}
    # the Runs page's detail: one row per generation, the fittest networks as replayable run files
    detail = client.get(f"/api/runs/{run}")
    assert detail.status_code == 200, detail.text
    detail = detail.json()
    assert detail["kind"] == "networks" and detail["species"] == ["A", "B", "C"]
    assert [g["gen"] for g in detail["history"]] == [1]
    assert detail["history"][0]["best"] == pytest.approx(max(fitness), abs=1e-4)
    assert detail["best"][0]["fitness"] == pytest.approx(max(fitness), abs=1e-4)
    source = detail["best"][0]["run_file"]["config"]["model_source"]
    assert client.post("/api/models/parse", json={"equations": source}).status_code == 200
    # parameter-search routes name the command that continues a network run
    for r in (client.get(f"/api/runs/{run}/generations/1"),
              client.get(f"/api/runs/{run}/individuals/1/0/config")):
        assert r.status_code == 400 and "morphogen networks --out" in r.json()["error"]


@pytest.mark.parametrize("change, message", [
    ({"mode": "topology"}, "mode"),
    ({"population": 1000}, "population"),
    ({"size": 128, "t_start": 1e5}, "cell-steps"),
    ({"rounds": 0}, "rounds"),
    ({"dt": "fast"}, "dt"),
])
def test_bad_network_settings_are_one_line_errors(client, change, message):
    runs = len(Archive(client.archive).runs())
    r = client.post("/api/evolve/networks", json={**SMALL, **change})
    assert r.status_code == 400, r.text
    error = r.json()["error"]
    assert message in error and "\n" not in error
    assert len(Archive(client.archive).runs()) == runs  # nothing recorded


def test_network_defaults_fit_the_server_budget(client):
    d = client.get("/api/evolve/networks/defaults").json()
    steps = d["t_start"] / d["dt"] + (d["rounds"] - 1) * d["interval"] / d["dt"]
    assert d["population"] * d["size"] ** 2 * steps <= 3.0e9
    assert d["mode"] == "network" and d["generations"] <= d["max_generations"]
