"""Mesh page case studies: flower pipelines run through the pipeline API, with progress and
cancel, from an examples folder the test makes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from morphogen.domains.ply import load_mesh, ply_fields
from morphogen.flowers.pipeline import load_pipeline, run_pipeline
from morphogen.web.app import create_app
from morphogen.web.case_study_routes import overall
from tests.web_support import TINY_PETAL, finished, poll_job


@pytest.fixture(scope="module")
def examples(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("examples")
    (root / "flowers").mkdir()
    (root / "flowers" / "tiny.toml").write_text(TINY_PETAL.replace("STEPS", "500"))
    (root / "flowers" / "endless.toml").write_text(
        TINY_PETAL.replace("STEPS", "1000000").replace("§4.2", "§4.9"))
    (root / "flowers" / "broken.toml").write_text(
        TINY_PETAL.replace("STEPS", "500").replace("§4.2", "§4.10")
        .replace('kind = "fields"', 'kind = "nope"'))
    (root / "flowers" / "model.toml").write_text('species = ["m"]\n')  # not a pipeline
    return root


@pytest.fixture(scope="module")
def client(examples):
    with TestClient(create_app(allowed_hosts=["testserver"], examples=examples)) as c:
        yield c


def test_the_menu_lists_pipelines_with_their_sections(client):
    cases = client.get("/api/mesh/cases").json()["cases"]
    assert cases == [
        {"name": "tiny", "section": "4.2", "caption": "tiny (Ringham §4.2)"},
        {"name": "endless", "section": "4.9", "caption": "endless (Ringham §4.9)"},
        {"name": "broken", "section": "4.10", "caption": "broken (Ringham §4.10)"},
    ]


def test_the_shipped_flowers_are_offered_by_default():
    with TestClient(create_app(allowed_hosts=["testserver"])) as c:
        names = [x["name"] for x in c.get("/api/mesh/cases").json()["cases"]]
    assert {"platycodon", "primula", "dianthus", "mimulus", "kohleria"} <= set(names)
    assert "dianthus-diffusion" not in names


def test_a_case_study_is_the_cli_pipeline_shown_in_the_viewer(client, examples, tmp_path):
    job = client.post("/api/mesh/cases", json={"name": "tiny"}).json()["job"]
    status = poll_job(client, job, finished)
    assert status["status"] == "done", status
    res = status["result"]
    assert res["stage"] == "02-grow" and res["caption"] == "tiny (Ringham §4.2)"
    # the files `morphogen pipeline run` writes: final.ply, the last stage's picture
    run_pipeline(load_pipeline(examples / "flowers" / "tiny.toml"), tmp_path / "cli")
    final = tmp_path / "cli" / "final.ply"
    assert client.get(res["ply"]).content == final.read_bytes()
    png = client.get(res["png"]).content
    assert png == (tmp_path / "cli" / "02-grow" / "out.png").read_bytes()
    mesh = load_mesh(final)
    fields = ply_fields(final)
    assert {"m", "u", "v"} <= set(fields)  # every field of every stage
    rgb = np.rint(255 * np.stack([fields[c] for c in ("red", "green", "blue")], 1))
    assert res["colours"] == rgb.astype(int).ravel().tolist()
    assert res["n_vertices"] == mesh.n_vertices and res["faces"] == mesh.faces.ravel().tolist()
    np.testing.assert_allclose(np.reshape(res["vertices"], (-1, 3)), mesh.vertices, atol=1e-4)
    assert len(set(res["colours"])) > 2  # a pattern, not one colour


def test_cancel_stops_a_long_case_study_between_chunks(client):
    job = client.post("/api/mesh/cases", json={"name": "endless"}).json()["job"]
    running = poll_job(client, job, lambda s: s["progress"] > 0 or s["status"] not in
                    ("queued", "running"))
    assert running["status"] == "running", running
    # stage 2 of 2 (the simulation) carries all of the progress, a million steps of it, so
    # however late the poll sees it, it is far from done
    assert "stage 2 of 2 (grow)" in running["message"] and 0 < running["progress"] < 0.25
    assert running["eta_s"] is not None and running["eta_s"] > 0
    client.delete(f"/api/jobs/{job}")
    stopped = poll_job(client, job, lambda s: s["status"] != "running", timeout=30.0)
    assert stopped["status"] == "cancelled" and stopped["progress"] < 0.5


def test_bad_case_studies_are_one_line_errors(client):
    r = client.post("/api/mesh/cases", json={"name": "rose"})
    assert r.status_code == 400
    assert r.json()["error"].startswith("unknown case study 'rose'; choose from tiny, endless")
    r = client.post("/api/mesh/cases", json={"name": "broken"})
    assert r.status_code == 400 and "stage 1: kind must be one of" in r.json()["error"]


def test_overall_share_counts_the_simulations():
    kinds = ["positional", "fields", "simulate"]
    assert overall(kinds, 2, 1.0) == 0.0  # meshing and fields: no share of the time
    assert overall(kinds, 3, 0.5) == 0.5
    two = ["simulate", "points", "simulate"]
    assert overall(two, 1, 0.5) == 0.25 and overall(two, 3, 0.0) == 0.5
    assert overall(two, 3, 1.0) == 1.0
    assert overall(["fields", "veins"], 2, 0.5) == 0.75  # nothing simulates: equal shares


def test_the_pipeline_reports_stages_and_chunks(examples, tmp_path):
    calls = []
    run_pipeline(load_pipeline(examples / "flowers" / "tiny.toml"), tmp_path / "out",
                 pictures=False, report=lambda k, n, f: calls.append((k, n, f)))
    # stage 1 starts and ends; stage 2 also after each compiled chunk of 250 steps
    assert calls == [(1, 2, 0.0), (1, 2, 1.0), (2, 2, 0.0), (2, 2, 0.5), (2, 2, 1.0),
                     (2, 2, 1.0)]
