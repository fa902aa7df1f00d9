"""Pages written by `morphogen export-web` for a model whose names are hostile, opened in
headless Chromium: no injected handler runs and the page still works.

The model (tests/runs/test_export_web_escaping.py::HOSTILE_MODEL) passes the equation parser: its
free-text ``name`` holds an ``<img onerror>``, ``</script><script>``, ``<!--``, U+2028/2029 and
the template's placeholders ``@DATA@``, ``@STEP@``, ``@SCRIPT@``, ``@TITLE@``; its species and
parameters are named ``img``, ``script``, ``constructor`` and ``onerror``; the colour map is a
ramp written with spaces. The injected code would set ``window.__pwned`` and the title. Three
ways to the page: `export-web` of the model file, of a run.json that carries the model's text,
and the web app's page download (``GET /api/live/{sid}/page.html``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import urllib.request

import pytest

from tests.e2e.browser_support import HERE, ROOT
from tests.runs.test_export_web_escaping import HOSTILE_NAME, hostile_model_text

pytestmark = pytest.mark.slow

CMAP = "0:#000000, 0.5:#ff8800, 1:#ffffff"
CLI = [sys.executable, "-m", "morphogen.cli.main"]
ENV = {**os.environ, "JAX_PLATFORMS": "cpu"}


def _cli(*args: str) -> None:
    r = subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=300, env=ENV,
                       cwd=ROOT)
    assert r.returncode == 0, r.stderr


def _open(page, tmp_path) -> dict:
    out = tmp_path / "seen.json"
    r = subprocess.run(["node", str(HERE / "hostile_page.mjs"), str(page), str(out)],
                       capture_output=True, text=True, timeout=300, cwd=HERE)
    assert r.returncode == 0, r.stderr
    return json.loads(out.read_text())


def _check(seen: dict) -> None:
    assert seen["pwned"] is None and seen["dialogs"] == []
    assert seen["images"] == 0 and seen["scripts"] == 3
    assert seen["title"] == seen["heading"] and seen["title"].startswith(HOSTILE_NAME + ": ")
    assert seen["started"] and seen["ready"], seen["error"] or seen["problems"]
    assert seen["problems"] == []
    assert seen["stepped"] == {"steps": 5, "finite": True}
    assert seen["sliders"] == ["constructor", "onerror", "Du", "Dv"]
    assert seen["about"].startswith(f"{HOSTILE_NAME} on 16 × 16")


@pytest.mark.usefixtures("browser_ready")
def test_hostile_model_file_and_run_json(tmp_path):
    model = tmp_path / "hostile.toml"
    model.write_text(hostile_model_text(), encoding="utf-8")
    flags = ["--size", "16x16", "--scheme", "euler", "--seed", "1", "--cmap", CMAP]
    _cli("export-web", str(model), *flags, "--out", str(tmp_path / "model.html"))
    _check(_open(tmp_path / "model.html", tmp_path))
    _cli("simulate", str(model), *flags, "--steps", "2", "--quiet", "--out", str(tmp_path / "run"))
    model.unlink()  # the run file alone carries the model
    _cli("export-web", str(tmp_path / "run" / "run.json"), "--out", str(tmp_path / "run.html"))
    _check(_open(tmp_path / "run.html", tmp_path))


def _post(url: str, body: dict) -> dict:
    req = urllib.request.Request(url, json.dumps(body).encode(), method="POST",
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=120) as r:
        return json.loads(r.read())


def test_hostile_model_through_the_web_apps_page_download(server, tmp_path):
    server = server.rstrip("/")
    live = _post(f"{server}/api/live", {
        "model": {"equations": hostile_model_text()}, "size": 16,
        "scheme": "euler", "init": "noise"})
    _post(f"{server}/api/live/{live['id']}/view", {"cmap": CMAP})
    with urllib.request.urlopen(f"{server}/api/live/{live['id']}/page.html", timeout=120) as r:
        assert r.headers["Content-Type"].startswith("text/html")
        (tmp_path / "download.html").write_bytes(r.read())
    _check(_open(tmp_path / "download.html", tmp_path))
