"""Atlas page with pattern families: the CLI's classifier, frames, legend counts, families.csv."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from fastapi.testclient import TestClient

from morphogen.domains.grid import Grid
from morphogen.models.library import get_model
from morphogen.patterns.classify import COLOURS
from morphogen.render.colour import parse_colour
from morphogen.runs.atlas import Axis, classify_atlas, compute_atlas, write_families
from morphogen.web.app import create_app
from tests.web_support import finished, poll_job

BODY = {"x": {"name": "k", "lo": 0.05, "hi": 0.065, "n": 3},
        "y": {"name": "F", "lo": 0.02, "hi": 0.04, "n": 2}, "tile": 16, "steps": 60,
        "init": "square", "families": True}


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(allowed_hosts=["testserver"])) as c:
        yield c


def _done(client, body):
    job = client.post("/api/atlas", json=body).json()["job"]
    status = poll_job(client, job, finished, timeout=60.0)
    assert status["status"] == "done", status
    return status["result"]


def _frame_colour(image, res, i, j):
    """The pixel in the top-left corner of tile (i, j) (row i from the top)."""
    cell = res["tile"] + res["pad"]
    return tuple(int(c) for c in image[res["pad"] + i * cell, res["pad"] + j * cell, :3])


@pytest.mark.slow
def test_families_are_the_cli_classifier_drawn_as_frames(client, tmp_path):
    res = _done(client, BODY)
    fam = res["families"]
    # the same atlas and classifier as `morphogen atlas --classify` (watch 4 x 15 for 60 steps)
    model = get_model("gray-scott")
    atlas = compute_atlas(model, Grid((16, 16)), Axis("k", np.linspace(0.05, 0.065, 3)),
                          Axis("F", np.linspace(0.02, 0.04, 2)), steps=60, dt=res["dt"],
                          init="square", seed=0, watch=(4, 15))
    labels, descriptors = classify_atlas(atlas, model.species_index(model.display_species))
    # rows from the top, as the mosaic: the largest F first
    assert fam["labels"] == labels[::-1].tolist()
    assert sum(fam["counts"].values()) == 6
    assert fam["counts"] == {f: int((labels == f).sum()) for f in fam["counts"]}
    assert fam["colours"] == {f: COLOURS[f] for f in fam["counts"]}
    csv = client.get(fam["csv"])
    assert csv.status_code == 200 and csv.headers["content-type"].startswith("text/csv")
    expected = write_families(tmp_path / "families.csv", atlas, labels, descriptors).read_text()
    assert csv.text == expected
    assert csv.text.splitlines()[0].startswith("k,F,family,")
    image = iio.imread(client.get(res["image"]).content)
    for i in range(2):
        for j in range(3):
            rgb = np.rint(255 * parse_colour(COLOURS[fam["labels"][i][j]])).astype(int)
            assert _frame_colour(image, res, i, j) == tuple(rgb)


def test_a_uniform_start_stays_uniform_and_is_named_so(client):
    """A uniform state of Gray-Scott (u = 1, v = 0) is a fixed point: every tile is 'uniform',
    framed grey, with one legend entry counting all six tiles."""
    res = _done(client, {**BODY, "init": "uniform"})
    fam = res["families"]
    assert fam["labels"] == [["uniform"] * 3] * 2
    assert fam["counts"] == {"uniform": 6} and fam["colours"] == {"uniform": "#9e9e9e"}
    image = iio.imread(client.get(res["image"]).content)
    assert _frame_colour(image, res, 1, 2) == (0x9E, 0x9E, 0x9E)


@pytest.mark.parametrize(("change", "fragment"), [
    ({"families": "yes"}, "families must be true or false"),
    ({"steps": 3}, "at least 4 steps"),
])
def test_bad_family_requests_are_one_line(client, change, fragment):
    r = client.post("/api/atlas", json={**BODY, **change})
    assert r.status_code == 400 and fragment in r.json()["error"]
    assert "\n" not in r.json()["error"]


def test_unstable_tiles_are_reported_and_hatched(client):
    """Gray-Scott at k = 0 ends in a checkerboard at dt = 1 (tests/runs/test_atlas_unstable.py):
    those tiles are not valid, the result carries the one-line report, and the mosaic hatches
    them (white stripes) while the sound tiles keep their colours."""
    from morphogen.web.batch import HATCH

    res = _done(client, {"x": {"name": "F", "lo": 0.01, "hi": 0.07, "n": 2},
                         "y": {"name": "k", "lo": 0.0, "hi": 0.05, "n": 2}, "tile": 24,
                         "steps": 1500, "dt": 1.0})
    assert res["valid"] == [[True, True], [False, False]]  # rows from the top: k = 0.05 first
    assert res["unstable"].startswith("2 of 4 tiles were numerically unstable at dt=1")
    image = iio.imread(client.get(res["image"]).content)[..., :3]
    period, width = HATCH
    cell = res["tile"] + res["pad"]
    stripes = np.add.outer(np.arange(24), np.arange(24)) % period < width
    for i in range(2):
        for j in range(2):
            top, left = res["pad"] + i * cell, res["pad"] + j * cell
            tile = image[top:top + 24, left:left + 24]
            white = (tile == 255).all(axis=-1)
            assert white[stripes].all() == (not res["valid"][i][j]), (i, j)
