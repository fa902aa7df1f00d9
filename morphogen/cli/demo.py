"""The demo gallery (``morphogen demo``, ``make demo``): every library model, a growing pattern,
an (F, k) atlas.

:func:`build_gallery` writes one PNG per library model at its default parameters, a GIF of
Gray-Scott growing from blobs, the Gray-Scott (F, k) atlas (compare Richard et al. fig. 9 and
Pearson's map), and ``index.html`` showing them all.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate
from morphogen.models.library import LIBRARY, get_model
from morphogen.render import (
    atlas_image,
    colour_limits,
    state_image,
    write_animation,
    write_gallery,
    write_png,
)
from morphogen.runs.atlas import Axis, compute_atlas
from morphogen.runs.outputs import picture
from morphogen.runs.policy import resolve_run
from morphogen.util.io import ensure_writable_dir

CMAPS = ("magma", "viridis", "inferno", "cividis", "plasma")


def model_gallery(out: Path, size: int) -> list[tuple[str, str]]:
    """One picture per library model at its defaults; returns (file, caption) pairs."""
    items = []
    for i, name in enumerate(LIBRARY):
        model = get_model(name)
        grid = Grid((size, size))
        p = model.parameters()
        plan = resolve_run(model, grid, p)
        dt, steps = plan.dt, plan.steps
        u0 = make_initial(model.init, model, grid, p, seed=i)
        start = time.perf_counter()
        sol = simulate(model, grid, u0, p, steps=steps, dt=dt)
        field = sol.state[model.species_index(model.display_species)]
        cmap = CMAPS[i % len(CMAPS)]
        write_png(out / f"{name}.png", picture(field, cmap, None, None))
        print(f"  {name}: {steps} steps in {time.perf_counter() - start:.1f} s", flush=True)
        items.append((f"{name}.png", f"{name} — {model.description} ({model.reference})"))
    return items


def growth_animation(out: Path, size: int) -> tuple[str, str]:
    """Gray-Scott ('worms' is slow to fill; the default spots/stripes grow visibly)."""
    model = get_model("gray-scott")
    grid = Grid((size, size))
    p = model.parameters(preset="mazes")
    u0 = make_initial("blobs", model, grid, p, seed=7, count=6)
    sol = simulate(model, grid, u0, p, steps=8000, dt=1.0, every=100)
    frames = sol.snapshots[:, 1]
    lo, hi = colour_limits(frames)
    rgb = np.stack([state_image(f, "magma", lo, hi) for f in frames])
    write_animation(out / "gray-scott-growth.gif", rgb, fps=15)
    return "gray-scott-growth.gif", "Gray-Scott 'mazes' (F=0.029, k=0.057) growing from blobs"


def fk_atlas(out: Path, tiles: int, size: int) -> tuple[str, str]:
    """The Gray-Scott (F, k) map: tiles x tiles runs in one batched program."""
    model = get_model("gray-scott")
    x = Axis("k", np.linspace(0.045, 0.07, tiles))
    y = Axis("F", np.linspace(0.01, 0.08, tiles))
    start = time.perf_counter()
    atlas = compute_atlas(model, Grid((size, size)), x, y, steps=8000, dt=1.0, init="blobs",
                          seed=1)
    fields = atlas.states[:, :, 1]
    lo, hi = colour_limits(fields)
    rgb = np.stack([[state_image(f, "magma", lo, hi) for f in row] for row in fields])
    image = atlas_image(rgb, "k", x.values, "F", y.values,
                        title="Gray-Scott v after 8000 steps (one colour scale)")
    write_png(out / "gray-scott-atlas.png", image)
    print(f"  atlas: {tiles}x{tiles} runs of {size}² in {time.perf_counter() - start:.1f} s")
    return "gray-scott-atlas.png", (
        f"Gray-Scott (F, k) atlas, {tiles}×{tiles} runs in one batched simulation "
        "(compare Richard et al. fig. 9, Pearson's classification)")


def build_gallery(out: str, size: int = 192, tiles: int = 16) -> Path:
    """Write the gallery into ``out``: model pictures of ``size``², the growth animation, a
    ``tiles`` x ``tiles`` atlas and ``index.html``; returns the folder."""
    folder = ensure_writable_dir(out)
    start = time.perf_counter()
    print("library models:", flush=True)
    items = model_gallery(folder, size)
    print("growth animation:", flush=True)
    items.insert(0, growth_animation(folder, size))
    print("atlas:", flush=True)
    items.insert(0, fk_atlas(folder, tiles, 64))
    write_gallery(folder, "morphogen demo gallery", items, wide=("gray-scott-atlas.png",))
    print(f"wrote {folder}/index.html in {time.perf_counter() - start:.0f} s")
    return folder
