"""Explore's tools through the API: scheme choice and rectangular grids, the brush's undo, the
value readout, a fixed colour range, and recording to GIF/MP4."""

from __future__ import annotations

import io

import imageio.v3 as iio
import numpy as np
import pytest

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.library import get_model
from morphogen.solvers.step import max_stable_dt
from morphogen.web.recording import colour_table
from tests.web.test_web import client, frame, new_session, sim_of  # noqa: F401  (fixture)


@pytest.mark.slow
def test_imex_on_a_rectangle_equals_simulate(client):  # noqa: F811
    """A 48 x 32 grid under IMEX: frames are 48 wide and 32 high, and 2 frames of 8 steps equal
    simulate() with the same scheme for 16 steps; dt's limit is the IMEX one."""
    state = new_session(client, model={"library": "schnakenberg"}, size=48, height=32,
                        scheme="imex", init="noise", seed=3)
    sid = state["id"]
    assert (state["size"], state["height"], state["scheme"]) == (48, 32, "imex")
    client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 8}).raise_for_status()
    for _ in range(2):
        f = frame(client, sid)
    assert (f["w"], f["h"], f["steps"]) == (48, 32, 16)
    model, grid = get_model("schnakenberg"), Grid((32, 48))
    params = model.parameters()
    assert state["dt_max"] == pytest.approx(max_stable_dt(model, grid, params, "imex"))
    assert state["dt_max"] > max_stable_dt(model, grid, params, "euler")
    u0 = make_initial("noise", model, grid, params, seed=3)
    ref = simulate(model, grid, u0, params, steps=16, dt=state["dt"], scheme="imex").state
    np.testing.assert_allclose(sim_of(client, sid).state(), ref, rtol=1e-4, atol=1e-5)
    config = client.get(f"/api/live/{sid}/config").json()["config"]
    assert config["size"] == [32, 48] and config["scheme"] == "imex"


def test_unsupported_scheme_is_refused_in_one_line(client):  # noqa: F811
    r = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 32,
                                       "scheme": "adaptive"})
    assert r.status_code == 400 and "scheme must be one of" in r.json()["error"]
    assert "\n" not in r.json()["error"]


def test_a_brush_disc_stays_round_on_a_rectangle_and_strokes_undo(client):  # noqa: F811
    sid = new_session(client, init="uniform", size=64, height=32)["id"]
    u_start = sim_of(client, sid).state()
    paint = {"radius": 0.1, "mode": "excite", "stroke": True}
    r = client.post(f"/api/live/{sid}/paint", json={"points": [[0.25, 0.5]], **paint})
    assert r.json()["undo"] == 1
    after_a = sim_of(client, sid).state()
    painted = np.isclose(after_a[1], 0.25)
    # radius 0.1 of the width = 6.4 cells on both axes: pi r^2 cells, 2r cells high
    assert abs(painted.sum() - np.pi * 6.4**2) < 0.1 * np.pi * 6.4**2
    rows = np.nonzero(painted.any(axis=1))[0]
    assert abs(len(rows) - 2 * 6.4) <= 2
    # a second stroke of two requests: the second continues the stroke
    client.post(f"/api/live/{sid}/paint", json={"points": [[0.75, 0.5]], **paint})
    client.post(f"/api/live/{sid}/paint",
                json={"points": [[0.8, 0.5]], "radius": 0.1}).raise_for_status()
    assert client.post(f"/api/live/{sid}/undo").json()["undo"] == 1
    np.testing.assert_array_equal(sim_of(client, sid).state(), after_a)
    assert client.post(f"/api/live/{sid}/undo").json()["undo"] == 0
    np.testing.assert_array_equal(sim_of(client, sid).state(), u_start)
    r = client.post(f"/api/live/{sid}/undo")
    assert r.status_code == 400 and "nothing to undo" in r.json()["error"]
    # a brush on one species: v set to 0.7 in the disc, u untouched everywhere; erase on u only
    one = {"radius": 0.1, "stroke": True, "species": "v"}
    client.post(f"/api/live/{sid}/paint", json={"points": [[0.5, 0.5]], "mode": "value",
                                                "value": 0.7, **one}).raise_for_status()
    after_v = sim_of(client, sid).state()
    disc = np.isclose(after_v[1], 0.7)
    assert abs(disc.sum() - np.pi * 6.4**2) < 0.1 * np.pi * 6.4**2
    np.testing.assert_array_equal(after_v[0], u_start[0])
    client.post(f"/api/live/{sid}/paint", json={"points": [[0.5, 0.5]], "mode": "erase",
                                                **{**one, "species": "u"}}).raise_for_status()
    np.testing.assert_array_equal(sim_of(client, sid).state()[1], after_v[1])
    r = client.post(f"/api/live/{sid}/paint", json={"points": [[0.5, 0.5]], "mode": "value"})
    assert r.status_code == 400 and "needs a species" in r.json()["error"]


def test_probe_reads_every_species_in_the_cell_under_the_cursor(client):  # noqa: F811
    sid = new_session(client, size=32, height=16, init="noise")["id"]
    frame(client, sid)
    data = client.get(f"/api/live/{sid}/probe", params={"x": 0.5, "y": 0.9}).json()
    u = sim_of(client, sid).state()
    assert (data["row"], data["col"]) == (14, 16)  # floor(0.9 * 16), floor(0.5 * 32)
    assert data["values"] == {"u": pytest.approx(float(u[0, 14, 16]), rel=1e-6),
                              "v": pytest.approx(float(u[1, 14, 16]), rel=1e-6)}
    r = client.get(f"/api/live/{sid}/probe", params={"x": 2, "y": 0})
    assert r.status_code == 400


def test_a_fixed_colour_range_quantises_on_it(client):  # noqa: F811
    sid = new_session(client, init="noise")["id"]
    r = client.post(f"/api/live/{sid}/view", json={"range": [0.0, 0.5]})
    assert r.json()["range"] == [0.0, 0.5]
    f = frame(client, sid)
    assert (f["lo"], f["hi"]) == (0.0, 0.5)
    v = sim_of(client, sid).state()[1]
    expect = np.clip(np.round(v * np.float32(255 / 0.5)), 0, 255).astype(int)
    assert np.abs(f["pixels"].astype(int) - expect).max() <= 1
    assert client.post(f"/api/live/{sid}/view", json={"range": [1, 1]}).status_code == 400
    assert client.post(f"/api/live/{sid}/view", json={"range": "auto"}).json()["range"] == "auto"


def test_recording_downloads_the_frames_shown_as_gif_and_mp4(client):  # noqa: F811
    sid = new_session(client, model={"library": "schnakenberg"}, size=32, height=16,
                      init="noise")["id"]
    r = client.get(f"/api/live/{sid}/recording")
    assert r.status_code == 400 and "nothing recorded" in r.json()["error"]
    frame(client, sid)  # not recorded
    assert client.post(f"/api/live/{sid}/record", json={"on": True}).json()["on"]
    shown = [frame(client, sid)["pixels"] for _ in range(3)]
    assert client.post(f"/api/live/{sid}/record", json={"on": False}).json()["frames"] == 3
    assert (shown[0] != shown[1]).any() and (shown[1] != shown[2]).any()
    frame(client, sid)  # not recorded either
    gif = client.get(f"/api/live/{sid}/recording", params={"format": "gif"})
    assert gif.headers["content-type"] == "image/gif"
    movie = iio.imread(io.BytesIO(gif.content), extension=".gif", index=None)
    assert movie.shape[:3] == (3, 16, 32)
    lut = colour_table(sim_of(client, sid).cmap)
    # GIF palettes are exact for at most 256 colours of one frame
    np.testing.assert_array_equal(movie[2][..., :3], lut[shown[2]])
    mp4 = client.get(f"/api/live/{sid}/recording", params={"format": "mp4"})
    assert mp4.headers["content-type"] == "video/mp4" and mp4.content[4:8] == b"ftyp"
    bad = client.get(f"/api/live/{sid}/recording", params={"format": "avi"})
    assert bad.status_code == 400 and "gif, mp4" in bad.json()["error"]
    # half the size (every other cell) and another frame rate: a GIF of 16 x 8 frames,
    # 50 ms -> 100 ms each; out of range is one line
    half = client.get(f"/api/live/{sid}/recording",
                      params={"format": "gif", "every": 2, "fps": 10})
    small = iio.imread(io.BytesIO(half.content), extension=".gif", index=None)
    assert small.shape[:3] == (3, 8, 16) and len(half.content) < len(gif.content)
    np.testing.assert_array_equal(small[2][..., :3], lut[shown[2][::2, ::2]])
    assert iio.immeta(io.BytesIO(half.content), extension=".gif")["duration"] == 100
    for params in ({"every": 5, "fps": 20}, {"every": 1, "fps": 0}):
        r = client.get(f"/api/live/{sid}/recording", params={"format": "gif", **params})
        assert r.status_code == 400, params


def test_an_image_starts_one_species_and_undoes_like_a_stroke(client):  # noqa: F811
    """A 2 x 4 PNG (left half black, right half white) on a 16 x 32 grid: v is lo on the left
    half and hi on the right (nearest neighbour), u is untouched; undo restores v."""
    import base64

    sid = new_session(client, init="uniform", size=32, height=16)["id"]
    before = sim_of(client, sid).state()
    img = np.zeros((2, 4), np.uint8)
    img[:, 2:] = 255
    png = base64.b64encode(iio.imwrite("<bytes>", img, extension=".png")).decode()
    r = client.post(f"/api/live/{sid}/image", json={"png": png, "species": "v", "lo": 0.1,
                                                    "hi": 0.6})
    assert r.status_code == 200 and r.json()["undo"] == 1
    after = sim_of(client, sid).state()
    np.testing.assert_allclose(after[1][:, :16], 0.1, rtol=1e-6)
    np.testing.assert_allclose(after[1][:, 16:], 0.6, rtol=1e-6)
    np.testing.assert_array_equal(after[0], before[0])
    client.post(f"/api/live/{sid}/undo").raise_for_status()
    np.testing.assert_array_equal(sim_of(client, sid).state(), before)
    for body, fragment in (({"png": "not base64!"}, "base64"),
                           ({"png": base64.b64encode(b"GIF89a").decode()}, "only PNG"),
                           ({"png": png, "species": "w"}, "unknown species")):
        r = client.post(f"/api/live/{sid}/image", json=body)
        assert r.status_code == 400 and fragment in r.json()["error"], r.json()
