"""Web app API: live simulation numbers, isolation between tabs, safety limits, downloads."""

from __future__ import annotations

import time

import imageio.v3 as iio
import numpy as np
import pytest
from fastapi.testclient import TestClient

from morphogen.cli.main import main as cli
from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models import neural_library
from morphogen.models.library import LIBRARY, get_model
from morphogen.web.app import create_app
from morphogen.web.explore import HEADER
from morphogen.web.limits import Limits, WorkTimeout, run_limited
from tests.web_support import finished, poll_job

HOSTS = ["testserver"]


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    with TestClient(create_app(archive=archive, allowed_hosts=HOSTS)) as c:
        yield c


def new_session(client, **body):
    body = {"model": {"library": "gray-scott"}, "size": 32, "init": "square", **body}
    r = client.post("/api/live", json=body)
    assert r.status_code == 200, r.text
    return r.json()


def frame(client, sid):
    r = client.get(f"/api/live/{sid}/frame")
    assert r.status_code == 200, r.text
    w, h, n, t, steps, lo, hi, ms = HEADER.unpack(r.content[: HEADER.size])
    pixels = np.frombuffer(r.content[HEADER.size:], np.uint8).reshape(h, w)
    return {"w": w, "h": h, "frame": n, "t": t, "steps": steps, "lo": lo, "hi": hi,
            "pixels": pixels}


def sim_of(client, sid):
    return client.app.state.sessions.get(sid)


def test_models_lists_the_whole_library(client):
    data = client.get("/api/models").json()
    shipped = set(neural_library.model_names())  # trained neural rules, neural:NAME
    assert {m["name"] for m in data["models"]} == set(LIBRARY) | shipped
    gs = client.get("/api/models/gray-scott").json()
    names = [p["name"] for p in gs["params"]]
    assert names == list(get_model("gray-scott").params)
    for p in gs["params"]:
        assert p["min"] <= p["value"] <= p["max"]
    # the scheme menu and the page's per-scheme cost table are the registry's rows
    from morphogen.solvers.registry import LIVE, SCHEMES
    assert data["schemes"] == list(LIVE)
    assert data["scheme_costs"] == {n: {"periodic": SCHEMES[n].live_cost[0],
                                        "neumann": SCHEMES[n].live_cost[1]} for n in LIVE}


def test_live_frames_equal_the_engine_and_sliders_never_recompile(client):
    """k frames of n steps reproduce simulate() for k*n steps; changing F and dt reuses the
    same compiled program."""
    state = new_session(client, params={"F": 0.03})
    sid = state["id"]
    client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 8}).raise_for_status()
    for _ in range(3):
        f = frame(client, sid)
    assert (f["w"], f["h"], f["steps"]) == (32, 32, 24)
    model, grid = get_model("gray-scott"), Grid((32, 32))
    params = model.parameters({"F": 0.03})
    u0 = make_initial("square", model, grid, params, seed=0)
    ref = simulate(model, grid, u0, params, steps=24, dt=state["dt"]).state
    live = sim_of(client, sid).state()
    np.testing.assert_allclose(live, ref, rtol=1e-5, atol=1e-6)
    # the picture is the shown species quantised on the colour scale used for that frame
    v = live[1]
    assert f["pixels"].shape == v.shape
    program = sim_of(client, sid).engine.program(8)
    compiled = program._cache_size()
    for value in (0.02, 0.05, 0.061):
        r = client.post(f"/api/live/{sid}/params", json={"params": {"F": value}, "dt": 0.5})
        r.raise_for_status()
        frame(client, sid)
    assert program._cache_size() == compiled
    assert sim_of(client, sid).describe()["params"]["F"] == 0.061


def test_picture_is_the_quantised_field(client):
    sid = new_session(client)["id"]
    sim = sim_of(client, sid)
    frame(client, sid)
    lo, hi = sim.lo, sim.hi  # the scale the next frame is drawn with
    f = frame(client, sid)
    v = sim.state()[1]
    expect = np.clip(np.round((v - np.float32(lo)) * np.float32(255.0 / (hi - lo))), 0, 255)
    assert np.abs(f["pixels"].astype(int) - expect.astype(int)).max() <= 1


def test_paint_sets_a_disc_of_the_excited_state(client):
    sid = new_session(client, init="uniform", size=64)["id"]
    r = client.post(f"/api/live/{sid}/paint",
                    json={"points": [[0.5, 0.5]], "radius": 0.1, "mode": "excite"})
    r.raise_for_status()
    u = sim_of(client, sid).state()
    painted = np.isclose(u[1], 0.25)  # Gray-Scott excited v
    # a disc of radius 0.1 of the width covers pi r^2 of the cells
    assert abs(painted.sum() - np.pi * (0.1 * 64) ** 2) < 0.1 * np.pi * (0.1 * 64) ** 2
    ys, xs = np.nonzero(painted)
    assert abs(xs.mean() - 31.5) < 1 and abs(ys.mean() - 31.5) < 1
    # strokes wrap around the edges of the periodic grid
    client.post(f"/api/live/{sid}/paint", json={"points": [[0.0, 0.0]], "radius": 0.05})
    u = sim_of(client, sid).state()
    assert np.isclose(u[1, 0, 0], 0.25) and np.isclose(u[1, -1, -1], 0.25)
    client.post(f"/api/live/{sid}/paint",
                json={"points": [[0.0, 0.0]], "radius": 0.05, "mode": "erase"})
    assert np.isclose(sim_of(client, sid).state()[1, 0, 0], 0.0)


def test_two_tabs_share_nothing(client):
    a = new_session(client)["id"]
    b = new_session(client)["id"]
    assert a != b
    before = sim_of(client, b).state()
    client.post(f"/api/live/{a}/params", json={"params": {"k": 0.05}}).raise_for_status()
    client.post(f"/api/live/{a}/paint", json={"points": [[0.2, 0.2]]}).raise_for_status()
    frame(client, a)
    assert client.get(f"/api/live/{b}").json()["params"]["k"] == get_model("gray-scott").params["k"]
    np.testing.assert_array_equal(sim_of(client, b).state(), before)
    r = client.get("/api/live/not-a-session/frame")
    assert r.status_code == 404 and "expired" in r.json()["error"]


MODEL_HEAD = 'name = "evil"\nspecies = ["u"]\n[equations]\n'
PAYLOADS = [
    "__import__('os').system('touch {marker}')",
    MODEL_HEAD + 'u = "__import__(\'os\').system(\'touch {marker}\')"\n',
    MODEL_HEAD + 'u = "().__class__.__bases__[0].__subclasses__()"\n',
    MODEL_HEAD + 'u = "open(\'{marker}\', \'w\')"\n',
]


@pytest.mark.parametrize("payload", PAYLOADS)
def test_equation_text_goes_through_the_safe_parser_only(client, tmp_path, payload):
    marker = tmp_path / "pwned"
    text = payload.format(marker=marker)
    for path, body in (("/api/models/parse", {"equations": text}),
                       ("/api/live", {"model": {"equations": text}})):
        r = client.post(path, json=body)
        assert r.status_code == 400
        assert r.json()["error"] and "\n" not in r.json()["error"]
    assert not marker.exists()


GRAY_SCOTT_TEXT = """name = "gs-pasted"
species = ["u", "v"]
display = "v"
[parameters]
F = 0.037
k = 0.06
Du = 0.2097
Dv = 0.105
[equations]
u = "-(u*v*v) + F*(1 - u) + Du*lap(u)"
v = "u*v*v - (F + k)*v + Dv*lap(v)"
[initial]
u = 1
v = 0
[excited]
u = 0.5
v = 0.25
"""


def test_pasted_equations_run_like_the_library_model(client):
    a = new_session(client, model={"equations": GRAY_SCOTT_TEXT}, params={"F": 0.03})["id"]
    b = new_session(client, params={"F": 0.03})["id"]
    for sid in (a, b):
        client.post(f"/api/live/{sid}/params", json={"dt": 1.0}).raise_for_status()
        client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 16}).raise_for_status()
        for _ in range(2):
            frame(client, sid)
    assert sim_of(client, a).engine.model.name == "gs-pasted"
    np.testing.assert_allclose(sim_of(client, a).state(), sim_of(client, b).state(),
                               rtol=1e-5, atol=1e-6)


@pytest.mark.parametrize("path,body,fragment", [
    ("/api/live", {"size": 100000}, "size"),
    ("/api/live", {"size": "big"}, "size"),
    ("/api/live", {"params": {"F": "nan"}}, "finite"),
    ("/api/live", {"params": {"nope": 1}}, "unknown parameter"),
    ("/api/live", {"model": {"library": "nope"}}, "unknown model"),
    ("/api/live", {"init": "/etc/passwd"}, "initial condition"),
    ("/api/live", {"model": {"equations": "x" * 10000}}, "limit"),
    ("/api/atlas", {"x": {"name": "k", "lo": 0.04, "hi": 0.07, "n": 16},
                    "y": {"name": "F", "lo": 0.01, "hi": 0.07, "n": 16},
                    "tile": 128, "steps": 200000}, "cell-steps"),
    ("/api/atlas", {"x": {"name": "k", "lo": 0.04, "hi": 0.07, "n": 99},
                    "y": {"name": "F", "lo": 0.01, "hi": 0.07, "n": 2}}, "tiles"),
    ("/api/atlas", {"x": {"name": "F", "lo": 0.04, "hi": 0.07, "n": 2},
                    "y": {"name": "F", "lo": 0.01, "hi": 0.07, "n": 2}}, "different"),
    ("/api/evolve", {"population": 10000}, "population"),
    ("/api/evolve", {"size": 128, "population": 36, "steps": 200000}, "cell-steps"),
    ("/api/evolve", {"genes": [{"name": "zz", "low": 0, "high": 1}]}, "not a parameter"),
])
def test_bad_requests_get_one_line_errors(client, path, body, fragment):
    r = client.post(path, json=body)
    assert r.status_code == 400, r.text
    msg = r.json()["error"]
    assert fragment in msg and "\n" not in msg


def test_live_controls_are_bounded(client):
    sid = new_session(client)["id"]
    dt_max = client.get(f"/api/live/{sid}").json()["dt_max"]
    assert client.post(f"/api/live/{sid}/params", json={"dt": 2 * dt_max}).status_code == 400
    assert client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 3}).status_code == 400
    assert client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 10**6}).status_code == 400
    assert client.post(f"/api/live/{sid}/view", json={"cmap": "no-such-map"}).status_code == 400
    many = [[0.5, 0.5]] * 1000
    assert client.post(f"/api/live/{sid}/paint", json={"points": many}).status_code == 400
    r = client.post(f"/api/live/{sid}/paint", json={"points": [[2.0, 0.5]]})
    assert r.status_code == 400 and "x must be <= 1" in r.json()["error"]
    # raising a diffusion coefficient lowers dt below the new stability limit, with a notice
    before = client.get(f"/api/live/{sid}").json()
    chosen, du = before["dt"], before["params"]["Du"]
    r = client.post(f"/api/live/{sid}/params", json={"params": {"Du": 2.0}}).json()
    assert r["dt"] <= r["dt_max"] and r["notices"]
    # ... and lowering it again restores the dt that was chosen
    r = client.post(f"/api/live/{sid}/params", json={"params": {"Du": du}}).json()
    assert r["dt"] == chosen and "back up" in r["notices"][0]


def test_blow_up_is_reported_not_hung(client):
    # a negative feed makes the exact solution diverge (F = 1e5 is stiff but bounded: the
    # stability limit now follows it down)
    sid = new_session(client, params={"F": -10.0})["id"]
    r = client.get(f"/api/live/{sid}/frame")
    assert r.status_code == 409 and "blew up" in r.json()["error"]
    with client.websocket_connect(f"/api/live/{sid}/ws") as ws:
        ws.send_text("next")
        assert "blew up" in ws.receive_json()["error"]
    # the last finite state is kept for the page to show
    assert np.isfinite(sim_of(client, sid).state()).all()


def test_websocket_streams_frames(client):
    sid = new_session(client)["id"]
    with client.websocket_connect(f"/api/live/{sid}/ws") as ws:
        seen = []
        for _ in range(3):
            ws.send_text("next")
            data = ws.receive_bytes()
            seen.append(HEADER.unpack(data[: HEADER.size])[2])
            assert len(data) == HEADER.size + 32 * 32
    assert seen == [1, 2, 3]


def test_show_redraws_a_painted_state_without_advancing_time(client):
    """``show`` (what a paused page sends after a stroke or a reset) draws the state as it is:
    the step count and time stay, and the painted cell appears in the picture."""
    sid = new_session(client, init="uniform")["id"]
    with client.websocket_connect(f"/api/live/{sid}/ws") as ws:
        ws.send_text("next")
        _, _, _, t0, steps0, *_ = HEADER.unpack(ws.receive_bytes()[: HEADER.size])
        client.post(f"/api/live/{sid}/paint",
                    json={"points": [[0.5, 0.5]], "radius": 0.05}).raise_for_status()
        ws.send_text("show")
        data = ws.receive_bytes()
    w, h, _, t1, steps1, lo, hi, _ = HEADER.unpack(data[: HEADER.size])
    assert (steps1, t1) == (steps0, t0)
    pixels = np.frombuffer(data[HEADER.size:], np.uint8).reshape(h, w)
    sim = sim_of(client, sid)
    f = sim.state()[sim.show]
    expected = np.clip(np.round((f - lo) * 255.0 / max(hi - lo, 1e-30)), 0, 255)
    assert np.abs(pixels.astype(int) - expected).max() <= 1
    assert pixels.min() != pixels.max()  # the stroke shows


def test_slow_work_times_out_with_a_message(monkeypatch):
    import anyio

    from morphogen.web.live import LiveSim

    async def go():
        return await run_limited(lambda: time.sleep(2), 0.1, "a frame")

    with pytest.raises(WorkTimeout, match="took longer than 0.1 s"):
        anyio.run(go)
    # a set-up slower than the limit (a warm cache can set a small grid up within it)
    configure = LiveSim.configure
    monkeypatch.setattr(LiveSim, "configure",
                        lambda self, *a, **k: time.sleep(0.5) or configure(self, *a, **k))
    app = create_app(limits=Limits(request_timeout_s=0.05), allowed_hosts=HOSTS)
    with TestClient(app) as c:
        r = c.post("/api/live", json={"size": 32})
        assert r.status_code == 504 and "took longer" in r.json()["error"]


def test_downloads_png_and_a_run_file_the_cli_reproduces(client, tmp_path):
    sid = new_session(client, params={"F": 0.03})["id"]
    client.post(f"/api/live/{sid}/view", json={"steps_per_frame": 16}).raise_for_status()
    for _ in range(4):
        frame(client, sid)
    png = client.get(f"/api/live/{sid}/png?cmap=magma")
    assert png.headers["content-type"] == "image/png" and png.content[:4] == b"\x89PNG"
    # at scale 3 each cell is a 3 x 3 block of one colour (nearest neighbour)
    one = iio.imread(png.content)
    big = iio.imread(client.get(f"/api/live/{sid}/png?cmap=magma&scale=3").content)
    assert big.shape == (3 * one.shape[0], 3 * one.shape[1], 3)
    np.testing.assert_array_equal(big[::3, ::3], one)
    np.testing.assert_array_equal(big[2::3, 1::3], one)
    big_sid = new_session(client, size=512)["id"]
    r = client.get(f"/api/live/{big_sid}/png?scale=16")
    assert r.status_code == 400 and "a scale of at most 8" in r.json()["error"]
    r = client.get(f"/api/live/{sid}/config?steps=64")
    assert "attachment" in r.headers["content-disposition"]
    path = tmp_path / "run.json"
    path.write_bytes(r.content)
    assert cli(["simulate", "--config", str(path), "--out", str(tmp_path / "out")]) == 0
    with np.load(tmp_path / "out" / "state.npz") as out:
        state = np.stack([out["u"], out["v"]])
    np.testing.assert_allclose(state, sim_of(client, sid).state(), rtol=1e-5, atol=1e-6)


def test_atlas_job_lays_tiles_out_for_clicks(client):
    body = {"x": {"name": "k", "lo": 0.05, "hi": 0.065, "n": 3},
            "y": {"name": "F", "lo": 0.02, "hi": 0.04, "n": 2}, "tile": 16, "steps": 40}
    job = client.post("/api/atlas", json=body).json()["job"]
    status = poll_job(client, job, finished, timeout=30.0)
    assert status["status"] == "done", status
    res = status["result"]
    assert res["x"]["values"] == pytest.approx([0.05, 0.0575, 0.065])
    import imageio.v3 as iio

    img = iio.imread(client.get(res["image"]).content)
    pad, n = res["pad"], res["tile"]
    assert img.shape[:2] == (2 * (n + pad) + pad, 3 * (n + pad) + pad)
    assert np.all(img[0, :] == 255) and np.all(img[:, 0] == 255)  # padding frames the tiles
    assert client.get("/api/jobs/unknown").status_code == 404


def test_only_local_host_names_and_a_strict_content_policy():
    with TestClient(create_app()) as c:
        assert c.get("/", headers={"host": "evil.example"}).status_code == 400
        r = c.get("/", headers={"host": "127.0.0.1:8000"})
        assert r.status_code == 200 and "default-src 'self'" in r.headers["content-security-policy"]
        assert c.get("/static/app.js", headers={"host": "localhost"}).status_code == 404


def test_front_end_fetches_nothing_from_elsewhere():
    from morphogen.web.app import STATIC

    for f in STATIC.iterdir():
        text = f.read_text()
        assert "http://" not in text and "https://" not in text and "//cdn" not in text, f.name


def test_serve_refuses_a_bad_port(capsys):
    assert cli(["serve", "--port", "70000"]) == 2
    assert "--port" in capsys.readouterr().err


def test_mesh_job_returns_a_coloured_flower(client):
    job = client.post("/api/mesh", json={"shape": "petal", "size": 40, "steps": 50}).json()["job"]
    status = poll_job(client, job, finished, timeout=30.0)
    assert status["status"] == "done", status
    res = status["result"]
    v = np.asarray(res["vertices"]).reshape(-1, 3)
    faces = np.asarray(res["faces"]).reshape(-1, 3)
    assert len(v) == res["n_vertices"] and faces.max() < len(v)
    assert len(res["colours"]) == 3 * len(v)
    # the unit petal scaled so that it is `size` mesh units long (one unit ~ one grid cell)
    from morphogen.flowers.shapes import petal

    unit = petal(length=1.0, width=0.7, edge=1.0 / (40 * 0.7))
    np.testing.assert_allclose(v, np.asarray(unit.vertices) * 40, atol=2e-3)
    assert client.get(res["image"]).content[:4] == b"\x89PNG"
    for body, fragment in (({"size": 240, "detail": 1.5}, "size x detail"),
                           ({"shape": "teapot"}, "shape")):
        r = client.post("/api/mesh", json=body)
        assert r.status_code == 400 and fragment in r.json()["error"]


def _mesh_job(client, body):
    job = client.post("/api/mesh", json=body).json()["job"]
    return poll_job(client, job, finished, timeout=60.0)


def test_mesh_modelling_loop_paints_continues_and_writes_the_pipeline_files(client, tmp_path):
    """Ringham §3.3: a painted production field reaches the PLY as a named vertex field, a
    painted source sets the start there, and a continued run starts from the last state."""
    from morphogen.domains.ply import load_mesh, ply_fields

    base = {"shape": "petal", "size": 30, "steps": 8, "model": {"library": "gray-scott"}}
    painted = list(range(0, 40, 3))
    res = _mesh_job(client, {**base, "paint": {"name": "F", "value": 0.07,
                                               "vertices": painted}})["result"]
    ply = tmp_path / "out.ply"
    ply.write_bytes(client.get(res["ply"]).content)
    fields = ply_fields(ply)
    f_default = get_model("gray-scott").params["F"]
    expected = np.full(res["n_vertices"], f_default, np.float32)
    expected[painted] = 0.07
    np.testing.assert_allclose(fields["F"], expected, rtol=1e-6)
    assert {"u", "v"} <= set(fields) and load_mesh(ply).n_vertices == res["n_vertices"]
    assert client.get(res["png"]).content[:4] == b"\x89PNG"
    live = client.get(f"/api/jobs/{res['job']}/files/live.bin").content
    assert len(live) == 3 * res["n_vertices"]
    # a source: v = 1 at the painted vertices; no steps beyond one, so it is still visible
    src = _mesh_job(client, {**base, "steps": 1, "paint": {"name": "v", "value": 1.0,
                                                           "vertices": [5]}})["result"]
    v1 = ply_fields(_save(client, src["ply"], tmp_path / "s.ply"))["v"]
    assert v1[5] > 0.9 and np.median(v1) < 0.5
    # continue: zero-length change of parameters from the painted run's state, one more step
    more = _mesh_job(client, {**base, "steps": 1, "from": src["job"]})["result"]
    v2 = ply_fields(_save(client, more["ply"], tmp_path / "c.ply"))["v"]
    assert v2[5] > 0.8  # grew on from the source, not from a fresh start
    bad = client.post("/api/mesh", json={**base, "paint": {"name": "zz", "value": 1,
                                                           "vertices": [1]}})
    assert bad.status_code == 400 and "paint a species" in bad.json()["error"]


def _save(client, url, path):
    path.write_bytes(client.get(url).content)
    return path


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_every_library_model_runs_live(client, name):
    state = new_session(client, model={"library": name}, init=None)
    model = get_model(name)
    assert state["dt"] <= min(model.dt, state["dt_max"])
    assert state["show"] == model.display_species
    f = frame(client, state["id"])
    assert f["steps"] == state["steps_per_frame"]
    assert np.isfinite(sim_of(client, state["id"]).state()).all()


def test_mesh_limits_and_the_size_error_name_the_detail(client):
    limits = client.get("/api/mesh/limits").json()
    assert limits == {"size": [20.0, 240.0], "detail": [0.2, 1.5], "max_across": 160.0}
    r = client.post("/api/mesh", json={"size": 200, "detail": 1.5})
    assert r.status_code == 400 and "the size can be at most 106" in r.json()["error"]


def test_atlas_cancel_stops_the_computation_between_chunks(client):
    """Cancel takes effect after the chunk in progress (250 steps), not when the whole atlas
    would have finished; the job reports its share done and an ETA while it runs."""
    body = {"x": {"name": "k", "lo": 0.05, "hi": 0.065, "n": 4},
            "y": {"name": "F", "lo": 0.02, "hi": 0.04, "n": 4}, "tile": 32, "steps": 150_000}
    job = client.post("/api/atlas", json=body).json()["job"]
    running = poll_job(client, job, lambda s: s["progress"] > 0 or s["status"] != "running"
                    and s["status"] != "queued")
    # a share strictly inside (0, 1): how far the job got before the first 50 ms poll saw it
    # depends on the machine's speed (16 tiles of 32² run 250 steps in about 13 ms)
    assert running["status"] == "running" and 0 < running["progress"] < 0.5
    assert running["eta_s"] is not None and running["eta_s"] > 0
    assert "step" in running["message"]
    client.delete(f"/api/jobs/{job}")
    stopped = poll_job(client, job, lambda s: s["status"] != "running", timeout=30.0)
    assert stopped["status"] == "cancelled" and stopped["progress"] < 0.5
    assert stopped["eta_s"] is None


def test_atlas_flags_grid_scale_checkerboards():
    """A checkerboard tile is flagged (shown like a blow-up), a resolved pattern is not."""
    from morphogen.web.atlas_routes import _grid_scale

    i, j = np.indices((32, 32))
    checker = ((i + j) % 2).astype(np.float32)
    stripes = np.sin(2 * np.pi * j / 8).astype(np.float32)
    assert _grid_scale(np.stack([checker, stripes, checker + 0.1 * stripes])).tolist() == \
        [True, False, True]
