"""Fixtures of the browser tests: a browser (``ensure_browser.sh``) and ``morphogen serve`` on
127.0.0.1 with its own run archive and examples folder, one per test module."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time

import pytest

from tests.e2e.browser_support import HERE, MEASURE, OUT, ROOT, WARM_UP
from tests.web_support import TINY_PETAL

# The Mesh page's case studies in the suite: the tiny petal pipeline and an endless one to
# cancel; MORPHOGEN_E2E_EXAMPLES serves another examples folder.


@pytest.fixture(scope="module")
def browser_ready():
    if shutil.which("sh") is None:
        pytest.skip("no shell to run ensure_browser.sh")
    r = subprocess.run(["sh", str(HERE / "ensure_browser.sh")], capture_output=True, text=True,
                       timeout=900)
    if r.returncode != 0:
        pytest.skip(f"no browser for the end-to-end tests: {r.stdout.strip() or r.stderr.strip()}")
    OUT.mkdir(parents=True, exist_ok=True)


@pytest.fixture(scope="module")
def server(browser_ready, tmp_path_factory):
    """``morphogen serve`` on 127.0.0.1 and a free port, with its own run archive."""
    archive = tmp_path_factory.mktemp("archive") / "index.sqlite"
    examples = os.environ.get("MORPHOGEN_E2E_EXAMPLES")
    if not examples:
        examples = tmp_path_factory.mktemp("examples")
        (examples / "flowers").mkdir()
        (examples / "flowers" / "tiny.toml").write_text(TINY_PETAL.replace("STEPS", "500"))
        (examples / "flowers" / "endless.toml").write_text(
            TINY_PETAL.replace("STEPS", "1000000").replace("§4.2", "§4.9"))
    env = {**os.environ, "JAX_PLATFORMS": "cpu", "PYTHONUNBUFFERED": "1"}
    if MEASURE:
        env["MORPHOGEN_COMPILE_CACHE"] = str(tmp_path_factory.mktemp("compile-cache"))
    log_path = OUT / "server.log"
    with open(log_path, "w") as log:
        proc = subprocess.Popen(
            [sys.executable, "-m", "morphogen.cli.main", "serve", "--port", "0",
             "--archive", str(archive), "--examples", str(examples), *WARM_UP],
            stdout=log, stderr=subprocess.STDOUT, text=True, env=env, cwd=ROOT,
        )
    try:
        url = None
        end = time.monotonic() + 120
        while url is None and time.monotonic() < end and proc.poll() is None:
            for word in log_path.read_text().split():
                if word.startswith("http://127.0.0.1:"):
                    url = word
            time.sleep(0.1)
        if url is None:
            pytest.fail(f"the server did not start: {log_path.read_text()}")
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
