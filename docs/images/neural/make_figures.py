"""Make the figures of docs/neural-rd.md from trained runs.

    python docs/images/neural/make_figures.py RUN_DIR [RUN_DIR ...]

Each RUN_DIR is a ``morphogen train`` output directory; its name (``stripes``, ``dots``) names
the figures. For every run: the model file, the target, runs from four seeds, the stages of one
run, the loss curve and last sample image, the model at two grid resolutions, on a spatially
varying ``r`` (seed 002 fig. 4), in a 3D volume (fig. 6) and on a flower mesh (fig. 5).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import jax
import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.simulate import simulate
from morphogen.learn.seeds import seed_state
from morphogen.learn.textures import state_to_rgb, to_uint8
from morphogen.models.neural import load_neural_model
from morphogen.render import upscale, write_png  # noqa: E402
from morphogen.render.mosaic import mosaic

HERE = Path(__file__).parent


def rgb(state: np.ndarray) -> np.ndarray:
    """uint8 RGB of a state ``(n, H, W)``."""
    return to_uint8(np.asarray(state_to_rgb(np.asarray(state))))


def grow(model, shape, steps, seed, dt=1.0, params=None, stencil=None):
    grid = Grid(shape, stencil=stencil or (9 if len(shape) == 2 else 7))
    u0 = np.asarray(seed_state(jax.random.PRNGKey(seed), len(model.species), shape))
    p = {**model.params, **(params or {})}
    return simulate(model, grid, u0, p, steps=steps, dt=dt).state


def seeds_figure(name, model, target):
    """Four seeds on 96^2: after 300 steps (top row) and 2000 steps (bottom row)."""
    size = 96
    reps = -(-size // target.shape[0])
    tile = np.tile(target, (reps, reps, 1))[:size, :size]
    tiles, labels = [], []
    for steps in (300, 2000):
        tiles += [tile, *(rgb(grow(model, (size, size), steps, seed)) for seed in range(4))]
        labels += ["target", *(f"seed {s}, {steps} steps" for s in range(4))]
    write_png(HERE / f"{name}_seeds.png", mosaic(upscale(np.stack(tiles), 2), 5, labels=labels))


def stages_figure(name, model):
    """Seed 002 fig. 3: one run from seed 0 after 50, 200, 1000 and 5000 steps."""
    steps = (50, 200, 1000, 5000)
    tiles = np.stack([rgb(grow(model, (96, 96), n, 0)) for n in steps])
    labels = [f"step {n}" for n in steps]
    write_png(HERE / f"{name}_stages.png", mosaic(upscale(tiles, 2), 4, labels=labels))


def resolution_figure(name, model):
    """r = 1 on 128^2 and r = 1/4 on 256^2 (a twice finer grid of the same plane)."""
    coarse = rgb(grow(model, (128, 128), 2000, 1))
    fine = rgb(grow(model, (256, 256), 8000, 1, params={"r": 0.25}))
    tiles = np.stack([upscale(coarse, 2), fine])
    labels = ["128x128, r = 1 (shown 2x)", "256x256, r = 1/4"]
    write_png(HERE / f"{name}_resolution.png", mosaic(tiles, 2, labels=labels))


def varying_r_figure(name, model):
    """Seed 002 fig. 4: r = 1 at the centre, decreasing to 1/9 at the edge."""
    n = 192
    y, x = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    r = np.maximum(1.0 / (1.0 + 8.0 * (x**2 + y**2)), 1.0 / 9.0).astype(np.float32)
    state = grow(model, (n, n), 6000, 2, params={"r": r})
    write_png(HERE / f"{name}_varying_r.png", upscale(rgb(state), 2))


def volume_figure(name, model):
    """Seed 002 fig. 6: the 2D-trained rule in a 3D volume (7-point Laplacian), z-slices."""
    shape = (32, 64, 64)
    state = grow(model, shape, 4000, 3, dt=0.5)
    zs = np.linspace(0, shape[0] - 1, 8).round().astype(int)
    tiles = np.stack([rgb(state[:, z]) for z in zs])
    labels = [f"z = {z}" for z in zs]
    write_png(HERE / f"{name}_volume.png", mosaic(upscale(tiles, 2), 4, labels=labels))


def mesh_figure(name, model):
    """Seed 002 fig. 5: the rule on a flower mesh, diffusing along mesh edges."""
    from morphogen.domains.mesh import Mesh
    from morphogen.flowers.shapes import corolla
    from morphogen.learn.seeds import BLOB_SIGMA
    from morphogen.render.mesh import render_mesh

    flower = corolla(5, 1.0, edge=0.02)
    mesh = Mesh(flower.vertices * 50.0, flower.faces)  # edges about one unit, like grid cells
    rng = np.random.default_rng(4)
    centres = mesh.vertices[rng.choice(mesh.n_vertices, 30, replace=False)]
    d2 = ((mesh.vertices[:, None, :] - centres[None]) ** 2).sum(-1)
    field = np.exp(-d2 / (2 * BLOB_SIGMA**2)).sum(1)
    u0 = np.broadcast_to(field, (len(model.species), mesh.n_vertices)).astype(np.float32)
    p = dict(model.params)
    dt = min(1.0, 0.9 * 2.0 / (mesh.spectral_radius() * 0.25))
    state = simulate(model, mesh, u0, p, steps=int(2000 / dt), dt=dt).state
    colours = np.clip(np.asarray(state[:3]).T + 0.5, 0, 1)
    image = render_mesh(mesh.vertices, mesh.faces, colours, view="oblique", size=(640, 640),
                        shade=0.3)
    write_png(HERE / f"{name}_mesh.png", image)


def main(runs: list[str]) -> None:
    for run in map(Path, runs):
        name = run.name
        model_path = HERE / f"{name}.npz"
        shutil.copyfile(run / "model.npz", model_path)
        shutil.copyfile(run / "loss.png", HERE / f"{name}_loss.png")
        model = load_neural_model(model_path)
        with np.load(run / "checkpoint.npz", allow_pickle=False) as data:
            target = to_uint8(data["target"])
        write_png(HERE / f"{name}_target.png", target)  # 64x64: usable as --target
        shutil.copyfile(sorted((run / "samples").glob("iter_*.png"))[-1],
                        HERE / f"{name}_samples.png")
        for figure in (seeds_figure, stages_figure, resolution_figure, varying_r_figure,
                       volume_figure, mesh_figure):
            print(f"{name}: {figure.__name__}", flush=True)
            if figure is seeds_figure:
                figure(name, model, target)
            else:
                figure(name, model)


if __name__ == "__main__":
    main(sys.argv[1:])
