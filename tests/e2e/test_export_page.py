"""Pages written by `morphogen export-web`, run in headless Chromium (WebGL2 on ANGLE's
SwiftShader: no GPU here) and compared with `morphogen simulate` for the same flags.

``webpage.mjs`` opens the page at 390 x 844 with touch, steps it N times from its initial state,
reads the float texture back and writes it out; the comparison is made here.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.e2e.browser_support import HERE, OUT, ROOT

USER_MODEL = """# a model pasted by a user: FitzHugh-Nagumo-like, with a cubic and a division
name = "pasted-user-model"
species = ["u", "v"]
display = "u"
dt = 0.02
t_end = 100.0
init = "noise"

[parameters]
a = 0.7
b = 0.8
eps = 0.08
Du = 1.0
Dv = 12.0

[equations]
u = "u - u**3/3 - v + Du*lap(u)"
v = "eps*(u + a - b*v) / (1 + 0.1*u*u) + Dv*lap(v)"

[initial]
u = -1.2
v = -0.62
"""


@pytest.mark.parametrize("name,flags,steps", [
    ("gray-scott", ["--size", "64x48", "--seed", "3"], 300),
    ("gierer-meinhardt", ["--size", "48x48", "--stencil", "9", "--boundary", "neumann",
                          "--init", "noise", "--seed", "1"], 400),
    ("USER", ["--size", "40x40", "--boundary", "neumann", "--seed", "2"], 300),
])
@pytest.mark.usefixtures("browser_ready")
def test_exported_page_matches_simulate(tmp_path, name, flags, steps):
    """`morphogen export-web` writes one HTML page whose WebGL2 shader (generated from the
    model's own equations) reaches the state `morphogen simulate` reaches after the same
    steps, within float32 rounding; read back from the float texture in headless Chromium."""
    if name == "USER":
        (tmp_path / "user.toml").write_text(USER_MODEL)
        name = str(tmp_path / "user.toml")
    env = {**os.environ, "JAX_PLATFORMS": "cpu"}
    common = [*flags, "--scheme", "euler"]
    cli = [sys.executable, "-m", "morphogen.cli.main"]
    r = subprocess.run([*cli, "export-web", name, *common, "--out", str(tmp_path / "page.html")],
                       capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    r = subprocess.run([*cli, "simulate", name, *common, "--steps", str(steps), "--quiet",
                        "--out", str(tmp_path / "sim")],
                       capture_output=True, text=True, timeout=300, env=env, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    stem = Path(name).stem
    shot = OUT / f"export-{stem}.png"
    r = subprocess.run(["node", str(HERE / "webpage.mjs"), str(tmp_path / "page.html"),
                        str(steps), str(tmp_path / "page.json"), str(shot)],
                       capture_output=True, text=True, timeout=300, cwd=HERE)
    assert r.returncode == 0, r.stderr
    page = json.loads((tmp_path / "page.json").read_text())
    assert not page["problems"] and page["painted"]
    text = (tmp_path / "page.html").read_text()
    assert "http://" not in text and "https://" not in text  # nothing to fetch
    with np.load(tmp_path / "sim" / "state.npz") as sim:
        species = [k for k in sim.files if sim[k].ndim == 2]
        want = np.stack([sim[k] for k in species[:len(page["state"])]])
    got = np.asarray(page["state"], np.float32).reshape(want.shape)
    scale = max(1.0, float(np.abs(want).max()))
    np.testing.assert_allclose(got, want, rtol=0, atol=2e-4 * scale)
    (OUT / f"export-{stem}.txt").write_text(
        f"{stem}: {steps} steps, max |page - simulate| = {np.abs(got - want).max():.3g}; "
        f"{page['stepsPerS']:.0f} steps/s, first frame {page['firstFrameMs']:.0f} ms after "
        f"navigation, {page['renderer']} (load {os.getloadavg()[0]:.1f})\n")
