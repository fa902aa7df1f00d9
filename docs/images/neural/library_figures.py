"""Figures of docs/neural-rd.md for the shipped rules (``neural:NAME``, seed 002 figs. 2-6).

    python docs/images/neural/library_figures.py [FIGURE ...]

Figures (all start from the models' own seed states, ``--init blobs`` with their spacing and
sigma, exactly as ``morphogen simulate neural:NAME`` does):

- ``targets``: the six synthetic targets;
- ``library``: every rule's target and three seeds after 5 000 steps on 64 x 64 (fig. 2);
- ``stages``: one run of ``neural:stripes`` and one of ``neural:dots`` after 50, 100, 1 000
  and 10 000 steps on 96 x 96 (fig. 3);
- ``varying_r``: ``neural:dots`` on 128 x 128 with ``r`` falling from 1 at the centre to 1/9
  at the edge (fig. 4);
- ``mesh``: ``neural:dots`` on a five-petal flower mesh (fig. 5);
- ``volume``: ``neural:checker`` in a 16 x 48 x 48 volume after 3 000 steps of 0.5, z-slices
  (fig. 6).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.learn.textures import synthetic_texture, to_uint8
from morphogen.learn.train_library import TARGET_SIZE, TARGETS
from morphogen.models.library import get_model
from morphogen.models.neural import rgb_channels
from morphogen.render import upscale, write_png
from morphogen.render.mosaic import mosaic

HERE = Path(__file__).parent


def rgb(state: np.ndarray) -> np.ndarray:
    """uint8 RGB of a state ``(n, *spatial)``."""
    return to_uint8(np.clip(rgb_channels(np.asarray(state)), 0.0, 1.0))


def grow(model, domain, steps, seed, dt=1.0, params=None):
    p = {**model.params, **(params or {})}
    u0 = make_initial("blobs", model, domain, p, seed=seed)
    return simulate(model, domain, u0, p, steps=steps, dt=dt).state


def targets_figure():
    tiles = np.stack([to_uint8(synthetic_texture(n, TARGET_SIZE)) for n in TARGETS])
    write_png(HERE / "library_targets.png",
              mosaic(upscale(tiles, 2), len(TARGETS), labels=list(TARGETS)))


def library_figure():
    size, steps = 64, 5000
    tiles, labels = [], []
    for name in TARGETS:
        model = get_model(f"neural:{name}")
        tiles.append(to_uint8(synthetic_texture(name, TARGET_SIZE)))
        labels.append(f"{name}: target")
        for seed in range(3):
            tiles.append(rgb(grow(model, Grid((size, size), stencil=9), steps, seed)))
            labels.append(f"seed {seed}, {steps} steps")
    write_png(HERE / "library.png", mosaic(upscale(np.stack(tiles), 2), 4, labels=labels))


def stages_figure():
    steps = (50, 100, 1000, 10000)
    tiles, labels = [], []
    for name in ("stripes", "dots"):
        model = get_model(f"neural:{name}")
        grid = Grid((96, 96), stencil=9)
        p = dict(model.params)
        u = make_initial("blobs", model, grid, p, seed=0)
        done = 0
        for n in steps:
            u = simulate(model, grid, u, p, steps=n - done, dt=1.0).state
            done = n
            tiles.append(rgb(u))
            labels.append(f"{name}, step {n}")
    write_png(HERE / "library_stages.png", mosaic(upscale(np.stack(tiles), 2), 4, labels=labels))


def varying_r_figure():
    n = 128
    y, x = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    r = np.maximum(1.0 / (1.0 + 8.0 * (x**2 + y**2)), 1.0 / 9.0).astype(np.float32)
    model = get_model("neural:dots")
    state = grow(model, Grid((n, n), stencil=9), 5000, 2, params={"r": r})
    write_png(HERE / "library_varying_r.png", upscale(rgb(state), 3))


def mesh_figure():
    from morphogen.domains.mesh import Mesh
    from morphogen.flowers.shapes import corolla
    from morphogen.render.mesh import render_mesh

    flower = corolla(5, 1.0, edge=0.02)
    mesh = Mesh(flower.vertices * 50.0, flower.faces)  # edges about one unit, like grid cells
    model = get_model("neural:dots")
    dt = min(1.0, 0.8 * 2.0 / (mesh.spectral_radius() * 0.25))  # inside the reaction-aware limit
    state = grow(model, mesh, int(2000 / dt), 4, dt=dt)
    colours = np.clip(np.asarray(state[:3]).T + 0.5, 0, 1)
    image = render_mesh(mesh.vertices, mesh.faces, colours, view="oblique", size=(640, 640),
                        shade=0.3)
    write_png(HERE / "library_mesh.png", image)


def volume_figure():
    shape = (16, 48, 48)
    model = get_model("neural:checker")
    state = grow(model, Grid(shape, stencil=7), 3000, 3, dt=0.5)
    zs = np.linspace(0, shape[0] - 1, 4).round().astype(int)
    tiles = np.stack([rgb(state[:, z]) for z in zs])
    labels = [f"z = {z}" for z in zs]
    write_png(HERE / "library_volume.png", mosaic(upscale(tiles, 3), 4, labels=labels))


FIGURES = {"targets": targets_figure, "library": library_figure, "stages": stages_figure,
           "varying_r": varying_r_figure, "mesh": mesh_figure, "volume": volume_figure}


def main(names: list[str]) -> None:
    for name in names or FIGURES:
        start = time.perf_counter()
        FIGURES[name]()
        print(f"{name}: {time.perf_counter() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
