"""Regenerate the pictures of docs/meshes.md.

    .venv/bin/python examples/mesh_gallery.py [OUT_DIR]

Writes the generated shapes with their named vertex sets, and runs the Mimulus and Kohleria
pipelines (about a minute each on 2 CPU cores), into ``docs/images/meshes/`` by default.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np

from morphogen.flowers import corolla, petal, tube
from morphogen.flowers.pipeline import run_pipeline
from morphogen.render.colour import colourise
from morphogen.render.images import write_png
from morphogen.render.mesh import render_mesh

HERE = Path(__file__).resolve().parent
SET_COLOURS = {"margin": (200, 30, 40), "base": (40, 40, 200), "throat": (40, 40, 200),
               "midline": (255, 255, 255)}


def shapes(out: Path) -> None:
    for name, mesh, key, view in [
        ("petal", petal(edge=0.02), "s", "top"),
        ("corolla", corolla(petals=5, edge=0.02, eye=0.1), "r", "oblique"),
        ("tube", tube(lobes=5, edge=0.02, lobe_scales=[0.75, 0.75, 1.1, 1.3, 1.1]), "s",
         "oblique"),
    ]:
        colours = colourise(mesh.fields[key], "viridis")
        for field, rgb in SET_COLOURS.items():
            if field in mesh.fields:
                colours[mesh.fields[field] > 0.5] = rgb
        image = render_mesh(mesh.vertices, mesh.faces, colours, view=view, size=(560, 560))
        write_png(out / f"shape-{name}.png", image)
        print(name, mesh.n_vertices, "vertices")


def pipelines(out: Path, work: Path) -> None:
    for name in ("mimulus", "kohleria"):
        result = work / name
        mesh = run_pipeline(HERE / f"{name}-mesh-pipeline.toml", result)
        for stage in sorted(result.glob("0*")):
            if (stage / "out.png").is_file():
                shutil.copyfile(stage / "out.png", out / f"{name}-{stage.name[3:]}.png")
        print(name, mesh.n_vertices, "vertices")
    mim = run_pipeline(HERE / "mimulus-mesh-pipeline.toml", work / "mimulus", resume=True)
    region = colourise(np.asarray(mim.fields["rho_a0"]), "#ffd54a,#8b5a2b")
    write_png(out / "mimulus-prepattern.png",
              render_mesh(mim.vertices, mim.faces, region, view=(62, -90), size=(640, 640)))


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "docs/images/meshes"
    target.mkdir(parents=True, exist_ok=True)
    shapes(target)
    pipelines(target, Path("out/mesh-gallery"))
