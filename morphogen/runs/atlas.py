"""Parameter atlases: a grid of parameter pairs simulated as one batched program.

The classic example is the Gray-Scott (F, k) map (Richard et al. fig. 9; Pearson's
classification): every tile is one run with its own ``(x, y)`` parameter pair, all tiles share
the initial state, and the whole grid is a single ``simulate_batch`` call (``vmap`` over the
``NX * NY`` members), not a loop. With ``watch`` the last few states of every tile are kept,
so that :func:`classify_atlas` can name each tile's pattern family (fig. 9 drawn by itself).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax.numpy as jnp
import numpy as np

from morphogen.engine.fields import resolve_params
from morphogen.engine.initial import make_initial
from morphogen.engine.simulate import simulate_batch
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.patterns.classify import classify
from morphogen.patterns.descriptors import NAMES, describe_batch
from morphogen.patterns.watch import simulate_watched
from morphogen.runs.policy import RunPlan, resolve_run
from morphogen.solvers.stability import grid_scale, grid_scale_dominated, observed_scale
from morphogen.solvers.step import batch_params
from morphogen.util.io import write_atomic


@dataclass(frozen=True)
class Axis:
    """One atlas axis: a parameter ``name`` and its ``values`` (evenly spaced)."""

    name: str
    values: np.ndarray

    @classmethod
    def parse(cls, text: str) -> Axis:
        """``"F=0.01:0.07:16"`` -> 16 values of ``F`` from 0.01 to 0.07 inclusive."""
        name, sep, spec = text.partition("=")
        parts = spec.split(":")
        if not sep or len(parts) != 3 or not name.strip():
            raise MorphogenError(f"axis {text!r}: use NAME=START:STOP:COUNT, e.g. F=0.01:0.07:16")
        try:
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise MorphogenError(
                f"axis {text!r}: START, STOP must be numbers, COUNT whole"
            ) from None
        if not 1 <= count <= 64:
            raise MorphogenError(f"axis {text!r}: COUNT must be between 1 and 64")
        return cls(name.strip(), np.linspace(start, stop, count))


@dataclass
class Atlas:
    """The result of :func:`compute_atlas`.

    Attributes:
        states: final states, shape ``(NY, NX, S, *spatial)``.
        valid: whether each run stayed finite and bounded, shape ``(NY, NX)``.
        x, y: the axes.
        wall_time: seconds for the batched simulation.
        snapshots: with ``watch``, the last states, shape ``(NY, NX, T + 1, S, *spatial)``.
        scheme: the scheme that ran (``auto`` resolved).
        unstable: runs that stayed finite but ended in a grid-scale (checkerboard) mode, the
            mark of a step too large for that member (:func:`checkerboard_members`), shape
            ``(NY, NX)``; with the runs that blew up (``~valid``) they are numerical
            artefacts, not patterns (:func:`instability_report`).
        dt: the time step of the run.
    """

    states: np.ndarray
    valid: np.ndarray
    x: Axis
    y: Axis
    wall_time: float
    snapshots: np.ndarray | None = None
    scheme: str = "euler"
    unstable: np.ndarray | None = None
    dt: float = 0.0


def atlas_batch(model: Model, domain: Any, x: Axis, y: Axis,
                params: dict[str, Any] | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """The atlas's parameter values (its axes at 0) and its batch: every parameter with a
    leading axis of ``NY · NX`` members, the axes' values laid out row-major."""
    if x.name == y.name:
        raise MorphogenError(f"the two atlas axes must be different parameters, both are {x.name}")
    values = model.parameters({**(params or {}), x.name: 0.0, y.name: 0.0})
    base = resolve_params(model, domain, values)
    batch = batch_params(base, len(y.values) * len(x.values), batched=())
    xx, yy = np.meshgrid(x.values, y.values)
    real = np.dtype(jnp.result_type(float))  # float32, or float64 in JAX's x64 mode
    batch[x.name] = np.asarray(xx.reshape(-1), real)
    batch[y.name] = np.asarray(yy.reshape(-1), real)
    return values, batch


def plan_atlas(model: Model, domain: Any, x: Axis, y: Axis, *,
               params: dict[str, Any] | None = None, scheme: str = "euler",
               dt: float | None = None, steps: int | None = None, time: float | None = None,
               unsafe: bool = False) -> RunPlan:
    """The run policy's scheme, ``dt`` and steps for an atlas
    (:func:`morphogen.runs.policy.resolve_run` over every member: the model's ``dt`` within
    the smallest member limit, ``auto`` resolved on the whole batch)."""
    _, batch = atlas_batch(model, domain, x, y, params)
    return resolve_run(model, domain, batch, scheme=scheme, dt=dt, steps=steps, t_end=time,
                       unsafe=unsafe, batched=True, where="the atlas")


def compute_atlas(
    model: Model,
    domain: Any,
    x: Axis,
    y: Axis,
    *,
    params: dict[str, Any] | None = None,
    steps: int,
    dt: float,
    init: str | None = None,
    init_options: dict[str, Any] | None = None,
    seed: int = 0,
    progress: bool = False,
    scheme: str = "euler",
    unsafe: bool = False,
    watch: tuple[int, int] | None = None,
    **options: Any,
) -> Atlas:
    """Simulate every ``(x, y)`` pair at once (one vmapped program).

    Args:
        params: the other parameters (defaults from the model); ``x.name`` and ``y.name`` must
            be model parameters.
        init, init_options: every tile's initial condition
            (:func:`morphogen.engine.initial.make_initial`; default the model's).
        unsafe: skip the explicit stability check (done over every member, since a diffusion
            coefficient may be an axis).
        watch: ``(count, gap)``: also keep ``count + 1`` states ``gap`` steps apart at the end
            (see :func:`morphogen.patterns.watch.simulate_watched`).
        options: passed to :func:`morphogen.engine.simulate.simulate_batch` (``noise``, ``clamp``).
    """
    values, batch = atlas_batch(model, domain, x, y, params)
    ny, nx = len(y.values), len(x.values)
    sample = dict(values)
    sample.update({x.name: float(x.values.mean()), y.name: float(y.values.mean())})
    u0 = make_initial(init or model.init, model, domain, sample, seed=seed,
                      **(init_options or {}))
    u0 = np.broadcast_to(u0, (ny * nx, *u0.shape))
    # the run policy: auto resolved over the whole batch, dt checked against every member
    scheme = resolve_run(model, domain, batch, scheme=scheme, dt=dt, steps=steps,
                         unsafe=unsafe, batched=True, where="the atlas").scheme
    shape = (ny, nx)
    snaps = None
    if watch is None:
        sol = simulate_batch(model, domain, u0, batch, steps=steps, dt=dt, seed=seed,
                             scheme=scheme, progress=progress, unsafe=True, **options)
    else:
        sol, snaps = simulate_watched(model, domain, u0, batch, steps=steps, dt=dt,
                                      count=watch[0], gap=watch[1], seed=seed, scheme=scheme,
                                      progress=progress, unsafe=True, **options)
        snaps = snaps.reshape(*shape, *snaps.shape[1:])
    return Atlas(
        states=sol.state.reshape(*shape, *sol.state.shape[1:]),
        valid=sol.valid.reshape(shape),
        x=x,
        y=y,
        wall_time=sol.wall_time,
        snapshots=snaps,
        scheme=scheme,
        unstable=(checkerboard_members(sol.state, u0, model, batch) & sol.valid).reshape(shape),
        dt=float(dt),
    )


def checkerboard_members(state: np.ndarray, u0: np.ndarray, model: Model,
                         params: dict[str, Any]) -> np.ndarray:
    """Members of a batch ``(B, S, *spatial)`` whose final state is dominated by the grid-scale
    mode in some species, shape ``(B,)``.

    The test of the engine's divergence monitor
    (:func:`morphogen.solvers.stability.divergence_flags`) on the last state alone: the
    checkerboard component carries more than ``GRID_SCALE_RATIO`` of a species' deviation and
    is above round-off (``1e-4`` of the starting scale). An explicit step beyond a member's
    limit leaves exactly this, bounded or still growing, while a pattern's wavelength spans
    several cells; the monitor only stops a run whose checkerboard keeps growing, so one that
    saturates needs this check.
    """
    state = np.asarray(state)
    if state.ndim < 4:  # a 1D grid has no checkerboard in this sense; meshes are not batched
        return np.zeros(len(state), bool)
    g, dev = (np.asarray(a, np.float64) for a in grid_scale(np.nan_to_num(state), True))
    scale = observed_scale(u0, model, params, True)
    return grid_scale_dominated(g, dev, scale).any(axis=1)


def instability_report(atlas: Atlas, shown: int = 6) -> str | None:
    """One line naming the tiles that blew up or ended in a checkerboard (numerically unstable
    at the atlas's ``dt``), or ``None`` when there are none."""
    bad = ~atlas.valid | (atlas.unstable if atlas.unstable is not None else False)
    if not bad.any():
        return None
    where = [f"{atlas.x.name}={atlas.x.values[j]:.4g} {atlas.y.name}={atlas.y.values[i]:.4g}"
             for i, j in zip(*np.nonzero(bad), strict=True)]
    more = f" and {len(where) - shown} more" if len(where) > shown else ""
    return (f"{int(bad.sum())} of {bad.size} tiles were numerically unstable at dt={atlas.dt:g} "
            f"(they blew up or ended in a grid-scale checkerboard, which is not a pattern): "
            f"{', '.join(where[:shown])}{more}; they are labelled blown-up; run again with a "
            f"smaller --dt (e.g. {atlas.dt / 2:g}) to see what those parameters do")


def classify_atlas(atlas: Atlas, species: int) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Family label and descriptors of every tile of a watched 2D atlas, for one species.

    Returns:
        labels ``(NY, NX)`` (names from :data:`morphogen.patterns.classify.FAMILIES`) and a
        dict of ``(NY, NX)`` descriptor arrays.
    """
    if atlas.snapshots is None:
        raise MorphogenError("classifying an atlas needs its last states: compute it with watch")
    snaps = atlas.snapshots[:, :, :, species]
    if snaps.ndim != 5:
        raise MorphogenError("pattern families are defined on 2D grids; this atlas is not 2D")
    ny, nx = snaps.shape[:2]
    desc = describe_batch(snaps.reshape(ny * nx, *snaps.shape[2:]))
    sound = atlas.valid if atlas.unstable is None else atlas.valid & ~atlas.unstable
    labels = classify(desc, sound.reshape(-1))
    return labels.reshape(ny, nx), {k: np.asarray(v).reshape(ny, nx) for k, v in desc.items()}


def write_families(path: str | Path, atlas: Atlas, labels: np.ndarray,
                   descriptors: dict[str, np.ndarray]) -> Path:
    """Write ``families.csv`` atomically: one row per tile, the two parameter values, the
    family and the descriptors (rows in order of ``y`` then ``x``)."""
    text = io.StringIO()
    out = csv.writer(text, lineterminator="\n")
    names = [n for n in NAMES if n in descriptors]
    out.writerow([atlas.x.name, atlas.y.name, "family", *names])
    for i, yv in enumerate(atlas.y.values):
        for j, xv in enumerate(atlas.x.values):
            out.writerow([f"{xv:.6g}", f"{yv:.6g}", labels[i, j],
                          *(f"{float(descriptors[n][i, j]):.6g}" for n in names)])
    data = text.getvalue().encode()
    return write_atomic(path, lambda f: f.write(data))

