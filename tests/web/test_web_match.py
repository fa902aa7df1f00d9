"""The Explore page's Match panel's API: a planted Gray-Scott picture comes back as Gray-Scott
candidates with pictures and run files; a bad upload is refused in one line before any job."""

from __future__ import annotations

import base64
import io
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

from tests.web_support import finished, poll_job


def _png(rgb: np.ndarray) -> str:
    buf = io.BytesIO()
    Image.fromarray(np.asarray(rgb, np.uint8)).save(buf, format="PNG")
    return base64.b64encode(buf.getvalue()).decode()


def _bomb() -> str:
    """A PNG that is only a header claiming 100 000² pixels."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    ihdr = struct.pack(">IIBBBBB", 100_000, 100_000, 8, 2, 0, 0, 0)
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr)
            + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b""))
    return base64.b64encode(data).decode()


def _planted() -> np.ndarray:
    """Spots grown by Gray-Scott at (F, k) = (0.035, 0.064) on 64² (tests/match/test_match.py's
    target), tiled 2 x 2 and recoloured with viridis: RGB uint8 (128, 128, 3)."""
    import jax
    from matplotlib import colormaps

    from morphogen.match import boxes
    from morphogen.search.evaluate import Evaluator, Problem

    problem = Problem(model="gray-scott", genes=boxes.BOXES["gray-scott"].genes, size=(64, 64),
                      dt=1.0, steps=3000, init="blobs", seed=7)
    _, metrics = Evaluator(problem)(np.array([[0.035, 0.064]], np.float32),
                                    jax.random.PRNGKey(0))
    f = np.tile(metrics["fields"][0], (2, 2))
    rgb = colormaps["viridis"]((f - f.min()) / np.ptp(f))[..., :3]
    return (255 * rgb).astype(np.uint8)


def test_the_panel_lists_the_models_and_a_small_default_budget(client):
    o = client.get("/api/match").json()
    assert "gray-scott" in o["models"] and set(o["default_models"]) <= set(o["models"])
    assert o["budget"]["default"] == o["budget"]["min"] == 8  # the smallest the match takes
    assert o["minutes"]["default"] <= 1


@pytest.mark.slow
def test_a_planted_gray_scott_picture_gives_gray_scott_candidates(client, monkeypatch):
    from morphogen.match import boxes

    # the planted spots settle in 3000 time units: search for that long (as
    # tests/match/test_match.py)
    box = boxes.Box("gray-scott", boxes.BOXES["gray-scott"].genes, time=3000.0)
    monkeypatch.setitem(boxes.BOXES, "gray-scott", box)
    r = client.post("/api/match", json={"image": _png(_planted()), "models": ["gray-scott"],
                                        "budget": 8, "minutes": 0.1, "top": 2})
    assert r.status_code == 200, r.text
    assert r.json()["picture"] == {"width": 128, "height": 128}
    status = poll_job(client, r.json()["job"], finished, timeout=600.0)
    assert status["status"] == "done", status
    assert "simulations" in status["message"]
    res = status["result"]
    assert res["target"]["family"] == "spots" and res["simulations"] >= 4
    assert 1 <= len(res["candidates"]) <= 2
    best = res["candidates"][0]
    assert best["model"] == "gray-scott" and best["rank"] == 1
    assert 0.01 <= best["params"]["F"] <= 0.08 and 0.04 <= best["params"]["k"] <= 0.07
    assert client.get(best["image"]).content[:4] == b"\x89PNG"
    assert client.get(res["sheet"]).content[:4] == b"\x89PNG"
    # its run file is what Explore opens: the same model, parameters, dx, grid and dt
    config = best["run"]["config"]
    assert config["model"] == "gray-scott" and config["dx"] == pytest.approx(best["dx"])
    assert config["params"]["F"] == pytest.approx(best["params"]["F"])
    assert config["size"] == best["size"] and config["dt"] == pytest.approx(best["dt"])
    live = client.post("/api/live", json={"model": {"library": "gray-scott"},
                                          "params": config["params"], "dx": config["dx"],
                                          "size": config["size"][1],
                                          "height": config["size"][0]})
    assert live.status_code == 200, live.text
    assert live.json()["dx"] == pytest.approx(best["dx"])


def _grey(n: int, value: int | None = None) -> np.ndarray:
    if value is not None:
        return np.full((n, n, 3), value, np.uint8)
    y, x = np.mgrid[0:n, 0:n]
    f = np.cos(2 * np.pi * x / 12) * np.cos(2 * np.pi * y / 12)
    return np.repeat(((f + 1) * 127.5).astype(np.uint8)[..., None], 3, axis=-1)


@pytest.mark.parametrize(("change", "fragment"), [
    ({"image": base64.b64encode(b"just some notes, not a picture").decode()}, "not a picture"),
    ({"image": "not base64!"}, "not valid base64"),
    ({"image": None}, "base64-encoded PNG or JPEG"),
    ({"image": _bomb()}, "more than the"),
    ({"image": _png(_grey(10))}, "at least 24x24"),
    ({"image": _png(_grey(64, 200))}, "blank"),
    ({"models": ["no-such-model"]}, "model must be one of"),
    ({"models": []}, "models must be a list"),
    ({"budget": 7}, "budget must be >= 8"),
    ({"minutes": 60}, "minutes must be <= 3"),
    ({"polarity": "sideways"}, "polarity must be one of"),
])
def test_a_bad_upload_or_option_is_refused_in_one_line(client, change, fragment):
    before = len(client.app.state.jobs._jobs)
    r = client.post("/api/match", json={"image": _png(_grey(64)), **change})
    assert 400 <= r.status_code < 500, r.text
    error = r.json()["error"]
    assert fragment in error and "\n" not in error
    assert len(client.app.state.jobs._jobs) == before  # nothing was queued
