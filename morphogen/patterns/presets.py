"""Classify the Gray-Scott presets: the check of the classifier against named patterns.

The presets are those of the WebGL explorer cited by Richard et al. (ref. [1]) and Richard et
al.'s own stripes / chaos / cells settings (§5.2.2, figs. 10-12), see
:mod:`morphogen.models.library`. ``EXPECTED`` is the family each preset is named for; the
presets that share a stencil run as one batched simulation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morphogen.domains.grid import Grid
from morphogen.engine.fields import resolve_params
from morphogen.engine.initial import make_initial
from morphogen.models.library import LIBRARY
from morphogen.patterns.classify import classify
from morphogen.patterns.descriptors import describe_batch
from morphogen.patterns.watch import simulate_watched
from morphogen.solvers.policy import plan_run
from morphogen.solvers.step import batch_params

EXPECTED = {
    "default": "stripes",
    "solitons": "spots",
    "pulsating": "oscillating",
    "worms": "stripes",
    "mazes": "stripes",
    "holes": "holes",
    "chaos": "chaotic",
    "chaos-holes": "chaotic",
    "moving-spots": "chaotic",
    "spots-loops": "mixed",
    "waves": "oscillating",
    "u-skate": "spots",
    "richard-stripes": "stripes",
    "richard-chaos": "chaotic",
    "richard-cells": "spots",
}


@dataclass
class PresetResult:
    """Per preset: ``names``, ``expected`` and ``predicted`` families, ``descriptors``."""

    names: list[str]
    expected: list[str]
    predicted: list[str]
    descriptors: dict[str, np.ndarray]


def classify_presets(names: list[str] | None = None, *, size: int = 128, steps: int = 6000,
                     seed: int = 0, count: int = 4, gap: int = 50) -> PresetResult:
    """Simulate Gray-Scott presets (the run policy's ``dt``: the model's 1 within the stencil's
    limit; the model's ``blobs`` start) and classify them.

    Richard et al.'s presets use the 9-point stencil their diffusion coefficients were
    converted for; the explorer presets the 5-point one.
    """
    model = LIBRARY["gray-scott"]()
    names = list(EXPECTED) if names is None else names
    results: dict[str, tuple[str, dict[str, float]]] = {}
    for stencil in (5, 9):
        group = [n for n in names if (n.startswith("richard-")) == (stencil == 9)]
        if not group:
            continue
        grid = Grid((size, size), stencil=stencil)
        values = [model.parameters(preset=n) for n in group]
        params = [resolve_params(model, grid, v) for v in values]
        batch = {k: np.stack([np.asarray(p[k], np.float32) for p in params]) for k in params[0]}
        batch = batch_params(batch, len(group), batched=tuple(batch))
        u0 = make_initial(model.init, model, grid, values[0], seed=seed)
        u0 = np.broadcast_to(u0, (len(group), *u0.shape))
        dt = plan_run(model, grid, batch, steps=steps, batched=True).dt  # the run policy's
        sol, snaps = simulate_watched(model, grid, u0, batch, steps=steps, dt=dt,
                                      count=count, gap=gap, seed=seed)
        index = model.species_index(model.display_species)
        desc = describe_batch(snaps[:, :, index])
        labels = classify(desc, sol.valid)
        for i, n in enumerate(group):
            results[n] = (str(labels[i]), {k: float(v[i]) for k, v in desc.items()})
    keys = list(results[names[0]][1])
    return PresetResult(
        names=names,
        expected=[EXPECTED[n] for n in names],
        predicted=[results[n][0] for n in names],
        descriptors={k: np.array([results[n][1][k] for n in names]) for k in keys},
    )
