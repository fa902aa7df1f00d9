"""The confusion table of the texture loss, and the dot statistics of a dotted texture.

.. code-block:: text

    python -m morphogen.learn.confusion [--steps 5000] [--size 64] [--seeds 3]
        [--rule NAME=FILE ...] [--json FILE]

Each rule of the library (:mod:`morphogen.models.neural_library`) is grown from its own seed
state (``--init blobs``, as ``morphogen simulate neural:NAME`` does; 9-point stencil, ``dt = 1``,
the training update) on a ``size x size`` torus for ``steps`` steps from ``seeds`` seeds, and
the texture loss of the training (:func:`morphogen.learn.session.build_loss` with the ``cpu``
preset: random features, best of 36 orientations) of every grown image is measured against
**every** target of the library. Row ``r`` of the table is rule ``r``'s mean loss against each
target; the rule is *closest to its own target* when its diagonal entry is the row's smallest,
and its **margin** is how much larger the next smallest entry is (``min_other / own - 1``;
negative when another target is closer). A reference row per target holds the loss of the
target image itself, moved by :data:`REFERENCE_SHIFT`, against every target (its own entry is
the floor of a perfect copy).

:func:`blob_stats` counts the features of a two-colour texture (the ``dots``): every pixel is
given to the nearer of the target's two colours (:func:`two_colours`), the ink pixels are
grouped into 8-connected components on the torus, components under ``min_area`` cells are
ignored, and a component is *elongated* when the ratio of the standard deviations of its cells'
coordinates along its principal axes exceeds ``elongated`` (2 by default: a disc scores 1, two
touching discs about 2.3, an ellipse its axis ratio).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from morphogen.errors import MorphogenError

LUMA = np.array([0.2126, 0.7152, 0.0722])
"""Rec. 709 luminance weights."""

REFERENCE_SHIFT = (7, 11)
"""The reference rows judge each target moved by this many cells (periodically): the loss's
image pyramid averages 2^l x 2^l blocks, so a texture aligned with them (the 64 x 64 checker,
squares of 8 cells) scores 0.43 against its own rotated crops, and 0.05-0.10 moved by 1-4
cells."""


@dataclass(frozen=True)
class Confusion:
    """Texture losses of grown rules against targets.

    Attributes:
        rules: row names (the rule grown).
        targets: column names (the target judged against).
        losses: shape ``(rules, targets, seeds)``.
        references: shape ``(targets, targets)``: each target image (moved by
            :data:`REFERENCE_SHIFT`) against every target.
    """

    rules: tuple[str, ...]
    targets: tuple[str, ...]
    losses: np.ndarray
    references: np.ndarray

    @property
    def mean(self) -> np.ndarray:
        """Mean over seeds, ``(rules, targets)``."""
        return self.losses.mean(axis=-1)

    def margin(self, rule: str) -> float | None:
        """``min_other / own - 1`` of ``rule``'s row (positive: closest to its own target);
        ``None`` when the rule's own target is not a column."""
        if rule not in self.targets:
            return None
        row = self.mean[self.rules.index(rule)]
        j = self.targets.index(rule)
        other = np.delete(row, j)
        return float(other.min() / row[j] - 1.0) if other.size else None

    def nearest(self, rule: str) -> str:
        """The target ``rule``'s grown images are closest to on average."""
        return self.targets[int(np.argmin(self.mean[self.rules.index(rule)]))]

    def to_dict(self) -> dict:
        return {"rules": list(self.rules), "targets": list(self.targets),
                "losses": self.losses.tolist(), "references": self.references.tolist(),
                "margins": {r: self.margin(r) for r in self.rules}}

    def markdown(self) -> str:
        """The table: one row per rule (the row's smallest entry bold), its nearest target and
        margin, then the reference rows."""
        head = " | ".join(self.targets)
        lines = [f"| rule | {head} | nearest | margin |", "|" + "---|" * (len(self.targets) + 3)]
        for i, rule in enumerate(self.rules):
            row = self.mean[i]
            best = int(np.argmin(row))
            cells = [f"**{v:.3g}**" if j == best else f"{v:.3g}" for j, v in enumerate(row)]
            m = self.margin(rule)
            margin = "" if m is None else f"{m:+.0%}"
            lines.append(f"| `neural:{rule}` | {' | '.join(cells)} | {self.nearest(rule)} | "
                         f"{margin} |")
        for i, name in enumerate(self.targets):
            cells = " | ".join(f"{v:.3g}" for v in self.references[i])
            lines.append(f"| target {name} | {cells} | | |")
        return "\n".join(lines)


def shape_only(rgb: np.ndarray) -> np.ndarray:
    """An image reduced to its shape: luminance, rank-normalised to a uniform grey ramp over
    ``[0, 1]`` (each pixel its quantile, ties sharing one), as three equal channels. Palette,
    contrast and any monotone change of brightness are gone; where light and dark fall stays.
    ``(..., H, W, 3)`` -> the same shape."""
    from scipy.stats import rankdata

    lum = np.asarray(rgb, np.float64) @ LUMA
    flat = lum.reshape(*lum.shape[:-2], -1)
    grey = (rankdata(flat, method="average", axis=-1) - 1.0) / max(flat.shape[-1] - 1, 1)
    return np.repeat(grey.reshape(lum.shape)[..., None], 3, axis=-1).astype(np.float32)


def confusion_table(images: Mapping[str, np.ndarray], targets: Mapping[str, np.ndarray],
                    n_rot: int = 36, shape: bool = False) -> Confusion:
    """The losses of ``images[rule]`` (``(seeds, H, W, 3)`` in ``[0, 1]``) against every target
    (``(S, S, 3)``), with the random-feature texture loss of the library's training; with
    ``shape``, of both reduced to their shape first (:func:`shape_only`), so that a texture is
    judged by where its light and dark fall, not by its colours."""
    if shape:
        images = {k: shape_only(v) for k, v in images.items()}
        targets = {k: shape_only(v) for k, v in targets.items()}
    import jax
    import jax.numpy as jnp

    from morphogen.learn.session import build_loss
    from morphogen.learn.train import preset

    rules, names = tuple(images), tuple(targets)
    if not rules or not names:
        raise MorphogenError("a confusion table needs at least one rule and one target")
    stacks = [np.asarray(images[r], np.float32) for r in rules]
    counts = {s.shape[0] for s in stacks}
    if len(counts) != 1 or any(s.ndim != 4 or s.shape[-1] != 3 for s in stacks):
        raise MorphogenError("every rule needs the same number of (H, W, 3) images")
    refs = np.stack([np.roll(np.asarray(targets[n], np.float32), REFERENCE_SHIFT, axis=(0, 1))
                     for n in names])
    k = counts.pop()
    n_images = len(rules) * k
    # the rules' images and the shifted targets in one batch, through one compiled program that
    # takes the target's loss as an argument (a pytree): one compilation for every target
    batch = jnp.asarray(np.concatenate([*stacks, refs]) if refs.shape[1:] == stacks[0].shape[1:]
                        else np.concatenate(stacks))
    apply = jax.jit(lambda loss, rgb: loss(rgb))
    losses = np.zeros((len(rules), len(names), k))
    references = np.zeros((len(names), len(names)))
    config = preset("cpu", n_rot=n_rot)
    for j, name in enumerate(names):
        loss = build_loss(config, np.asarray(targets[name], np.float32))
        values = np.asarray(apply(loss, batch))
        losses[:, j, :] = values[:n_images].reshape(len(rules), k)
        references[:, j] = (values[n_images:] if len(values) > n_images
                            else np.asarray(apply(loss, jnp.asarray(refs))))
    return Confusion(rules, names, losses, references)


def grow_rule(model, size: int = 64, steps: int = 5000, seeds: Sequence[int] = (0, 1, 2)
              ) -> np.ndarray:
    """RGB images ``(len(seeds), size, size, 3)`` in ``[0, 1]`` of ``model`` grown from its
    seed state (``blobs``, seed ``s``) on a periodic ``size x size`` grid, 9-point stencil,
    ``dt = 1``."""
    from morphogen.domains.grid import Grid
    from morphogen.engine.initial import make_initial
    from morphogen.engine.simulate import simulate
    from morphogen.models.neural import rgb_channels

    grid = Grid((size, size), stencil=9)
    p = dict(model.params)
    out = []
    for s in seeds:
        u0 = make_initial("blobs", model, grid, p, seed=int(s))
        state = np.asarray(simulate(model, grid, u0, p, steps=steps, dt=1.0).state)
        out.append(np.clip(rgb_channels(state), 0.0, 1.0))
    return np.stack(out).astype(np.float32)


# --- blobs of a two-colour texture ---------------------------------------------------------

@dataclass(frozen=True)
class BlobStats:
    """Features of a two-colour texture: ``count`` components of at least ``min_area`` ink
    cells, their ``density`` per 1 000 cells, mean ``area`` (cells), ``ink`` fraction of the
    image, and the ``elongated`` share of components."""

    count: int
    density: float
    area: float
    ink: float
    elongated: float


def two_colours(target: np.ndarray, iterations: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """``(ink, ground)``: the two colours of a two-colour image by 2-means in RGB; the ink is
    the rarer one."""
    px = np.asarray(target, np.float64).reshape(-1, 3)
    lum = px.mean(axis=1)
    centres = np.stack([px[np.argmin(lum)], px[np.argmax(lum)]])  # darkest and brightest
    for _ in range(iterations):
        d = ((px[:, None, :] - centres[None]) ** 2).sum(-1)
        label = d.argmin(1)
        centres = np.stack([px[label == c].mean(0) if np.any(label == c) else centres[c]
                            for c in (0, 1)])
    d = ((px[:, None, :] - centres[None]) ** 2).sum(-1)
    share = np.bincount(d.argmin(1), minlength=2)
    ink = int(np.argmin(share))
    return centres[ink], centres[1 - ink]


def ink_mask(img: np.ndarray, ink: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """Cells nearer to ``ink`` than to ``ground`` in RGB, ``(H, W)`` bool."""
    img = np.asarray(img, np.float64)
    return ((img - ink) ** 2).sum(-1) < ((img - ground) ** 2).sum(-1)


def aspect_ratio(ys: np.ndarray, xs: np.ndarray) -> float:
    """Ratio of the standard deviations of cell coordinates along the principal axes (1 for a
    disc; ``inf`` for a one-cell-wide line)."""
    if ys.size < 2:
        return 1.0
    cov = np.cov(np.stack([ys, xs]).astype(np.float64))
    lo, hi = np.linalg.eigvalsh(cov + np.eye(2) / 12.0)  # + a cell's own extent (uniform)
    return float(np.sqrt(hi / lo))


def blob_stats(img: np.ndarray, ink: np.ndarray, ground: np.ndarray, *, min_area: int = 4,
               elongated: float = 2.0) -> BlobStats:
    """:class:`BlobStats` of ``img`` ``(H, W, 3)``, periodic in both directions.

    The mask is tiled 3 x 3 and labelled without wrapping; each component of the torus
    appears once with its centroid in the central tile (a component that spans the whole
    tile is counted once there too, and is elongated or not by its shape in the tiling).
    """
    mask = ink_mask(img, ink, ground)
    h, w = mask.shape
    labels, n = ndimage.label(np.tile(mask, (3, 3)), structure=np.ones((3, 3)))
    areas, shapes = [], []
    if n:
        index = np.arange(1, n + 1)
        cy, cx = np.asarray(ndimage.center_of_mass(np.ones_like(labels), labels, index)).T
        keep = index[(cy >= h) & (cy < 2 * h) & (cx >= w) & (cx < 2 * w)]
        for obj, lab in zip(ndimage.find_objects(labels), range(1, n + 1), strict=True):
            if lab not in keep:
                continue
            ys, xs = np.nonzero(labels[obj] == lab)
            if ys.size >= min_area:
                areas.append(min(ys.size, h * w))
                shapes.append(aspect_ratio(ys, xs))
    count = len(areas)
    return BlobStats(
        count=count,
        density=1000.0 * count / (h * w),
        area=float(np.mean(areas)) if areas else 0.0,
        ink=float(mask.mean()),
        elongated=float(np.mean(np.asarray(shapes) > elongated)) if shapes else 0.0,
    )


def dot_report(images: np.ndarray, target: np.ndarray) -> dict:
    """The dots' statistics of grown ``images`` ``(k, H, W, 3)`` relative to ``target``:
    density ratio, elongated share, mean area (all images pooled) and the target's own."""
    ink, ground = two_colours(target)
    ref = blob_stats(target, ink, ground)
    stats = [blob_stats(im, ink, ground) for im in images]
    count = sum(s.count for s in stats)
    density = float(np.mean([s.density for s in stats]))
    elong = (sum(s.elongated * s.count for s in stats) / count) if count else 0.0
    return {"target_density": ref.density, "target_elongated": ref.elongated,
            "target_area": ref.area, "density": density,
            "density_ratio": density / ref.density if ref.density else float("nan"),
            "elongated": float(elong), "blobs": count,
            "area": float(np.mean([s.area for s in stats if s.count])) if count else 0.0}


# --- the library's table --------------------------------------------------------------------

def library_runs(rules: Mapping[str, str] | None = None, *, size: int = 64, steps: int = 5000,
                 seeds: Sequence[int] = (0, 1, 2), log=print) -> dict[str, np.ndarray]:
    """Grown images of each rule: ``rules`` maps a library name to a model name or file
    (default: every shipped rule ``neural:NAME``)."""
    from morphogen.models.neural_library import rule_names
    from morphogen.models.registry import load_model

    rules = dict(rules) if rules else {n: f"neural:{n}" for n in rule_names()}
    out = {}
    for name, source in rules.items():
        start = time.perf_counter()
        out[name] = grow_rule(load_model(source), size, steps, seeds)
        log(f"{name}: grown {len(seeds)} x {steps} steps on {size}^2 in "
            f"{time.perf_counter() - start:.0f} s")
    return out


def library_targets(names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """The library's synthetic targets (64 x 64), every one of :data:`TARGETS` by default."""
    from morphogen.learn.textures import synthetic_texture
    from morphogen.learn.train_library import TARGET_SIZE, TARGETS

    return {n: synthetic_texture(n, TARGET_SIZE) for n in (names or TARGETS)}


def report(images: Mapping[str, np.ndarray], targets: Mapping[str, np.ndarray]) -> dict:
    """The confusion table (by colour, as the training's loss sees it, and by shape alone:
    :func:`shape_only`) and (when ``dots`` is among both) the dots' statistics."""
    table = confusion_table(images, targets)
    shape = confusion_table(images, targets, shape=True)
    out = {"table": table, "markdown": table.markdown(), "shape": shape,
           "shape_markdown": shape.markdown()}
    if "dots" in images and "dots" in targets:
        out["dots"] = dot_report(images["dots"], targets["dots"])
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--rule", action="append", default=[], metavar="NAME=FILE",
                        help="judge this model file as rule NAME (default: the shipped rules)")
    parser.add_argument("--only", nargs="+", metavar="NAME", help="rows to grow")
    parser.add_argument("--json", type=Path, help="also write the numbers here")
    parser.add_argument("--images", type=Path, help="also keep the grown images (.npz) here")
    args = parser.parse_args(argv)
    from morphogen.models.neural_library import rule_names

    rules = {n: f"neural:{n}" for n in (args.only or rule_names())}
    for item in args.rule:
        name, sep, path = item.partition("=")
        if not sep:
            parser.error(f"--rule takes NAME=FILE, got {item!r}")
        rules[name] = path
    images = library_runs(rules, size=args.size, steps=args.steps, seeds=range(args.seeds))
    if args.images:
        np.savez_compressed(args.images, **images)
    result = report(images, library_targets())
    print(result["markdown"])
    print("\nby shape (luminance ranks, palette removed):\n" + result["shape_markdown"])
    if "dots" in result:
        print(json.dumps(result["dots"], indent=2))
    if args.json:
        data = {"table": result["table"].to_dict(), "shape": result["shape"].to_dict(),
                "dots": result.get("dots"),
                "steps": args.steps, "size": args.size, "seeds": args.seeds, "rules": rules}
        args.json.write_text(json.dumps(data, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
