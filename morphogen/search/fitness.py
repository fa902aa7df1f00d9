"""Fitness of simulated states: modified Dirichlet energy, target-image statistics, human choice.

Higher is better everywhere. Automatic fitness is staged (Yamamoto et al. §3.3): a state is
first checked for valid values, then for any non-homogeneous pattern, and only then scored:

========================  =========================================
invalid (NaN, Inf, huge)  :data:`INVALID` = -1
uniform (flat)            :data:`FLAT` = 0
patterned                 the score, in ``(0, 1]``
========================  =========================================

so invalid < uniform < any pattern, and fitness-proportionate selection (Skaggs eq. 3.10, which
needs ``f >= 0``) never picks an invalid or flat individual while a patterned one exists.

States have shape ``(P, S, *spatial)`` (a population) or ``(S, *spatial)`` (one); the scores
are pure JAX and ``vmap`` over the population.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.engine.monitors import OVERFLOW
from morphogen.errors import MorphogenError
from morphogen.patterns.spectrum import spectrum_distribution, wasserstein_1d
from morphogen.util.io import check_image

Array = Any

INVALID = -1.0
FLAT = 0.0
HUMAN_LAMBDA = 0.9
"""Share of the total fitness given to the selected individuals (Skaggs eq. 3.9)."""


def gradient_energy(u: Array, periodic: bool = True) -> Array:
    """``|grad u|^2`` per cell: forward differences summed over species and axes.

    Args:
        u: one state, shape ``(S, *spatial)``.
        periodic: wrap the differences around the grid (a torus); otherwise the last cell of
            each axis gets a zero difference.

    Returns:
        shape ``spatial``.
    """
    total = jnp.zeros(u.shape[1:], u.dtype)
    for axis in range(1, u.ndim):
        if periodic:
            d = jnp.roll(u, -1, axis=axis) - u
        else:
            d = jnp.diff(u, axis=axis, append=jnp.take(u, jnp.array([-1]), axis=axis))
        total = total + jnp.sum(d * d, axis=0)
    return total


def dirichlet_energy(u: Array, periodic: bool = True) -> Array:
    """Modified Dirichlet energy as a mean per cell (Skaggs eqs. 3.7-3.8).

    .. math:: E(u) = \\frac{1}{N}\\,\\frac{\\sum_{\\Omega} \\|\\nabla u\\|^2}
                                       {\\max_{\\Omega} \\|\\nabla u\\|^2}

    with ``N`` the number of cells, so ``0 < E <= 1`` and ``E`` does not grow with the grid
    size. Dividing by the maximum makes ``E`` blind to the scale of ``u`` (Skaggs's reason
    for the modification); it is high when strong gradients fill the domain and low when
    they are rare. A perfectly flat state gives 0.

    Args:
        u: one state, shape ``(S, *spatial)``.

    Returns:
        a scalar.
    """
    g = gradient_energy(u, periodic)
    top = jnp.max(g)
    return jnp.where(top > 0, jnp.mean(g) / jnp.where(top > 0, top, 1.0), 0.0)


def is_valid(u: Array) -> Array:
    """Whether every value of the state ``(S, *spatial)`` is finite and below :data:`OVERFLOW`."""
    return jnp.all(jnp.isfinite(u) & (jnp.abs(u) < OVERFLOW))


def is_flat(u: Array, tol: float = 1e-3) -> Array:
    """Whether every species is uniform: ``max - min <= tol * max(1, max |u|)``."""
    axes = tuple(range(1, u.ndim))
    spread = jnp.max(u, axis=axes) - jnp.min(u, axis=axes)
    scale = jnp.maximum(1.0, jnp.max(jnp.abs(u), axis=axes))
    return jnp.all(spread <= tol * scale)


def staged(score: Callable[[Array], Array], flat_tol: float = 1e-3) -> Callable[[Array], Array]:
    """Wrap a per-state score in the three stages of Yamamoto et al. §3.3.

    Returns ``f(states (P, S, *spatial)) -> (P,)``: :data:`INVALID` for invalid states,
    :data:`FLAT` for uniform ones, ``score(u)`` (expected in ``(0, 1]``) otherwise. States are
    scored by ``lax.map``, one compiled program for every state, so a score is bit-for-bit the
    same whatever the population size or however a population is split into batches.
    """

    def one(u: Array) -> Array:
        valid = is_valid(u)
        safe = jnp.where(valid, u, 0.0)
        value = jnp.where(is_flat(safe, flat_tol), FLAT, score(safe))
        return jnp.where(valid, value, INVALID)

    return lambda states: jax.lax.map(one, states)


def dirichlet_fitness(periodic: bool = True, flat_tol: float = 1e-3) -> Callable[[Array], Array]:
    """Staged modified Dirichlet energy over a population ``(P, S, *spatial) -> (P,)``."""
    return staged(lambda u: dirichlet_energy(u, periodic), flat_tol)


# --- target image -----------------------------------------------------------------------------


def intensity_histogram(field: Array, bins: int = 32) -> Array:
    """Histogram of the field's values rescaled to ``[0, 1]`` by its own min and max, shape
    ``(bins,)``, summing to 1. Blind to position, orientation and affine changes of scale."""
    lo, hi = jnp.min(field), jnp.max(field)
    x = (field - lo) / jnp.maximum(hi - lo, 1e-12)
    idx = jnp.clip((x * bins).astype(jnp.int32), 0, bins - 1)
    counts = jnp.zeros(bins, field.dtype).at[idx.ravel()].add(1.0)
    return counts / field.size


def pattern_statistics(field: Array, hist_bins: int = 32) -> tuple[Array, Array]:
    """``(spectrum_distribution, intensity_histogram)`` of a 2D field ``(H, W)``
    (:func:`morphogen.patterns.spectrum.spectrum_distribution`)."""
    return spectrum_distribution(field), intensity_histogram(field, hist_bins)


def target_distance(field: Array, target: tuple[Array, Array]) -> Array:
    """Mean of the spectrum and histogram earth mover's distances to ``target`` statistics
    (from :func:`pattern_statistics`), between 0 and 1."""
    spectrum, hist = pattern_statistics(field, target[1].shape[0])
    return 0.5 * (wasserstein_1d(spectrum, target[0]) + wasserstein_1d(hist, target[1]))


def target_fitness(
    target: np.ndarray,
    species: int,
    *,
    sharpness: float = 10.0,
    flat_tol: float = 1e-3,
) -> Callable[[Array], Array]:
    """Staged similarity to a target image, ``(P, S, H, W) -> (P,)`` (Skaggs §6.4).

    ``fitness = exp(-sharpness * d)`` with ``d`` from :func:`target_distance` between species
    ``species`` of each state and the grey-level ``target`` (already resized to ``(H, W)``).
    Statistics rather than pixels are compared, so a pattern scores the same wherever its spots
    or stripes sit and however they are turned.
    """
    stats = pattern_statistics(jnp.asarray(target, jnp.float32))
    return staged(lambda u: jnp.exp(-sharpness * target_distance(u[species], stats)), flat_tol)


def load_target(path: str, shape: Sequence[int]) -> np.ndarray:
    """Read an image as grey levels in ``[0, 1]`` resized to ``shape = (H, W)``.

    Raises:
        MorphogenError: unreadable file, or a grid that is not 2D.
    """
    from PIL import Image

    if len(shape) != 2:
        raise MorphogenError("--fitness target needs a 2D grid (--size N or HxW)")
    check_image(path, "target image")  # header and size, before decoding
    try:
        with Image.open(path) as img:
            grey = img.convert("L").resize((int(shape[1]), int(shape[0])), Image.BILINEAR)
    except (OSError, ValueError) as exc:
        raise MorphogenError(f"cannot read target image {path}: {exc}") from None
    return np.asarray(grey, np.float32) / 255.0


# --- human selection --------------------------------------------------------------------------


def human_fitness(selected: Sequence[int], n: int, lam: float = HUMAN_LAMBDA) -> np.ndarray:
    """Fitness from a person's choice (Skaggs eq. 3.9), shape ``(n,)``.

    .. math:: f_i = \\frac{\\lambda}{|S|}\\ \\text{if } i \\in S,
              \\text{ otherwise } \\frac{1-\\lambda}{N-|S|}

    The selected share ``lambda`` of the total is split among the chosen individuals and the
    rest among the others; if all are chosen each gets ``1/N``.

    Raises:
        MorphogenError: empty selection, repeated or out-of-range indices.
    """
    chosen = check_selection(selected, n)
    f = np.full(n, (1.0 - lam) / max(n - len(chosen), 1))
    f[chosen] = lam / len(chosen) if len(chosen) < n else 1.0 / n
    return f


def check_selection(selected: Sequence[int], n: int) -> list[int]:
    """Validate a selection of individual indices in ``[0, n)``; returns it as a list."""
    chosen = [int(i) for i in selected]
    if not chosen:
        raise MorphogenError("select at least one individual")
    bad = [i for i in chosen if not 0 <= i < n]
    if bad:
        raise MorphogenError(f"index {bad[0]} is out of range; choose from 0 to {n - 1}")
    if len(set(chosen)) != len(chosen):
        raise MorphogenError("an index is selected more than once")
    return chosen


def parse_selection(text: str, n: int) -> list[int]:
    """Parse ``"0 3 5-7"`` or ``"0,3,5-7"`` into validated indices ``[0, 3, 5, 6, 7]``."""
    out: list[int] = []
    for token in text.replace(",", " ").split():
        lo, dash, hi = token.partition("-")
        try:
            if dash:
                out.extend(range(int(lo), int(hi) + 1))
            else:
                out.append(int(token))
        except ValueError:
            raise MorphogenError(f"{token!r} is not an index or a range like 3-5") from None
    return check_selection(out, n)


def ask_selection(
    sheet: str,
    n: int,
    *,
    read: Callable[[str], str] = input,
    write: Callable[[str], Any] = print,
) -> list[int]:
    """Ask in the terminal which individuals of the contact sheet ``sheet`` to keep.

    Re-asks until the answer is a valid selection (:func:`parse_selection`).
    """
    write(f"contact sheet: {sheet}")
    while True:
        try:
            answer = read(f"select individuals to breed (0-{n - 1}, e.g. '0 3 5-7'): ")
        except EOFError:
            raise MorphogenError("no selection given (end of input)") from None
        try:
            return parse_selection(answer, n)
        except MorphogenError as exc:
            write(f"invalid selection: {exc}")
