"""The parameter box each candidate model is searched over, and how it is simulated there.

The boxes are the library's sensible ranges: for Gray-Scott the part of Richard et al.'s
``(F, k)`` map (seed 001, §5.2.2, fig. 9) that holds every settled family, for Gierer-Meinhardt
Skaggs's table 3.2 widened in ``kappa`` and ``nu`` (saturation and decay shape the spots), and
for the other library models the ranges where their docstrings place the Turing regime. Each
model is searched on a small periodic grid (``SEARCH_SIZE``) from its own initial condition for
its own simulated time; the grid spacing ``dx`` is set so its default pattern has a wavelength of
about 8-16 cells there (the answer then fits ``dx`` to the picture).

Exploration starts from the model's presets that lie in its box (:func:`preset_genomes`: for
Gray-Scott the explorer's and Richard et al.'s named patterns), then samples it uniformly.

A model not in the table (a model file, or a library model with other genes) is searched over
the genes the user gives (``--gene NAME=LOW:HIGH``) with the model's own ``dt`` and ``t_end``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.genes import DEFAULT_SIGMA_FRACTION, Gene

SEARCH_SIZE = 64
"""Side of the search grid (cells)."""


@dataclass(frozen=True)
class Box:
    """How one model is searched.

    Attributes:
        model: library name or model file.
        genes: the searched parameters and their ranges.
        dx: grid spacing of the search grid.
        time: simulated time (``None``: the model's ``t_end``).
    """

    model: str
    genes: tuple[Gene, ...]
    dx: float = 1.0
    time: float | None = None


def _genes(**ranges: tuple[float, float]) -> tuple[Gene, ...]:
    return tuple(Gene(n, lo, hi, DEFAULT_SIGMA_FRACTION * (hi - lo))
                 for n, (lo, hi) in ranges.items())


BOXES: dict[str, Box] = {
    "gray-scott": Box("gray-scott", _genes(F=(0.01, 0.08), k=(0.04, 0.07)), time=5000.0),
    "schnakenberg": Box("schnakenberg", _genes(a=(0.02, 0.3), b=(0.4, 1.6)), time=50.0),
    "fitzhugh-nagumo": Box("fitzhugh-nagumo", _genes(alpha=(-0.3, 0.3), epsilon=(2.0, 8.0))),
    "turing": Box("turing", _genes(alpha=(12.0, 20.0), beta=(10.0, 14.0))),
    "brusselator": Box("brusselator", _genes(a=(2.0, 6.0), b=(4.0, 12.0))),
    "gierer-meinhardt": Box("gierer-meinhardt", _genes(kappa=(0.0, 1.0), nu=(0.5, 1.0))),
}
"""Search boxes of the library models."""

DEFAULT_MODELS = ("gray-scott", "schnakenberg", "fitzhugh-nagumo", "turing", "brusselator")
"""Models tried when none are named (Gierer-Meinhardt's default wavelength is about 4 cells at
``dx = 1``, too fine for the 64² search grid; name it to include it)."""


def preset_genomes(box: Box) -> np.ndarray:
    """The model's presets that set every gene inside the box, as genomes ``(N, G)`` (first
    seen first, duplicates dropped): the library's named patterns start the exploration."""
    from morphogen.models.registry import load_model

    out: list[tuple[float, ...]] = []
    for values in load_model(box.model).presets.values():
        if all(g.name in values for g in box.genes):
            genome = tuple(float(values[g.name]) for g in box.genes)
            inside = all(g.low <= v <= g.high for g, v in zip(box.genes, genome, strict=True))
            if inside and genome not in out:
                out.append(genome)
    return np.array(out, np.float64).reshape(len(out), len(box.genes))


def resolve_boxes(models: Sequence[str], genes: Sequence[str] = ()) -> list[Box]:
    """The boxes of ``models``; ``genes`` (``NAME=LOW:HIGH``) replace a model's table genes.

    Raises:
        MorphogenError: no models, an unknown model, or a model without a box and no genes.
    """
    from morphogen.models.registry import load_model

    if not models:
        raise MorphogenError("name at least one model to match, e.g. --models gray-scott")
    parsed = tuple(Gene.parse(g) for g in genes)
    out = []
    for name in models:
        model = load_model(name)  # an unknown name or unreadable file: one line
        if parsed:
            missing = [g.name for g in parsed if g.name not in model.params]
            if missing:
                raise MorphogenError(f"gene {missing[0]!r} is not a parameter of {name}; its "
                                     "parameters are " + ", ".join(model.params))
            base = BOXES.get(name)
            out.append(Box(name, parsed, dx=base.dx if base else 1.0,
                           time=base.time if base else None))
        elif name in BOXES:
            out.append(BOXES[name])
        else:
            raise MorphogenError(f"model {name!r} has no search box; give its genes with "
                                 "--gene NAME=LOW:HIGH")
    return out
