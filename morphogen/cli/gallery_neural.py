"""``morphogen gallery neural``: every shipped neural RD rule on the plane, a mesh and in 3D.

For each rule of :mod:`morphogen.models.neural_library` (seed 002, figs. 2, 5 and 6 side by
side) ``DIR/NAME/`` receives

- ``target.png``: the synthetic target the rule was trained on;
- ``seed_K.png``: the rule grown from its own seed state (``--init blobs``, seed ``K``) on a
  periodic ``size x size`` grid for ``steps`` steps (9-point stencil, ``dt = 1``, the training
  update);
- ``mesh.png``: the rule on a five-petal corolla (:func:`morphogen.flowers.shapes.corolla`,
  scaled so its edges are about one unit), from the mesh seed state, for ``mesh_time`` time
  units at 80 % of the mesh's diffusion stability limit, rendered obliquely;
- ``volume.png``: the rule in a periodic ``D x S x S`` volume (7-point Laplacian, ``dt = 0.5``)
  after ``volume_steps`` steps: four z-slices;
- ``row.png``: the six pictures side by side;

and ``DIR/index.html`` shows the rows, each captioned with the rule's line of the confusion
table (:mod:`morphogen.learn.confusion`: the texture loss of the plane runs against every
target), which is also written as ``DIR/confusion.md`` and ``DIR/confusion.json``.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morphogen.errors import MorphogenError


@dataclass(frozen=True)
class NeuralGallery:
    """Sizes of the gallery's runs (the defaults are the figures of docs/neural-rd.md)."""

    size: int = 64
    steps: int = 5000
    seeds: int = 3
    mesh_edge: float = 0.02
    mesh_time: float = 2000.0
    volume: tuple[int, int, int] = (16, 48, 48)
    volume_steps: int = 3000
    tile: int = 256


def _resize(img: np.ndarray, side: int) -> np.ndarray:
    """Nearest-neighbour resampling of ``(H, W, 3)`` to ``(side, side, 3)``."""
    h, w = img.shape[:2]
    ys = (np.arange(side) * h // side).clip(0, h - 1)
    xs = (np.arange(side) * w // side).clip(0, w - 1)
    return img[ys][:, xs]


def _rgb(state: np.ndarray) -> np.ndarray:
    from morphogen.learn.textures import to_uint8
    from morphogen.models.neural import rgb_channels

    return to_uint8(np.clip(rgb_channels(np.asarray(state)), 0.0, 1.0))


def _grow(model, domain, steps: int, seed: int, dt: float) -> np.ndarray:
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import simulate

    p = dict(model.params)
    u0 = make_initial("blobs", model, domain, p, seed=seed)
    return np.asarray(simulate(model, domain, u0, p, steps=steps, dt=dt).state)


def mesh_picture(model, cfg: NeuralGallery, seed: int = 4) -> np.ndarray:
    """The rule on a corolla with edges of about one unit, rendered ``tile x tile``."""
    from morphogen.domains.mesh import Mesh
    from morphogen.flowers.shapes import corolla
    from morphogen.render.mesh import render_mesh

    flower = corolla(5, 1.0, edge=cfg.mesh_edge)
    mesh = Mesh(flower.vertices / cfg.mesh_edge, flower.faces)  # edges about one unit
    dt = min(1.0, 0.8 * 2.0 / (mesh.spectral_radius() * 0.25))
    state = _grow(model, mesh, max(1, int(round(cfg.mesh_time / dt))), seed, dt)
    colours = np.clip(state[:3].T + 0.5, 0.0, 1.0)
    return render_mesh(mesh.vertices, mesh.faces, colours, view="oblique",
                       size=(cfg.tile, cfg.tile), shade=0.3)


def volume_picture(model, cfg: NeuralGallery, seed: int = 3) -> np.ndarray:
    """Four z-slices of the rule grown in a periodic volume, as a 2 x 2 ``tile x tile``
    picture."""
    from morphogen.domains.grid import Grid

    state = _grow(model, Grid(cfg.volume, stencil=7), cfg.volume_steps, seed, 0.5)
    zs = np.linspace(0, cfg.volume[0] - 1, 4).round().astype(int)
    half = cfg.tile // 2
    s = [_resize(_rgb(state[:, z]), half) for z in zs]
    out = np.full((cfg.tile, cfg.tile, 3), 255, np.uint8)
    out[:half, :half], out[:half, half:2 * half] = s[0], s[1]
    out[half:2 * half, :half], out[half:2 * half, half:2 * half] = s[2], s[3]
    return out


def rule_row(name: str, source: str, out: Path, cfg: NeuralGallery, log=print) -> np.ndarray:
    """Run rule ``name`` (model ``source``) into ``out/NAME/``; returns its plane images
    ``(seeds, size, size, 3)`` in ``[0, 1]`` for the confusion table."""
    from morphogen.learn.confusion import grow_rule
    from morphogen.learn.textures import synthetic_texture, to_uint8
    from morphogen.learn.train_library import TARGET_SIZE
    from morphogen.models.registry import load_model
    from morphogen.render import write_png
    from morphogen.render.mosaic import mosaic

    folder = out / name
    model = load_model(source)
    start = time.perf_counter()
    target = to_uint8(synthetic_texture(name, TARGET_SIZE))
    write_png(folder / "target.png", target)
    tiles, labels = [_resize(target, cfg.tile)], [f"{name}: target"]
    plane = grow_rule(model, cfg.size, cfg.steps, range(cfg.seeds))
    for k, img in enumerate(plane):
        write_png(folder / f"seed_{k}.png", to_uint8(img))
        tiles.append(_resize(to_uint8(img), cfg.tile))
        labels.append(f"seed {k}, {cfg.steps} steps")
    mesh = mesh_picture(model, cfg)
    write_png(folder / "mesh.png", mesh)
    tiles.append(_resize(mesh, cfg.tile))
    labels.append(f"corolla, t = {cfg.mesh_time:g}")
    volume = volume_picture(model, cfg)
    write_png(folder / "volume.png", volume)
    tiles.append(volume)
    labels.append(f"3D {'x'.join(map(str, cfg.volume))}, 4 z-slices")
    write_png(folder / "row.png", mosaic(np.stack(tiles), len(tiles), labels=labels))
    log(f"  {name}: done in {time.perf_counter() - start:.0f} s")
    return plane


def run_neural_gallery(out: str | Path, cfg: NeuralGallery = NeuralGallery(), *,
                       only: list[str] | None = None, rules: dict[str, str] | None = None,
                       log=print) -> Path:
    """Run the selected rules into ``out/NAME/``, write the confusion table and
    ``out/index.html``; returns the page. ``rules`` maps a library name to another model
    (a candidate rule file) to show instead of the shipped one."""
    from morphogen.learn.confusion import library_targets, report
    from morphogen.learn.train_library import TARGETS
    from morphogen.models.neural_library import rule_names
    from morphogen.render.gallery import write_gallery
    from morphogen.util.io import ensure_writable_dir, write_atomic

    shipped = [n for n in rule_names() if n in TARGETS]
    unknown = [n for n in (only or []) if n not in shipped]
    if unknown:
        raise MorphogenError(f"unknown neural rule {', '.join(unknown)}; choose from "
                             f"{', '.join(shipped)}")
    names = only or shipped
    sources = {n: (rules or {}).get(n, f"neural:{n}") for n in names}
    out_dir = ensure_writable_dir(out)
    images = {}
    for i, name in enumerate(names, 1):
        log(f"[{i}/{len(names)}] {sources[name]}")
        images[name] = rule_row(name, sources[name], out_dir, cfg, log)
    result = report(images, library_targets())
    table, shape = result["table"], result["shape"]
    data = {"table": table.to_dict(), "shape": shape.to_dict(), "dots": result.get("dots"),
            "rules": sources,
            "size": cfg.size, "steps": cfg.steps, "seeds": cfg.seeds}
    text = json.dumps(data, indent=2) + "\n"
    write_atomic(out_dir / "confusion.json", lambda fh: fh.write(text.encode()))
    md = (result["markdown"] + "\n\nBy shape (luminance ranks, the palette removed):\n\n"
          + result["shape_markdown"] + "\n")
    write_atomic(out_dir / "confusion.md", lambda fh: fh.write(md.encode()))
    items = []
    for name in names:
        row = table.mean[table.rules.index(name)]
        own = row[table.targets.index(name)]
        margin = table.margin(name)
        caption = (f"{sources[name]}: target, {cfg.seeds} seeds after {cfg.steps} steps on "
                   f"{cfg.size}², a corolla (fig. 5), a volume (fig. 6). Texture loss against "
                   f"its own target {own:.3g}; nearest target {table.nearest(name)}"
                   + ("" if margin is None else f" (margin {margin:+.0%})")
                   + f"; by shape nearest {shape.nearest(name)}")
        if name == "dots" and "dots" in result:
            d = result["dots"]
            caption += (f"; dot density {d['density_ratio']:.0%} of the target's, "
                        f"{d['elongated']:.0%} elongated")
        items.append((f"{name}/row.png", caption))
    return write_gallery(
        out_dir, "Neural RD: the shipped rules (Mordvintsev et al., figs. 2, 5, 6)", items,
        intro=f"{len(names)} rules; the confusion tables of the texture loss, by colour and by "
        "shape (palette removed), are in confusion.md (rows: rules grown, columns: targets).",
        wide=[rel for rel, _ in items])
