"""Export network genomes: as a :class:`ReactionNetwork`, then a morphogen model file, Antimony,
SBML or a drawing (Yamamoto et al. §3.1, Tables 2-3, Fig. 7).

A genome's active slots become reactions with rates ``k = (mantissa / 10) · 10^exponent``
written as exact decimals (two significant digits, §3.2). Slots are named after their role:
inflow ``∅ → S`` is reaction ``inflow_S`` with rate ``rho_S``, decay ``S → ∅`` is ``decay_S``
with ``mu_S`` (the ``ρ``, ``μ`` of §2.1), evolvable reactions are ``R1, R2, …`` with ``k1, k2,
…`` in slot order (numbered among the active evolvable slots). Reactions whose rate is 0, and
``∅ → ∅``, change nothing and are left out (Table 3 lists some); the diffusion coefficients are
the spec's ``D`` (§3.2).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.network import ReactionNetwork, to_toml
from morphogen.search.networks.genome import Genome, NetworkSpec, table2_genome, table2_spec
from morphogen.util.io import write_atomic

FORMATS = ("toml", "antimony", "sbml", "png", "svg")
"""What :func:`write_network` writes."""

SUFFIX = {"toml": ".toml", "antimony": ".ant", "sbml": ".xml", "png": ".png", "svg": ".svg"}


def genome_network(
    genome: Genome,
    spec: NetworkSpec,
    *,
    name: str = "evolved-network",
    dt: float = 0.1,
    t_end: float = 3800.0,
    initial: tuple[float, ...] | None = None,
    description: str = "",
) -> ReactionNetwork:
    """The active, non-zero-rate reactions of one genome as a :class:`ReactionNetwork`.

    ``dt`` and ``t_end`` default to Table 1 (Δt = 0.1, last evaluation at 2000 + 9 · 200).
    Without ``initial`` the model starts from ``init = "random"`` (uniform in ``[0, 1]``, the
    seed's random initial state of §3.1 scaled to the library's default).
    """
    n = spec.n
    mant = np.asarray(genome.mantissa, np.int64)
    expo = np.asarray(genome.exponent, np.int64)
    me, mp = np.asarray(genome.educts), np.asarray(genome.products)
    active = np.asarray(genome.active, bool)
    if mant.shape != (spec.m_max,) or me.shape != (n, spec.m_max):
        raise MorphogenError(f"genome does not fit the spec ({n} species, {spec.m_max} slots)")
    keep, ids, names, rates = [], [], [], []
    evolvable = 0
    for j in range(spec.m_max):
        if j >= 2 * n and active[j]:
            evolvable += 1
        if not active[j] or mant[j] == 0 or not (me[:, j].any() or mp[:, j].any()):
            continue
        keep.append(j)
        if j < n:
            ids.append(f"inflow_{spec.species[j]}")
            names.append(f"rho_{spec.species[j]}")
        elif j < 2 * n:
            ids.append(f"decay_{spec.species[j - n]}")
            names.append(f"mu_{spec.species[j - n]}")
        else:
            ids.append(f"R{evolvable}")
            names.append(f"k{evolvable}")
        rates.append(float(f"{mant[j]}e{expo[j] - 1}"))
    return ReactionNetwork(
        name, spec.species, me[:, keep], mp[:, keep], tuple(ids), tuple(names), tuple(rates),
        tuple(map(float, spec.diffusion)), initial=initial, display=spec.species[0],
        description=description or "mass-action reaction network (evolved genome)",
        reference="Yamamoto et al. eqs. 2-3, §3.1", dt=dt, t_end=t_end,
        init="random" if initial is None else "noise")


def table2_network() -> ReactionNetwork:
    """The hand-made network of Table 2 / §2.1 (species ``A, B, C``), homogeneous steady state
    ``A = B = C = 1``."""
    net = genome_network(table2_genome(), table2_spec(), name="table2", initial=(1.0, 1.0, 1.0),
                         description="hand-made activator-inhibitor-catalyst network")
    return replace(net, reference="Yamamoto et al. §2.1, Table 2")


def run_network(run_dir: str | Path) -> tuple[ReactionNetwork, float]:
    """The best genome of a ``morphogen networks`` run folder (its last saved generation) and its
    fitness. The spec and evaluation settings come from the folder's ``state.npz``."""
    from morphogen.search.networks.evolve import load_state

    run_dir = Path(run_dir)
    path = run_dir / "state.npz"
    if not path.exists():  # anything else there is named by the reader (a FIFO, a folder)
        raise MorphogenError(f"no {path}: give a `morphogen networks` run folder or 'table2'")
    try:
        pop, history, _, meta = load_state(path)
    except (OSError, ValueError, KeyError) as exc:
        raise MorphogenError(f"cannot read {path}: {exc}") from None
    if not len(history):
        raise MorphogenError(f"{run_dir} holds no evaluated generation yet")
    try:
        s = meta["spec"]
        spec = NetworkSpec(tuple(s["species"]), int(s["m_max"]), tuple(s["diffusion"]),
                           tuple(s["fixed"]), tuple(s["fixed_rates"]), int(s["exp_min"]),
                           int(s["exp_max"]))
        ev = meta["ev"]
        t_end = float(ev["t_start"]) + (int(ev["rounds"]) - 1) * float(ev["interval"])
        dt = float(ev["dt"])
    except (KeyError, TypeError, ValueError):
        raise MorphogenError(f"{run_dir}/state.npz has no readable run settings") from None
    fitness = np.asarray(history[-1])
    best = int(np.argmax(fitness))
    genome = Genome(*(np.asarray(x)[best] for x in pop))
    net = genome_network(genome, spec, name=_model_name(run_dir), dt=dt, t_end=t_end,
                         description=f"best genome of {run_dir.name} (fitness "
                         f"{fitness[best]:.2f})")
    return net, float(fitness[best])


def _model_name(run_dir: Path) -> str:
    stem = "".join(c if c.isalnum() or c in "-_" else "-" for c in run_dir.resolve().name)
    return f"{stem or 'run'}-best"


def network_text(net: ReactionNetwork, fmt: str) -> str:
    """The network as a morphogen model file (``toml``), Antimony or SBML text."""
    from morphogen.models.text.sbml import to_antimony, to_sbml

    writers: dict[str, Any] = {"toml": to_toml, "antimony": to_antimony, "sbml": to_sbml}
    if fmt not in writers:
        raise MorphogenError(f"unknown text format {fmt!r}; use toml, antimony or sbml")
    return writers[fmt](net)


def write_network(net: ReactionNetwork, fmt: str, out: str | Path, *,
                  evolvable_only: bool = False) -> Path:
    """Write ``net`` as ``fmt`` (one of :data:`FORMATS`) to ``out``, atomically.

    ``evolvable_only`` (drawings) leaves out the static inflow/decay reactions, as Fig. 7 does.
    """
    if fmt not in FORMATS:
        raise MorphogenError(f"unknown format {fmt!r}; use one of {', '.join(FORMATS)}")
    out = Path(out)
    if not out.parent.is_dir():
        raise MorphogenError(f"cannot write {out}: folder {out.parent} does not exist")
    if fmt in ("png", "svg"):
        from morphogen.search.networks.draw import draw_network

        keep = None
        if evolvable_only:
            keep = [j for j, r in enumerate(net.reaction_ids)
                    if not r.startswith(("inflow_", "decay_"))]
        data = draw_network(net, fmt, reactions=keep)
    else:
        data = network_text(net, fmt).encode()
    return write_atomic(out, lambda fh: fh.write(data))
