"""End-to-end tests: `morphogen serve` driven by a real headless Chromium.

``ensure_browser.sh`` installs Debian's ``chromium`` and the npm package ``playwright-core``
when they are missing; the tests skip (with the reason) only if that is impossible.
``browser.mjs`` performs each scenario and writes what it saw, plus screenshots, into
``out/e2e/`` (override with ``$MORPHOGEN_E2E_OUT``); the checks are made here. The server and
the driver are in ``conftest.py`` and ``browser_support.py``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from tests.e2e.browser_support import HERE, MEASURE, OUT, scenario

pytestmark = pytest.mark.slow
LAMBDA = 0.9  # Skaggs eq. 3.9

def test_explore_shows_a_live_simulation(server):
    warm = wait_for_warm_up() if MEASURE else None
    load = os.getloadavg()[0]
    data = scenario(server, "explore")
    assert data["model"] == "gray-scott" and data["size"] == 256
    assert data["change"] > 0, "the picture did not change between frames"
    assert data["fps"] > 0
    print(f"\nExplore, 256x256, {data['steps_per_frame']} steps per frame: "
          f"{data['fps']:.1f} frames/s in the browser, {data['server_ms']:.1f} ms per frame "
          "on the server")
    assert (OUT / "explore.png").stat().st_size > 10_000
    if MEASURE:  # docs/web.md's speed figures: measured, not asserted
        m = data["measured"]
        m.update(warm_up=warm, load_before=load, load_after=os.getloadavg()[0])
        (OUT / "explore-speed.json").write_text(json.dumps(m, indent=2))
        (OUT / "explore-speed.txt").write_text(speed_table(m))
        assert all(r["fps"] > 0 for rows in m["rates"].values() for r in rows)


def wait_for_warm_up() -> str:
    """The server's ``warm-up: ...`` line, once it has printed it (all models compiled)."""
    log = OUT / "server.log"
    end = time.monotonic() + 600
    while time.monotonic() < end:
        warm = [w for w in log.read_text().splitlines() if w.startswith("warm-up:")]
        if warm:
            return warm[0]
        time.sleep(0.5)
    pytest.fail("the server did not finish its warm-up in 10 minutes")


def speed_table(m: dict) -> str:
    """The measured figures as lines of text, each with the 1-minute load average."""
    lines = [f"1-minute load: {m['load_before']:.2f} before, {m['load_after']:.2f} after",
             m["warm_up"]]
    for f in m["firstFrame"]:
        lines.append(f"first frame of a new tab: {f['frame'] / 1000:.2f} s after navigation, "
                     f"{f['afterLoad'] / 1000:.2f} s after the load event (load {f['load']})")
    for size, rows in m["rates"].items():
        for r in rows:
            lines.append(f"Gray-Scott Euler {size}^2, {r['steps']} steps/frame: {r['fps']:.1f} "
                         f"frames/s, {r['serverMs']:.1f} ms/frame on the server, first frame "
                         f"after the change {r['firstS']:.2f} s (load {r['load']})")
    for where, rows in m["switches"].items():
        for name, kind, r in rows:
            lines.append(f"switch ({where}) to {name}, {kind}: {r['s']:.2f} s (load {r['load']})")
    return "\n".join(lines) + "\n"


def test_moving_the_feed_slider_changes_the_picture(server):
    data = scenario(server, "slider")
    assert data["repeat"] == 0, "the same start and steps must give the same picture"
    assert data["after"] > data["before"]
    assert float(data["shown"]) == pytest.approx(data["after"], rel=1e-3)
    assert data["change"] > 1000, "changing F did not change the picture"
    # the address holds the settings, and a reload restores them
    assert "p.F=" in data["hash"] and "cmap=magma" in data["hash"]
    assert data["urlAfter"] == data["urlBefore"] and data["urlAfter"]["cmap"] == "magma"
    assert data["urlAfter"]["F"] == pytest.approx(data["after"])
    assert data["hashAfter"] == data["hash"]
    # a refused link: in a running tab the simulation goes on; opened afresh, the default runs
    assert data["keptRunning"] == "magma" and data["hashKept"] == data["hash"]
    assert "address were refused" in data["refused"] and "9999" in data["refused"]
    assert data["refusedSize"] == 256


def test_painting_a_perturbation(server):
    ramp = np.tile(np.linspace(0, 255, 64).astype(np.uint8), (64, 1))  # black left, white right
    iio.imwrite(OUT / "ramp.png", ramp)
    data = scenario(server, "paint")
    flat, painted = data["flat"], data["painted"]
    assert flat[0] == flat[1], "the uniform start should look uniform"
    assert painted[0] != flat[0], "the click left no mark"
    assert painted[1] != flat[1], "the drag left no mark"
    assert data["untouched"] == flat[0], "paint appeared where nothing was painted"
    # the readout names every species under the cursor; the bar spans the frame's range
    assert data["paintedReadout"]["values"]["v"] > 0.05  # the click excited v there
    readout = data["undone"]
    assert set(readout["values"]) == {"u", "v"} and "u = " in readout["text"]
    assert (readout["row"], readout["col"]) == (64, 64)  # a quarter of 256
    bar = data["bar"]
    assert bar["top"] == bar["lutTop"] and bar["hi"] and bar["lo"]
    assert len(bar["ticks"]) == 3 and all(bar["ticks"])  # values inside the bar too
    assert data["undoLabel"] == "Undo stroke (2)"
    # U twice took both strokes back: the uniform start (Gray-Scott u = 1, v = 0) is back
    assert data["undone"]["values"] == {"u": 1.0, "v": 0.0}
    assert data["undoneDrag"]["values"] == {"u": 1.0, "v": 0.0}
    assert data["undoDisabled"]
    brush = data["brush"]
    assert brush["cursor"].startswith('url("data:image/png') and brush["species"] == ["", "u", "v"]
    assert abs(brush["ring"] - 2 * 0.03 * brush["width"]) <= 1  # the default radius 0.03
    assert brush["imageUndo"] == "Undo stroke (1)"  # an uploaded PNG became v's state
    # F from the ramp: a map badge instead of the number, the slider and run file unavailable
    mapped, cleared = data["map"]["mapped"], data["map"]["cleared"]
    assert mapped["maps"] == {"F": {"lo": 0.02, "hi": 0.06, "resample": "bilinear"}}
    assert mapped["badge"] == "map ×" and "0.02 at black to 0.06 at white" in mapped["title"]
    assert mapped["rangeDisabled"] and mapped["numHidden"] and mapped["runHidden"]
    assert mapped["note"]
    assert cleared["maps"] == {} and cleared["badge"] is None and not cleared["rangeDisabled"]
    assert not cleared["numHidden"] and not cleared["runHidden"] and not cleared["note"]


def test_one_evolve_generation_with_two_favourites(server):
    data = scenario(server, "evolve")
    assert data["picked"] == 2
    run = {r["id"]: r for r in data["runs"]}[data["run"]]
    assert run["fitness"] == "user" and run["done"] >= 1
    # the two favourites (tiles 1 and 4 of 6) share lambda, the other four 1 - lambda
    expect = [(1 - LAMBDA) / 4] * 6
    expect[1] = expect[4] = LAMBDA / 2
    assert data["gen1"] == pytest.approx(expect, rel=1e-5)
    # reloading while the run waits for a choice keeps it with its own settings (not the
    # page's defaults) and the favourite picked before the reload; Runs offers to continue it
    shown = {"population": "6", "size": "48", "steps": "2000", "generations": "3"}
    assert data["reloaded"] == {"gen": 2, "state": "choose", "stop": True, "controls": shown,
                                "picked": ["3"]}
    assert "null" not in data["detailText"] and data["continued"] == "choose"
    # stopped while choosing, generation 2's six pictures stay (after a reload too), unchosen
    assert data["stopped"] == {"captions": [f"#{i} (not chosen)" for i in range(6)],
                               "loaded": 6, "controls": shown}
    # stopped, it resumes from the Runs page at generation 2, and is deleted after a confirmation
    assert data["resumedGen"] == 2
    assert data["run"] in data["dialog"] and data["run"] not in data["listedAfterDelete"]


def test_downloaded_params_file_runs_with_the_cli(server, tmp_path):
    data = scenario(server, "download")
    assert data["run"].endswith(".json") and data["png"].endswith(".png")
    # saved at 4 pixels per cell, nearest neighbour: 4 x 4 blocks of one colour
    saved = iio.imread(OUT / "explore-saved.png")
    assert saved.shape[:2] == (4 * 128, 4 * 256)
    np.testing.assert_array_equal(saved[::4, ::4], saved[3::4, 3::4])
    # a 256 x 128 grid under IMEX, shown at its own aspect ratio, recorded as a GIF
    assert data["canvas"] == [256, 128] and data["shownRatio"] == pytest.approx(2, rel=0.02)

    movie = iio.imread(OUT / "recording.gif", index=None)
    assert data["gif"].endswith(".gif") and data["recordedLabel"] >= 12
    assert movie.shape[1:3] == (128, 256) and 12 <= len(movie) <= data["recordedLabel"]
    run_file = OUT / "run.json"
    config = json.loads(run_file.read_text())["config"]
    assert config["model"] == "gray-scott" and config["size"] == [128, 256]
    assert config["scheme"] == "imex"
    # the page opens a run.json: its model, parameters, grid, scheme and colour map
    assert data["opened"] == {"F": 0.05, "cmap": "magma", "size": 256, "height": 128,
                              "scheme": "imex", "model": "gray-scott"}
    assert "not a run file" in data["openError"]
    out = tmp_path / "sim"
    r = subprocess.run([sys.executable, "-m", "morphogen.cli.main", "simulate", "--config",
                        str(run_file), "--out", str(out)], capture_output=True, text=True,
                       timeout=300, env={**os.environ, "JAX_PLATFORMS": "cpu"})
    assert r.returncode == 0, r.stderr
    with np.load(out / "state.npz") as state:
        assert state["v"].shape == (128, 256) and np.isfinite(state["v"]).all()
    record = json.loads((out / "run.json").read_text())
    assert record["resolved"]["steps"] == config["steps"]


def test_atlas_tile_opens_in_explore(server):
    data = scenario(server, "atlas")
    assert np.asarray(data["valid"]).shape == (6, 6)
    assert data["params"]["F"] == pytest.approx(data["y"]["values"][-1])
    assert data["params"]["k"] == pytest.approx(data["x"]["values"][1])
    # the tile's own grid, so Explore grows the pattern the tile showed; the Grid box shows it
    assert data["size"] == data["tile"] == 32 and data["sizeShown"] == "32"
    assert data["dt"] == data["atlasDt"]  # and its step
    assert not data["staleShown"]  # an error does not sit over the previous atlas
    mosaic = iio.imread(OUT / "atlas-mosaic.png")  # the downloaded mosaic: 6 x 6 tiles of 32
    assert mosaic.shape[0] >= 6 * 32 and mosaic.shape[1] >= 6 * 32
    # the second atlas named each tile's family: legend with counts and colours, hover, CSV
    fam = data["families"]
    from morphogen.patterns.classify import COLOURS

    assert sum(fam["counts"].values()) == 36
    assert [(f, f"{f} {n}") for f, n in fam["counts"].items()] == \
        [(name, text) for name, text, _ in data["legend"]]
    for name, _, colour in data["legend"]:
        r, g, b = (int(COLOURS[name][i:i + 2], 16) for i in (1, 3, 5))
        assert colour == f"rgb({r}, {g}, {b})"
    assert data["hover"].endswith(f" · {fam['labels'][0][1]}")
    assert data["csv"]["shown"] and data["csv"]["text"].startswith("k,F,family,")
    assert len(data["csv"]["text"].splitlines()) == 1 + 36
    # the downloaded mosaic has each tile's frame in its family's colour (top row, column 2)
    top = mosaic[1, 1 + (32 + 1)]
    r, g, b = (int(COLOURS[fam["labels"][0][1]][i:i + 2], 16) for i in (1, 3, 5))
    assert tuple(int(c) for c in top[:3]) == (r, g, b)


def test_two_tabs_have_their_own_simulations(server):
    data = scenario(server, "tabs")
    assert data["ids"][0] != data["ids"][1]
    assert data["k"][0] != data["k"][1]


def test_unsafe_equation_text_is_refused_in_the_page(server):
    data = scenario(server, "equations")
    assert data["error"].strip() and data["model"] == "gray-scott"
    # the server's "line 5, column 16" error marks that line in the equations box
    marked = data["marked"]
    assert marked["line"] == 5 and marked["selected"] == 'u = "u*(1-u) + zz"' and marked["bad"]
    assert marked["mark"] == '5 | u = "u*(1-u) + zz"\n' + " " * 19 + "^"


def test_mesh_page_grows_and_rotates_a_flower(server):
    data = scenario(server, "mesh")
    assert data["faces"] > 1000
    assert data["before"] != data["after"], "dragging did not rotate the view"
    assert 0 < data["tilt"] <= 1.2 + 1e-9  # tilted by the drag, never edge-on
    # Ringham's modelling loop: the pattern shown while it grows, a painted prepattern, a run
    # continued with new parameters, and the pipeline's PLY (with the painted field) and PNG
    assert data["liveFrames"] >= 1
    assert data["painted"] > 0 and not data["loopError"].strip()
    assert "property float F" in data["plyHeader"] and "property float u" in data["plyHeader"]
    assert data["pngHead"] == "PNG"
    # a case study from the menu: the pipeline's last stage in the viewer, its PLY; and a cancel
    cases = data["cases"]
    assert cases["menu"] == [["tiny", "tiny (Ringham §4.2)"], ["endless", "endless (Ringham §4.9)"]]
    shown = cases["shown"]
    assert shown["faces"] == shown["nFaces"] > 0 and shown["stage"] == "02-grow" and shown["still"]
    assert "property float v" in cases["plyHeader"]
    assert any("stage 2 of 2 (grow)" in m for m in cases["progress"] + [cases["running"]])
    # a cancel is the user's own: no error, and the finished case study stays shown
    assert cases["cancelled"].startswith("case study cancelled; still showing tiny")
    assert not cases["errorShown"] and cases["keptFaces"] == shown["nFaces"]
    assert cases["cancelHidden"]
    (OUT / "mesh-fps.txt").write_text(f"{data['fps']:.1f} frames/s, {data['faces']} faces\n")


def test_hidden_elements_keys_presets_and_slider_ranges(server):
    """Web-app details: hidden controls stay hidden (page CSS must not override ``hidden``),
    Space/S drive the simulation, strokes and resets while paused do not advance time, a
    chosen preset stays shown until a parameter changes, a
    typed value widens the slider only while it needs to, the canvas scales by pixels."""
    data = scenario(server, "details")
    assert data["hiddenShown"] == {"atlas": [], "evolve": [], "mesh": []}
    assert data["running"] == [True, False]
    assert data["stepped"] == 1
    assert data["afterPaint"] == data["beforePaint"] > 0, "painting while paused advanced time"
    assert data["afterReset"] == 0 and data["runLabel"] == "Run"
    assert data["preset"] == "mazes" and data["presetAfterEdit"] == ""
    assert data["maxAt50"] == 50 and data["maxBack"] == data["maxBefore"] < 50
    assert data["rendering"] == "pixelated"
    assert "lost the connection" in data["lost"] and "not answering" in data["statsLost"]


def test_layout_fits_a_phone_and_the_evolve_sidebar(server):
    """At 390 x 844 the picture comes first with the sidebar under it and no page is wider
    than the screen; at desktop size every Evolve control fits inside its sidebar."""
    data = scenario(server, "layout")
    assert data["evolveDesktop"] == []
    assert all(w <= 390 for w in data["width"].values()), data["width"]
    assert data["stacked"] and data["canvasWidth"] >= 300


def test_mesh_page_has_a_detail_control_and_refuses_sizes_up_front(server):
    """The Mesh page's Detail box bounds the Size box (size x detail <= 160, as the server
    checks); a size beyond it is refused on the page, naming the largest allowed."""
    data = scenario(server, "meshsize")
    assert data["max"] == 106
    assert "at most 106" in data["error"] and data["posts"] == 0


def test_runs_page_shows_a_map_elites_archive_and_opens_an_elite(server, quality_diversity_run):
    """A MAP-Elites run from the command line, in the server's archive: the Runs page shows its
    elite map, coverage plot and one tile per elite; an elite opens in Explore."""
    import urllib.request

    with urllib.request.urlopen(f"{server.rstrip('/')}/api/runs") as r:
        archive = json.loads(r.read())["archive"]
    quality_diversity_run(archive, Path(archive).parent / "me-run", 2, 3)
    data = scenario(server, "mapelites")
    assert data["images"] == 2 + data["elites"]  # map, plot, one picture per elite
    assert data["tiles"] == data["elites"] >= 1
    assert f"{data['elites']} of 64 cells" in data["heading"]
    assert data["params"]["F"] == pytest.approx(data["first"]["F"])
    assert data["params"]["k"] == pytest.approx(data["first"]["k"])


def test_evolve_page_runs_map_elites_and_shows_its_elites(server):
    data = scenario(server, "evolvemap")
    assert data["tiles"] == data["elites"] >= 1
    assert data["params"]["F"] == pytest.approx(data["first"]["F"])


def test_a_forgotten_session_comes_back_with_every_setting(server):
    """The server forgets the tab's session (what a restart does): the page starts it again
    with its parameters, view, grid, boundary and scheme and puts back the painted state of the
    last stroke; the address stays the same and a paused view stays paused."""
    data = scenario(server, "restart")
    before, after = data["before"], data["after"]
    assert before["server"]["F"] == pytest.approx(0.05) and before["server"]["cmap"] == "magma"
    assert after["server"] == before["server"]
    assert after["shown"] == before["shown"]
    assert data["hashAfter"] == data["hashBefore"]
    assert "restarted" in data["notice"] and not data["error"].strip()
    # the whole stroke painted before is back (its end too, painted after the first 200 ms of
    # the drag), at its own time, and a paused view stays paused
    assert data["paintedBefore"]["t"] > 0
    assert data["paintedAfter"] == data["paintedBefore"] and not data["running"]
    assert "painted state" in data["notice"]


def test_dt_lowered_stays_said_and_dt_back_up_passes(server):
    data = scenario(server, "dtNotices")
    assert data["lowered"].startswith("dt lowered to ")  # still shown 5 s later
    assert data["up"].startswith("dt back up to ") and data["gone"] == ""


def test_refusals_and_grid_changes_keep_the_controls_true(server):
    """A new grid keeps the species shown, steps per frame, colours, a fixed range and a
    hand-set dt; after a refused grid or parameter every control shows what runs."""
    data = scenario(server, "refusals")
    grid = data["afterGrid"]
    assert grid["server"]["size"] == "128" and grid["server"]["species"] == "u"
    assert grid["server"]["steps"] == "8" and grid["server"]["cmap"] == "magma"
    assert grid["rawServer"]["range"] == [0, 1]
    assert grid["server"]["dt"] == pytest.approx(data["handDt"])
    assert grid["shown"] == grid["server"]
    refused = data["refusedGrid"]
    assert "9999" in refused["error"] and refused["shown"] == refused["server"]
    assert refused["shown"]["size"] == "128"
    param = data["refusedParam"]
    assert param["shown"] == param["server"] and param["error"]


def test_each_scheme_runs_at_its_own_step(server):
    """imex1, imex and etdrk4 treat diffusion implicitly: they run at the stable step the
    server reports (the run policy's, whose limit keeps its own margin), far above Euler's; a
    set-up whose frames would exceed the server's limit is refused on the page before anything
    is sent."""
    data = scenario(server, "schemes")
    rows = {r["scheme"]: r for r in data["rows"]}
    for name in ("imex1", "imex", "etdrk4"):
        assert rows[name]["dt"] == pytest.approx(rows[name]["dt_max"], rel=1e-6)
        assert rows[name]["shown"] == pytest.approx(rows[name]["dt"], rel=1e-3)
        assert rows[name]["dt"] > 5 * rows["euler"]["dt"]
    assert rows["euler"]["dt"] <= rows["euler"]["dt_max"]
    budget = data["budget"]
    assert "limit" in budget["error"] and budget["posts"] == 0 and budget["sizeShown"] == "128"
    # the frame-time estimate reads the set-up's fastest frame, not one that compiled
    assert [round(ms) for ms in data["framesMs"]] == [5000, 20, 20]


def test_axe_finds_no_serious_violation_and_every_page_has_a_heading(server):
    """axe-core, loaded from node_modules into each page (no network), reports no critical
    or serious accessibility violation; each page has an h1."""
    data = scenario(server, "axe")
    assert data["found"] == {name: [] for name in ("explore", "atlas", "evolve", "runs", "mesh")}
    assert all(len(h) == 1 for h in data["h1"].values()), data["h1"]
    # the default atlas (10 x 10 tiles of 64²) says its step limit beside the field: 3e9 / 409 600
    assert data["stepLimit"] == "at most 7324 steps for these tiles"


def test_keyboard_reaches_run_rows_atlas_tiles_and_both_canvases(server, quality_diversity_run):
    """Tab reaches the Explore picture (arrows move the brush, Enter paints), its three file
    choosers, the atlas
    mosaic (arrows choose a tile, Enter opens it), the flower (arrows turn it) and the run
    rows (Enter opens one)."""
    import urllib.request

    with urllib.request.urlopen(f"{server.rstrip('/')}/api/runs") as r:
        archive = json.loads(r.read())["archive"]
    quality_diversity_run(archive, Path(archive).parent / "keyboard-run", 1, 5)
    data = scenario(server, "keyboard")
    assert data["canvasTabs"] > 0 and data["canvasUndo"] == "Undo stroke (1)"
    assert all(data["fileTabs"].values()), data["fileTabs"]  # the three file choosers
    assert data["readout"].startswith("cell (136, 128)")
    assert data["atlasTabs"] > 0 and data["atlasHover"].startswith("k = ")
    assert data["atlasOpened"]["k"] == pytest.approx(data["atlasOpened"]["want"])
    assert data["meshTabs"] > 0 and data["meshTurned"] == pytest.approx(0.1)
    assert data["runRows"] >= 1 and data["runTabs"] > 0 and data["runOpened"]


def test_phone_shows_the_picture_first(server, quality_diversity_run):
    """At 390 x 844 with touch: the picture is in the first screen and stays there while the
    controls scroll; every target is at least 44 px; no keyboard hints; the atlas and the
    Runs table fit the screen with their labels."""
    import urllib.request

    with urllib.request.urlopen(f"{server.rstrip('/')}/api/runs") as r:
        archive = json.loads(r.read())["archive"]
    quality_diversity_run(archive, Path(archive).parent / "phone-run", 1, 6)
    data = scenario(server, "phone")
    assert not data["errors"]
    top = data["canvasTop"]
    assert top["y"] >= 0 and top["y"] + top["height"] <= 844 and top["width"] >= 250
    assert data["scrollY"] > 400  # the controls scrolled under it
    moved = data["canvasScrolled"]
    assert moved["y"] >= 0 and moved["y"] + moved["height"] <= 844
    slider = data["slider"]
    assert slider["y"] >= moved["y"] + moved["height"] and slider["y"] + slider["height"] <= 845
    assert data["small"] == []
    assert data["under"] == []  # no control focused by keyboard rests under the picture
    assert not data["keysShown"]
    assert data["atlas"] == {"image": True, "labels": True, "width": 390}
    runs = data["runs"]
    assert runs["page"] <= 390 and runs["overflow"] == "auto" and runs["firstCellInside"]


def test_checkpoint_and_web_page_from_explore(server, tmp_path):
    """Explore saves the whole state (a painted stroke included) as state.npz: the command
    line continues from it and the page restores it; the Web page button writes an HTML page
    starting from that state, and names a scheme the page cannot run."""
    data = scenario(server, "checkpoint")
    assert data["names"] == ["gray-scott-state.npz", "gray-scott-run.json", "gray-scott.html"]
    assert data["painted"]["v"] > 0.1 and data["afterReset"]["v"] == 0.0
    assert data["restored"] == data["painted"]
    assert "export-web: scheme 'imex' is not supported" in data["refused"]
    with np.load(OUT / "checkpoint.npz") as state:
        v = state["v"]
    assert v.shape == (64, 64) and v.max() > 0.1 and v[0, 0] == 0.0
    out = tmp_path / "continued"
    r = subprocess.run([sys.executable, "-m", "morphogen.cli.main", "simulate", "--config",
                        str(OUT / "checkpoint-run.json"), "--init", str(OUT / "checkpoint.npz"),
                        "--steps", "20", "--quiet", "--out", str(out)],
                       capture_output=True, text=True, timeout=300,
                       env={**os.environ, "JAX_PLATFORMS": "cpu"})
    assert r.returncode == 0, r.stderr
    with np.load(out / "state.npz") as continued:
        assert continued["v"].max() > 0.05  # the painted spot grew on, not a fresh start
    r = subprocess.run(["node", str(HERE / "webpage.mjs"), str(OUT / "explore-page.html"), "0",
                        str(tmp_path / "page.json"), str(OUT / "explore-page-phone.png")],
                       capture_output=True, text=True, timeout=300, cwd=HERE)
    assert r.returncode == 0, r.stderr
    page = json.loads((tmp_path / "page.json").read_text())
    start = np.asarray(page["state"], np.float32).reshape(2, 64, 64)
    np.testing.assert_array_equal(start[1], v)
