"""A network run folder's ``state.npz``, read back whole and checked before a resume changes
anything (Yamamoto §3.4's run, resumed after a kill).

The file (:func:`morphogen.search.networks.evolve.save_state`) holds the population as five
arrays ``arr_0`` .. ``arr_4`` (the :class:`~morphogen.search.networks.genome.Genome` fields:
mantissas and exponents ``(P, m)``, ``M_e`` and ``M_p`` ``(P, n, m)``, the active mask
``(P, m)``), the fitness ``history`` ``(G, P)``, the number of generations done ``G`` and the
run's settings as JSON text (``meta``). :func:`read_state` reads it through the one checked
``.npz`` reader (:func:`morphogen.util.npz.read_npz`): the shapes announced by the headers must
agree with each other, with the population and with the saved settings before any array is
read (a truncated, empty, junk, wrong-key file or a FIFO is one line); then the values must be a
genome's (mantissas in ``[0, 99]``, exponents within the spec's bounds, stoichiometries in
``[0, MAX_ENTRY]``) and the history finite, so an all-NaN state can never breed a population or
reach ``best.json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.search.networks.genome import MANTISSA_MAX, MAX_ENTRY, Genome
from morphogen.util.npz import npz_members, read_npz

KEYS = ("arr_0", "arr_1", "arr_2", "arr_3", "arr_4", "history", "generation", "meta")
"""The members of a network run's ``state.npz``."""

_KINDS = {"arr_0": "iu", "arr_1": "iu", "arr_2": "iu", "arr_3": "iu", "arr_4": "biu",
          "history": "f", "generation": "iu", "meta": "U"}


def read_state(path: str | Path, population: int | None = None
               ) -> tuple[Genome, np.ndarray, int, dict[str, Any]]:
    """``(population as NumPy arrays, history (G, P), G, settings)`` of a run's ``state.npz``,
    every part checked (module docstring); ``population``: the ``P`` the run must have.

    Raises:
        MorphogenError: one line naming the file and what is wrong; nothing is changed.
    """
    what = "network run state"
    name = f"{what} {path}"
    heads = npz_members(path, what)
    missing = [k for k in KEYS if k not in heads]
    if missing:
        raise MorphogenError(f"{name} has no array {missing[0]!r}; the run cannot be resumed")
    shape0, shape2 = heads["arr_0"][0], heads["arr_2"][0]
    if len(shape0) != 2 or len(shape2) != 3 or shape2[0] != shape0[0] or shape2[2] != shape0[1]:
        raise MorphogenError(f"{name}: the population's arrays have shapes {shape0} and "
                             f"{shape2}, which do not fit together; the run cannot be resumed")
    p, m, n = shape0[0], shape0[1], shape2[1]
    if population is not None and p != population:
        raise MorphogenError(f"{name} holds a population of {p}, the run has {population}; "
                             "the run cannot be resumed")
    shapes = {"arr_0": (p, m), "arr_1": (p, m), "arr_2": (p, n, m), "arr_3": (p, n, m),
              "arr_4": (p, m), "history": (None, p), "generation": (), "meta": ()}
    data = read_npz(path, what, keys=KEYS, extra="refuse", shapes=shapes, kinds=_KINDS,
                    finite=True, max_elements=2**26)
    meta = _meta(str(data["meta"]), name)
    spec = meta["spec"]
    history = data["history"]
    generation = int(data["generation"])
    if generation != len(history) or generation < 1:
        raise MorphogenError(f"{name} says {generation} generations are done but holds "
                             f"{len(history)} rows of fitness; the run cannot be resumed")
    if meta.get("population") != p or spec.get("m_max") != m or len(spec.get("species",
                                                                          ())) != n:
        raise MorphogenError(f"{name}: its arrays ({p} genomes, {n} species, {m} slots) do not "
                             "match its own settings; the run cannot be resumed")
    mant, expo, educts, products, active = (data[f"arr_{i}"] for i in range(5))
    lo, hi = spec.get("exp_min", -6), spec.get("exp_max", 2)
    for label, arr, a, b in (("mantissas", mant, 0, MANTISSA_MAX), ("exponents", expo, lo, hi),
                             ("educts", educts, 0, MAX_ENTRY), ("products", products, 0,
                                                                MAX_ENTRY),
                             ("active flags", active, 0, 1)):
        if arr.size and (arr.min() < a or arr.max() > b):
            raise MorphogenError(f"{name}: {label} outside [{a}, {b}] (a damaged genome row); "
                                 "the run cannot be resumed")
    pop = Genome(mant.astype(np.int32), expo.astype(np.int32), educts.astype(np.int32),
                 products.astype(np.int32), active.astype(bool))
    return pop, history, generation, meta


def _meta(text: str, name: str) -> dict[str, Any]:
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError):
        meta = None
    if not isinstance(meta, dict) or not isinstance(meta.get("spec"), dict) \
            or not isinstance(meta.get("ev"), dict) or not isinstance(meta.get("ops"), dict):
        raise MorphogenError(f"{name}: its settings are not readable; the run cannot be resumed")
    return meta
