"""The Runs page's view of a MAP-Elites run: its elite map, coverage plot, and every elite with
its family, a run file and the parameters that open it in Explore."""

from __future__ import annotations

import json

import pytest
from fastapi.testclient import TestClient

from morphogen.web.app import create_app


@pytest.mark.slow
def test_runs_page_lists_the_elites_of_a_map_elites_run(tmp_path, quality_diversity_run):

    archive, out = tmp_path / "index.sqlite", tmp_path / "run"
    quality_diversity_run(archive, out, 2, 3)
    index = json.loads((out / "elites" / "index.json").read_text())
    with TestClient(create_app(archive=archive, allowed_hosts=["testserver"])) as client:
        run = client.get("/api/runs").json()["runs"][0]["id"]
        detail = client.get(f"/api/runs/{run}").json()
        me = detail["map_elites"]
        assert me["cells"] == 64 and me["grid"]["descriptors"] == ["spot_index", "coherence"]
        assert [e["cell"] for e in me["elites"]] == [e["cell"] for e in index["elites"]]
        for shown, stored in zip(me["elites"], index["elites"], strict=True):
            assert shown["family"] == stored["family"]
            assert shown["fitness"] == pytest.approx(stored["fitness"])
            assert [shown["params"]["F"], shown["params"]["k"]] == stored["genome"]
        for url in (me["map"], me["qd_plot"], me["elites"][0]["image"]):
            assert client.get(url).content[:4] == b"\x89PNG"
        replay = client.get(me["elites"][0]["config"]).json()
        assert replay["config"]["params"]["F"] == me["elites"][0]["params"]["F"]
        assert replay["elite"]["cell"] == me["elites"][0]["cell"]
