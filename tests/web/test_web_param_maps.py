"""Explore: a PNG's grey levels as a parameter's spatial field (lo at black, hi at white)."""

from __future__ import annotations

import base64

import imageio.v3 as iio
import numpy as np
import pytest
from fastapi.testclient import TestClient

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.library import get_model
from morphogen.solvers.step import max_stable_dt
from morphogen.web.app import create_app
from morphogen.web.image_input import image_field


@pytest.fixture(scope="module")
def client():
    with TestClient(create_app(allowed_hosts=["testserver"])) as c:
        yield c


def png64(grey: np.ndarray) -> str:
    """A uint8 grey PNG as the page sends it (a data URL)."""
    data = iio.imwrite("<bytes>", np.asarray(grey, np.uint8), extension=".png")
    return "data:image/png;base64," + base64.b64encode(data).decode()


def session(client, **body):
    r = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16,
                                       "init": "square", **body})
    assert r.status_code == 200, r.text
    return r.json()["id"]


def test_resampling_by_hand():
    """A 2 x 2 image, black left and white right, on 4 columns: cell centres at image
    columns -0.25, 0.25, 0.75, 1.25; nearest takes pixels 0, 0, 1, 1, bilinear the grey levels
    0 (edge held), 0.25, 0.75, 1; mapped to 2 + 4 g."""
    grey = np.array([[0.0, 1.0], [0.0, 1.0]])
    near = image_field(grey, (2, 4), 2.0, 6.0, "nearest")
    bil = image_field(grey, (2, 4), 2.0, 6.0, "bilinear")
    np.testing.assert_allclose(near, [[2, 2, 6, 6]] * 2)
    np.testing.assert_allclose(bil, [[2, 3, 5, 6]] * 2, atol=1e-6)
    # a white pixel in the middle of 3 x 3 black, on 6 x 6: the bilinear field peaks at the four
    # cells nearest the centre (0.75 of the way to it on both axes: 0.75^2 of white)
    dot = np.zeros((3, 3))
    dot[1, 1] = 1.0
    f = image_field(dot, (6, 6), 0.0, 1.0, "bilinear")
    np.testing.assert_allclose(f[2:4, 2:4], 0.75 ** 2, atol=1e-6)
    assert f[0, 0] == 0.0


@pytest.mark.slow
def test_a_mapped_feed_runs_as_simulate_with_that_field(client):
    """F from an image (left half black, right half white: 0.02 and 0.06, nearest) gives the
    same state as simulate() with that F array; the slider's number is kept for afterwards."""
    sid = session(client, params={"F": 0.037})
    grey = np.zeros((4, 4), np.uint8)
    grey[:, 2:] = 255
    r = client.post(f"/api/live/{sid}/map", json={"param": "F", "png": png64(grey), "lo": 0.02,
                                                 "hi": 0.06, "resample": "nearest"})
    assert r.status_code == 200, r.text
    state = r.json()
    assert state["maps"] == {"F": {"lo": 0.02, "hi": 0.06, "resample": "nearest"}}
    assert state["params"]["F"] == 0.037
    client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 8}).raise_for_status()
    for _ in range(2):
        assert client.get(f"/api/live/{sid}/frame").status_code == 200
    model, grid = get_model("gray-scott"), Grid((16, 16))
    F = np.where(np.arange(16) < 8, 0.02, 0.06)[None, :] * np.ones((16, 1))
    params = {**model.parameters({}), "F": F.astype(np.float32)}
    u0 = make_initial("square", model, grid, model.parameters({"F": 0.037}), seed=0)
    ref = simulate(model, grid, u0, params, steps=16, dt=state["dt"]).state
    live = client.app.state.sessions.get(sid).state()
    np.testing.assert_allclose(live, ref, rtol=1e-5, atol=1e-6)
    # a run file cannot hold the image: refused in one line while the map is set
    r = client.get(f"/api/live/{sid}/config")
    assert r.status_code == 400 and "map from an image" in r.json()["error"]
    cleared = client.delete(f"/api/live/{sid}/map/F").json()
    assert cleared["maps"] == {} and cleared["params"]["F"] == 0.037
    assert client.get(f"/api/live/{sid}/config").status_code == 200


def test_a_diffusion_map_sets_dt_by_its_largest_value(client):
    """The explicit limit follows the largest coefficient of the field (Du from 0.1 at black
    to 4 at white): the same limit as Du = 4 everywhere, and dt is lowered to it (the run
    policy's step: the model's dt = 1 is above it)."""
    sid = session(client)
    grey = np.tile(np.linspace(0, 255, 8).astype(np.uint8), (8, 1))
    r = client.post(f"/api/live/{sid}/map",
                    json={"param": "Du", "png": png64(grey), "lo": 0.1, "hi": 4.0})
    state = r.json()
    model = get_model("gray-scott")
    expect = max_stable_dt(model, Grid((16, 16)), model.parameters({"Du": 4.0}))
    assert state["dt_max"] == pytest.approx(expect, rel=1e-5)
    assert state["dt"] == pytest.approx(expect, rel=1e-5)
    assert any("dt lowered" in n for n in state["notices"])
    assert state["maps"]["Du"]["resample"] == "bilinear"  # the default


def test_a_scheme_that_needs_constant_diffusion_refuses_a_diffusion_map(client):
    """ETDRK4's exact diffusion needs one coefficient per species: tracing a step with a
    diffusion map raises the scheme's own one-line error, and the map is not kept."""
    sid = session(client, scheme="etdrk4")
    r = client.post(f"/api/live/{sid}/map", json={"param": "Du", "png": png64(np.eye(4) * 255),
                                                 "lo": 0.1, "hi": 0.3})
    assert r.status_code == 400 and "constant isotropic diffusion" in r.json()["error"]
    assert client.get(f"/api/live/{sid}").json()["maps"] == {}


@pytest.mark.parametrize(("change", "fragment"), [
    ({"png": "not base64!"}, "not valid base64"),
    ({"png": base64.b64encode(b"GIF89a....").decode()}, "only PNG"),
    ({"png": base64.b64encode(b"\x89PNG\r\n\x1a\n broken").decode()}, "could not be read"),
    ({"lo": 0.05, "hi": 0.05}, "must be above its low value"),
    ({"hi": "lots"}, "high value must be a number"),
    ({"param": "Q"}, "unknown parameter 'Q'"),
    ({"resample": "cubic"}, "resampling must be one of nearest, bilinear"),
])
def test_bad_maps_are_one_line_errors(client, change, fragment):
    sid = session(client)
    body = {"param": "F", "png": png64(np.zeros((2, 2))), "lo": 0.02, "hi": 0.06, **change}
    r = client.post(f"/api/live/{sid}/map", json=body)
    assert r.status_code == 400, r.text
    assert fragment in r.json()["error"] and "\n" not in r.json()["error"]
    assert client.get(f"/api/live/{sid}").json()["maps"] == {}
