"""Genes: the searched parameters of a model, with bounds and mutation scales.

A genome is a vector of gene values in real (model) units, shape ``(G,)``; a population is
``(P, G)``. Each :class:`Gene` names a model parameter, its bounds ``[low, high]`` (also the
range of the uniform initialisation) and its mutation standard deviation ``sigma``.

Skaggs table 3.2 lists, per gene, an initial range and a "mutation rate" printed as
:math:`\\sigma^2` in eq. 3.5, :math:`\\gamma \\leftarrow \\gamma + N(0, \\sigma^2)`. Read
literally as an absolute variance the rates are several times larger than the ranges
(``k`` in ``[0.04, 0.06]`` with ``sigma^2 = 0.05`` gives a step of 0.22), so with genes kept
inside their bounds every mutation would land on a bound. The presets here therefore read the
table's number as a variance in units of the gene's range: ``sigma = sqrt(rate) * (high - low)``
(``k``: 0.0045, ``F``: 0.013, ``kappa``: 0.42). :data:`SKAGGS_RATES` keeps the printed values.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from morphogen.errors import MorphogenError

DEFAULT_SIGMA_FRACTION = 0.1
"""Mutation standard deviation, as a fraction of the range, for genes with no preset."""


@dataclass(frozen=True)
class Gene:
    """One searched parameter.

    Attributes:
        name: the model parameter it sets.
        low, high: bounds (and uniform initialisation range); genomes never leave them.
        sigma: standard deviation of the Gaussian mutation (Skaggs eq. 3.5), in gene units;
            default :data:`DEFAULT_SIGMA_FRACTION` of the range.
    """

    name: str
    low: float
    high: float
    sigma: float | None = None  # a float once built: the default is set from the range

    def __post_init__(self) -> None:
        if not self.name:
            raise MorphogenError("a gene needs a parameter name, e.g. --gene F=0.02:0.08")
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise MorphogenError(
                f"gene {self.name}: range {self.low:g}:{self.high:g} must be finite with low < high"
            )
        sigma = DEFAULT_SIGMA_FRACTION * self.width if self.sigma is None else self.sigma
        object.__setattr__(self, "sigma", sigma)
        if not (math.isfinite(sigma) and sigma >= 0):
            raise MorphogenError(f"gene {self.name}: sigma must be >= 0, got {sigma:g}")

    @property
    def width(self) -> float:
        return self.high - self.low

    @classmethod
    def parse(cls, spec: str, default_sigma: float | None = None) -> Gene:
        """Parse ``NAME=LOW:HIGH`` or ``NAME=LOW:HIGH:SIGMA``.

        Without ``SIGMA`` the mutation scale is ``default_sigma`` if given, otherwise
        :data:`DEFAULT_SIGMA_FRACTION` of the range.
        """
        name, eq, rest = spec.partition("=")
        parts = rest.split(":")
        if not eq or len(parts) not in (2, 3):
            raise MorphogenError(
                f"bad gene {spec!r}: write NAME=LOW:HIGH or NAME=LOW:HIGH:SIGMA, e.g. F=0.02:0.08"
            )
        try:
            values = [float(p) for p in parts]
        except ValueError:
            msg = f"bad gene {spec!r}: LOW, HIGH and SIGMA must be numbers"
            raise MorphogenError(msg) from None
        low, high = values[0], values[1]
        if len(values) == 3:
            sigma = values[2]
        elif default_sigma is not None:
            sigma = default_sigma
        else:
            sigma = DEFAULT_SIGMA_FRACTION * (high - low)
        return cls(name.strip(), low, high, sigma)

    def to_dict(self) -> dict[str, float | str | None]:
        return {"name": self.name, "low": self.low, "high": self.high, "sigma": self.sigma}

    @classmethod
    def from_dict(cls, data: Mapping) -> Gene:
        return cls(str(data["name"]), float(data["low"]), float(data["high"]),
                   float(data["sigma"]))


def skaggs_gene(name: str, low: float, high: float, rate: float) -> Gene:
    """A gene from Skaggs table 3.2: ``rate`` is the printed ``sigma^2``, read in range units."""
    return Gene(name, low, high, math.sqrt(rate) * (high - low))


SKAGGS_RATES: dict[str, dict[str, tuple[float, float, float]]] = {
    "gray-scott": {"F": (0.02, 0.08, 0.05), "k": (0.04, 0.06, 0.05)},
    "gierer-meinhardt": {
        "rho": (0.45, 0.55, 0.2),
        "mu": (0.95, 1.0, 0.1),
        "nu": (0.85, 0.95, 0.1),
        "kappa": (0.2, 0.8, 0.5),
    },
}
"""Skaggs table 3.2 as printed: gene -> (initial low, initial high, sigma^2)."""

GENRD_RANGE = (-1.0, 1.0, 0.5)
"""Skaggs table 3.2 for every GenRD coefficient alpha and beta: range [-1, 1], sigma^2 0.5."""

SKAGGS_SCHEDULE: dict[str, tuple[float, float]] = {
    "gray-scott": (0.5, 2000.0),
    "gierer-meinhardt": (0.05, 500.0),
    "genrd": (0.01, 50.0),
}
"""Skaggs table 3.3: model -> (dt, T)."""


def preset_genes(model_name: str, param_names: Sequence[str] = ()) -> list[Gene]:
    """Skaggs's genes for ``model_name`` (tables 3.1-3.2).

    For ``genrd`` every parameter whose name starts with ``alpha`` or ``beta`` (taken from
    ``param_names``, the model's parameters) is a gene on ``[-1, 1]``.

    Raises:
        MorphogenError: the model has no preset; give genes with ``--gene``.
    """
    if model_name in SKAGGS_RATES:
        return [skaggs_gene(n, *v) for n, v in SKAGGS_RATES[model_name].items()]
    if model_name == "genrd":
        names = [n for n in param_names if n.startswith(("alpha", "beta"))]
        if names:
            return [skaggs_gene(n, *GENRD_RANGE) for n in names]
    known = ", ".join([*SKAGGS_RATES, "genrd"])
    raise MorphogenError(
        f"no preset genes for model {model_name!r} (presets: {known}); "
        "give genes with --gene NAME=LOW:HIGH"
    )


def check_genes(genes: Sequence[Gene], param_names: Sequence[str]) -> None:
    """Raise if a gene is not a parameter of the model or appears twice."""
    if not genes:
        raise MorphogenError("no genes to search; give at least one --gene NAME=LOW:HIGH")
    names = [g.name for g in genes]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise MorphogenError(f"gene {dupes[0]!r} given more than once")
    unknown = [n for n in names if n not in param_names]
    if unknown:
        raise MorphogenError(
            f"gene {unknown[0]!r} is not a parameter of the model; parameters are "
            + ", ".join(param_names)
        )


def bounds(genes: Sequence[Gene]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(low, high, sigma)`` as float32 arrays of shape ``(G,)``."""
    low = np.array([g.low for g in genes], np.float32)
    high = np.array([g.high for g in genes], np.float32)
    sigma = np.array([g.sigma for g in genes], np.float32)
    return low, high, sigma


def genome_params(genes: Sequence[Gene], genome: Sequence[float]) -> dict[str, float]:
    """The parameter overrides ``{name: value}`` a genome of shape ``(G,)`` stands for."""
    return {g.name: float(v) for g, v in zip(genes, genome, strict=True)}
