"""Richard et al.'s fig. 9 (seed 001, §5.2.1) redone at their own range, start and step, with
the linear analysis' boundaries drawn over the tiles (docs/patterns.md).

    python docs/images/patterns/fig9.py [OUT_DIR]

Their method: "we go through every combination of f and k possible between 0 and 0.07 with a
0.005 step" (15 × 15 pairs) from "U = 0.8 everywhere, V = 0, and a square of V = 1, U = 0 from
0.45 N to 0.55 N in the middle". Gray-Scott with the library's diffusion coefficients (their
rule ``D_u / D_v = 2``), on 64², Δt = 0.5 (at Δt = 1 the tiles at small k end in a grid-scale
checkerboard) for t = 5000, every tile classified (`morphogen atlas --classify`) and the
saddle-node, Hopf and Turing boundaries of the homogeneous states drawn over them
(`--analysis`). Writes ``richard-fig9-atlas.png`` and ``richard-fig9-analysis.png`` here and
prints the family counts and the analysis' summary.
"""

from __future__ import annotations

import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np

from morphogen.cli.main import main

HERE = Path(__file__).parent
N = 64
ARGS = ["--x", "k=0:0.07:15", "--y", "F=0:0.07:15", "--size", f"{N}x{N}", "--dt", "0.5",
        "--steps", "10000", "--classify", "--analysis", "--quiet"]


def richard_start(path: Path, n: int = N) -> Path:
    """Their initial arrays: ``U = 0.8``, ``V = 0``, and ``U = 0``, ``V = 1`` on the central
    square ``int(0.45 n) <= i, j < int(0.55 n)``."""
    u = np.full((n, n), 0.8)
    v = np.zeros((n, n))
    inner = slice(int(0.45 * n), int(0.55 * n))
    u[inner, inner], v[inner, inner] = 0.0, 1.0
    np.savez(path, u=u, v=v)
    return path


def run(out: Path) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        start = richard_start(Path(tmp) / "start.npz")
        work = Path(tmp) / "atlas"
        code = main(["atlas", "gray-scott", *ARGS, "--init", "npz", "--init-opt",
                     f"path={start}", "--out", str(work)])
        if code:
            raise SystemExit(code)
        shutil.copy(work / "atlas.png", out / "richard-fig9-atlas.png")
        shutil.copy(work / "analysis.png", out / "richard-fig9-analysis.png")
        summary = json.loads((work / "atlas.json").read_text())
    return {"families": summary["families"], "analysis": summary["analysis"],
            "wall_time_s": summary["wall_time_s"]}


if __name__ == "__main__":
    print(json.dumps(run(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE), indent=1))
