"""The browser tests' driver: :func:`scenario` runs one scenario of ``browser.mjs`` in headless
Chromium against the ``server`` fixture (``conftest.py``) and returns what it saw.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from tests.paths import ROOT

HERE = Path(__file__).parent
OUT = Path(os.environ.get("MORPHOGEN_E2E_OUT", ROOT / "out" / "e2e"))
# The speed figures of docs/web.md come from `MORPHOGEN_E2E_MEASURE=1 pytest tests/e2e -k explore`,
# against a server that warms its models up as `morphogen serve` does, with an empty persistent
# compilation cache of its own (so a first switch compiles); the suite skips all three.
MEASURE = bool(os.environ.get("MORPHOGEN_E2E_MEASURE"))
WARM_UP = [] if MEASURE else ["--no-warm-up"]


def scenario(server: str, name: str) -> dict:
    """Run one scenario of browser.mjs; its observations as a dict."""
    r = subprocess.run(["node", str(HERE / "browser.mjs"), name, server, str(OUT)],
                       capture_output=True, text=True, timeout=900 if MEASURE else 300, cwd=HERE)
    assert r.returncode == 0, f"{name}: {r.stderr.strip()} (screenshot {OUT}/{name}-failed.png)"
    data = json.loads((OUT / f"{name}.json").read_text())
    assert not data["problems"], data["problems"]
    return data
