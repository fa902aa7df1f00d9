"""Linear stability of network genomes on the evaluation's grid: how many draws lie in the
Turing region?

    nice -n 5 python docs/images/networks/stability.py [RUNS_DIR] [--draws N] [--batch B]
        [--rescue R]

For each genome (a population at once, ``jax.vmap`` over individuals, float64), with the
package's analysis (:mod:`morphogen.models.fixed_points`, :mod:`morphogen.models.linear`, the
code of ``morphogen analyse``):

1. the evaluation's homogeneous start ``s*``
   (:func:`~morphogen.search.networks.evolve.homogeneous_states`: the well-mixed system, explicit
   Euler at ``Δt = 0.1`` for 5000 time units from ``s = 1``, float32, exactly as the ``steady``
   start) and a fixed point ``u*`` of ``f(u) = (M_p - M_e) v(u)``: the first that is finite,
   non-negative and has every ``|f_i| <= RESIDUAL · Σ_j |ν_ij| v_j`` of :data:`NEWTON` Newton
   steps from ``s*`` (from ``s = 1`` where ``s*`` is not finite); Newton in log-concentrations
   from ``s = 1`` with each subset of the species held at 0, the empty one first
   (:data:`LOG_NEWTON` steps; with and then without :data:`POLISH` Newton steps after); Newton
   from ``s = 1``. None: ``no_fixed_point``. A genome with several fixed points is classified
   at the first found, so at ``s*``'s own where the evaluation's start converges;
2. ``J = ∂f/∂u`` at ``u*`` (:func:`morphogen.models.model.reaction_jacobian`);
3. the dispersion relation of the discrete problem — 32² periodic grid, 5-point Laplacian,
   ``dx = 1`` as in :mod:`morphogen.search.networks.lanes`: for every grid mode ``(m, n)``,
   ``κ² = 4 - 2 cos(2πm/32) - 2 cos(2πn/32)`` and ``σ(κ²) = max Re eig(J - κ² D)``
   (the 153 modes ``0 <= m <= n <= 16`` carry every distinct ``κ²``);
4. a class: ``turing`` (``σ(0) < -tol`` and ``σ(κ²) > tol`` for some ``κ² > 0``),
   ``stable`` (``σ(0) < -tol`` and ``σ(κ²) <= tol`` for every ``κ² > 0``), ``unstable_k0``
   (``σ(0) > tol``: the homogeneous state itself grows or oscillates), ``marginal``
   (``|σ(0)| <= tol``, e.g. a conserved quantity), or ``no_fixed_point``. ``tol`` is
   :data:`TOL_ABS` (per time unit: a factor e^0.000004 over the evaluation's 3800) plus
   :data:`TOL` times ``max|J̃|`` (LAPACK's backward error is ``~1e-16 max|J̃|``), with
   ``J̃ = diag(u*)⁻¹ J diag(u*)`` (zeros of ``u*`` taken as 1): the same eigenvalues, and
   with them ``σ(κ²)``, since ``D`` is diagonal, but entries in units of 1/time where
   ``J``'s span tens of decades when ``u*`` does. ``marginal`` also takes genomes whose
   ``σ(0)`` is smaller than that bound only because ``J̃`` is huge (``u*`` far out of the
   evaluation's bounds).
5. whether the evaluation's explicit Euler step (``Δt = 0.1``) is stable at ``u*``: every
   eigenvalue ``λ`` of every ``J - κ² D`` with ``Re λ < 0`` has ``|1 + Δt λ| <= 1``
   (``euler_ok``; otherwise a decaying mode grows on the grid and the state leaves the valid
   range).

Measured: the hand-made Table-2 network (fastest mode, and the dominant wavelength of its
evaluated A field at t = 3800 for comparison), every run folder's final population (copied to
a temporary folder first: runs may be mid-write), the runs' own generation 0 (the key of
:func:`~morphogen.search.networks.evolve.run`) and ``N`` fresh generation-0 draws per
experiment (:func:`~morphogen.search.networks.operators.random_population`, as
``make_figures.py`` sets them up), with a 95 % Clopper-Pearson interval on the Turing fraction
(rule of three, ``3/N``, when none is found) and the funnel from Turing-unstable to visible to
the evaluation (:func:`summary`); up to ``R`` of the Turing draws are evaluated from ``u*``
and from their own ``steady`` start (:func:`from_fixed_point`). Writes ``stability.json``
beside this file and prints a table. RUNS_DIR defaults to ``/work/netruns``; about 3 CPU-minutes
with the defaults (20 000 draws of each experiment, single-threaded XLA).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shutil
import sys
import tempfile
import time
from functools import lru_cache
from pathlib import Path

from morphogen.util.cluster import SINGLE_THREAD

os.environ.setdefault("XLA_FLAGS", SINGLE_THREAD)
sys.path.insert(0, str(Path(__file__).parent))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from make_figures import EVAL, experiment  # noqa: E402

from morphogen.domains.grid import Grid  # noqa: E402
from morphogen.models.fixed_points import (  # noqa: E402
    LOG_NEWTON,
    NEWTON,
    POLISH,
    RESIDUAL,
    first_found,
    solver,
)
from morphogen.models.linear import CLASSES, TOL, lattice_modes, stability_at  # noqa: E402
from morphogen.search.networks.cluster import PROMINENCE, S_MAX, peaks  # noqa: E402
from morphogen.search.networks.evolve import (  # noqa: E402
    evaluate,
    homogeneous_states,
    initial_state,
    load_state,
    within_bounds,
)
from morphogen.search.networks.genome import (  # noqa: E402
    Genome,
    NetworkSpec,
    stack,
    table2_genome,
)
from morphogen.search.networks.operators import random_population  # noqa: E402
from morphogen.search.networks.reaction import genome_params, padded_model  # noqa: E402

HERE = Path(__file__).parent
DRAWS = 20_000
BATCH = 2_000
RESCUE = 8
T_END = EVAL.t_start + (EVAL.rounds - 1) * EVAL.interval


def grid_modes(size: int) -> tuple[np.ndarray, np.ndarray]:
    """``κ²`` ``(K,)`` of the modes ``0 <= m <= n <= size/2`` of the periodic 5-point Laplacian
    (``dx = 1``, eigenvalue ``-κ²``) and their lattice wavelengths ``size / |(m, n)|``
    (``inf`` for ``(0, 0)``, first): :func:`morphogen.models.linear.lattice_modes`."""
    grid = Grid((size, size))
    modes = lattice_modes(grid.shape, grid.symbol)
    return modes.kappa2, modes.wavelength


@lru_cache(maxsize=4)
def _program(spec: NetworkSpec, size: int):
    """The vmapped float64 analysis of a population (module docstring, steps 1-4): the fixed
    points of :func:`morphogen.models.fixed_points.solver` (mass-action balance; starts
    ``s*`` then ``s = 1``), the first found, and :func:`morphogen.models.linear.stability_at`
    there; the Euler check and the distance to the start on top."""
    model = padded_model(spec)
    kappa2 = jnp.asarray(grid_modes(size)[0], jnp.float64)
    find = solver(model, balance="mass-action", newton=NEWTON, log_newton=LOG_NEWTON,
                  polish=POLISH)

    def one(p, s0):
        start = jnp.where(jnp.all(jnp.isfinite(s0)), s0, 1.0)
        u, found = first_found(find(p, jnp.stack([start, jnp.ones_like(start)])))
        st = stability_at(model, p, u, kappa2, found)
        lam = st.eigenvalues
        euler = jnp.all((jnp.real(lam) >= 0) | (jnp.abs(1 + EVAL.dt * lam) <= 1 + 1e-12))
        close = jnp.all(jnp.abs(start - u) <= 1e-2 * jnp.abs(u) + 1e-6)
        found = st.cls != CLASSES.index("no_fixed_point")
        return {"cls": st.cls, "sigma0": st.sigma[0], "oscillatory": st.oscillatory,
                "sigma_max": st.sigma[st.fastest], "mode": st.fastest, "u": u,
                "near_start": close, "in_bounds": found & jnp.all(u <= S_MAX),
                "euler_ok": euler}

    return jax.jit(jax.vmap(one))


def analyse(pop, spec: NetworkSpec) -> dict[str, np.ndarray]:
    """Per genome of ``pop`` (leading axis ``P``): class index into :data:`CLASSES`, ``σ(0)``,
    the largest ``σ`` over ``κ² > 0`` and its mode index into :func:`grid_modes`, ``u*``
    ``(P, n)``, whether the evaluation's start lies within 1 % of ``u*`` and whether it is
    valid at all (``start_valid``)."""
    params = genome_params(pop, spec)
    s0 = homogeneous_states(params, spec, EVAL)
    valid = np.asarray(within_bounds(s0))
    with jax.enable_x64(True):
        p64 = {"k": jnp.asarray(np.asarray(params["k"]), jnp.float64),
               "Me": jnp.asarray(params["Me"]), "Mp": jnp.asarray(params["Mp"])}
        p64.update({f"D_{s}": jnp.full(len(p64["k"]), d, jnp.float64)
                    for s, d in zip(spec.species, spec.diffusion, strict=True)})
        out = _program(spec, EVAL.size)(p64, jnp.asarray(np.asarray(s0), jnp.float64))
        out = {k: np.asarray(v) for k, v in out.items()}
    out["start_valid"] = valid
    return out


def summary(res: dict[str, np.ndarray]) -> dict:
    """Class counts (all, and with ``u*`` in the evaluation's bounds ``[0, S_MAX]``), the
    largest ``σ`` over ``κ² > 0`` (among genomes with a fixed point, with one in bounds, and
    Turing ones), and the funnel of the Turing genomes to what the evaluation can see (each
    step keeps the previous ones): ``u*`` in bounds, Euler at ``Δt = 0.1`` stable there, the
    evaluation's start ``s*`` valid, ``s*`` within 1 % of ``u*``, growth at least e-fold by the
    last scoring round (``σ · 3800 >= 1``; ``turing_seen``)."""
    cls, inb, smax = res["cls"], res["in_bounds"], res["sigma_max"]
    has = cls != CLASSES.index("no_fixed_point")
    turing = cls == CLASSES.index("turing")

    def top(mask):
        return float(smax[mask].max()) if mask.any() else None

    funnel, keep = {}, turing
    for name, step in (("in_bounds", inb), ("euler_ok", res["euler_ok"]),
                       ("start_valid", res["start_valid"]), ("near_start", res["near_start"]),
                       ("efold", smax * T_END >= 1)):
        keep = keep & step
        funnel[name] = int(keep.sum())
    return {"n": int(cls.size), **{c: int((cls == i).sum()) for i, c in enumerate(CLASSES)},
            "in_bounds": {c: int(((cls == i) & inb).sum()) for i, c in enumerate(CLASSES)},
            "start_invalid": int((~res["start_valid"]).sum()),
            "start_at_fixed_point": int((has & res["start_valid"] & res["near_start"]).sum()),
            "unstable_k0_oscillatory": int(((cls == 2) & res["oscillatory"]).sum()),
            "sigma_max_largest": top(has), "sigma_max_largest_in_bounds": top(has & inb),
            "sigma_max_largest_turing": top(turing), "turing_funnel": funnel,
            "turing_seen": funnel["efold"]}


def interval(hits: int, n: int) -> dict:
    """Fraction with a 95 % Clopper-Pearson interval; the rule of three when ``hits == 0``."""
    from scipy.stats import beta

    if hits == 0:
        return {"fraction": 0.0, "low": 0.0, "high": 3.0 / n, "method": "rule of three"}
    return {"fraction": hits / n, "low": float(beta.ppf(0.025, hits, n - hits + 1)),
            "high": float(beta.ppf(0.975, hits + 1, n - hits)) if hits < n else 1.0,
            "method": "Clopper-Pearson"}


def pattern_wavelength(spec: NetworkSpec, genome) -> dict:
    """The A field at t = 3800 of the evaluation from the key-0 start (make_figures.py's
    pattern): its power spectrum's strongest modes and their wavelengths (cells), its
    prominent peaks (the fitness's), and their median nearest-neighbour distance on the torus
    (a hexagonal lattice of wavelength ``λ`` has spacing ``2λ/√3``)."""
    u0 = initial_state(jax.random.key(0), spec, EVAL)
    fitness, states = evaluate(stack([genome]), u0, spec, EVAL)
    a = np.asarray(states[0, 0], np.float64)
    power = np.abs(np.fft.fft2(a - a.mean())) ** 2
    m, n = np.unravel_index(np.argmax(power), power.shape)
    m, n = min(m, a.shape[0] - m), min(n, a.shape[1] - n)
    k = np.fft.fftfreq(a.shape[0])
    radius = np.hypot(*np.meshgrid(k, k, indexing="ij"))
    mean_k = float((power * radius).sum() / power.sum())
    top = np.argwhere(np.asarray(peaks(jnp.asarray(a, jnp.float32), prominence=PROMINENCE)))
    gap = np.abs(top[:, None] - top[None])
    gap = np.minimum(gap, a.shape[0] - gap)
    dist = np.hypot(gap[..., 0], gap[..., 1]) + np.diag(np.full(len(top), np.inf))
    order = np.argsort(power.ravel())[::-1][:8:2]  # four strongest modes (±k pairs)
    strongest = [(int(min(i, a.shape[0] - i)), int(min(j, a.shape[1] - j)))
                 for i, j in zip(*np.unravel_index(order, power.shape), strict=True)]
    return {"fitness": float(fitness[0]), "mode": [int(m), int(n)],
            "wavelength_peak": float(a.shape[0] / np.hypot(m, n)),
            "strongest_modes": [[i, j, float(a.shape[0] / np.hypot(i, j))]
                                for i, j in strongest],
            "wavelength_mean": 1.0 / mean_k, "peaks": len(top),
            "hex_spacing_from_count": float(np.sqrt(2 * a.size / (np.sqrt(3) * len(top)))),
            "nearest_peak_median": float(np.median(dist.min(axis=1)))}


def table2() -> dict:
    spec = experiment(1)[0]
    genome = table2_genome(spec)
    res = analyse(stack([genome]), spec)
    kappa2, wavelength = grid_modes(EVAL.size)
    mode = int(res["mode"][0])
    sigma_max = float(res["sigma_max"][0])
    return {"class": CLASSES[int(res["cls"][0])], "u_star": res["u"][0].tolist(),
            "sigma0": float(res["sigma0"][0]), "sigma_max": sigma_max,
            "kappa2_fastest": float(kappa2[mode]), "wavelength_fastest": float(wavelength[mode]),
            "wavelength_continuous": float(2 * np.pi / np.sqrt(kappa2[mode])),
            "efold_by_t_end": sigma_max * T_END, "euler_ok": bool(res["euler_ok"][0]),
            "start_valid": bool(res["start_valid"][0]), "near_start": bool(res["near_start"][0]),
            "pattern": pattern_wavelength(spec, genome)}


def final_populations(root: Path) -> dict:
    out = {}
    for folder in sorted(root.glob("exp*-seed*")):
        number = int(folder.name[3])
        with tempfile.TemporaryDirectory() as tmp:
            copy = Path(tmp) / "state.npz"
            shutil.copyfile(folder / "state.npz", copy)
            pop, history, generation, _ = load_state(copy)
        res = analyse(pop, experiment(number)[0])
        out[folder.name] = {"generation": generation,
                            "best_fitness": float(history[-1].max()), **summary(res)}
    return out


def from_fixed_point(pop, res: dict[str, np.ndarray], spec: NetworkSpec, count: int) -> list:
    """Up to ``count`` Turing genomes with ``u*`` in bounds and Euler stable there (those the
    evaluation's own start reaches first), each evaluated (Table 1, key-0 noise) from
    ``u* · (1 ± 10 %)`` instead of the relaxation's ``s*`` (``fitness_from_u``), and with the
    evaluation's own ``steady`` start (``fitness_steady``)."""
    ok = (res["cls"] == 0) & res["in_bounds"] & res["euler_ok"]
    seen = ok & res["start_valid"] & res["near_start"]
    picked = np.concatenate([np.flatnonzero(seen), np.flatnonzero(ok & ~seen)])[:count]
    if not picked.size:
        return []
    noise = initial_state(jax.random.key(0), spec, EVAL)
    genomes = [Genome(*(np.asarray(x)[i] for x in pop)) for i in picked]
    steady, _ = evaluate(stack(genomes), noise, spec, EVAL)
    ev = dataclasses.replace(EVAL, init="uniform")
    wavelength = grid_modes(EVAL.size)[1]
    out = []
    for i, genome, fit in zip(picked, genomes, steady, strict=True):
        u0 = jnp.asarray(res["u"][i], jnp.float32)[:, None, None] * noise
        fitness, _ = evaluate(stack([genome]), u0, spec, ev)
        out.append({"index": int(i), "fitness_from_u": float(fitness[0]),
                    "fitness_steady": float(fit), "start_valid": bool(res["start_valid"][i]),
                    "near_start": bool(res["near_start"][i]), "u_star": res["u"][i].tolist(),
                    "sigma0": float(res["sigma0"][i]), "sigma_max": float(res["sigma_max"][i]),
                    "wavelength": float(wavelength[res["mode"][i]]),
                    "k": np.asarray(genome_params(stack([genome]), spec)["k"])[0].tolist()})
    return out


def generation_zero(number: int, seeds: list[int], draws: int, batch: int, rescue: int) -> dict:
    """The runs' own generation 0 (``seeds``) and ``draws`` fresh ones, in batches; up to
    ``rescue`` of the fresh Turing draws evaluated from ``u*`` (:func:`from_fixed_point`)."""
    spec, template, ops = experiment(number)
    own = {}
    for seed in seeds:
        key = jax.random.fold_in(jax.random.key(seed), 0)
        own[f"seed{seed}"] = summary(analyse(
            random_population(key, template, spec, 150, ops), spec))
    pops, parts = [], []
    for b in range(-(-draws // batch)):
        key = jax.random.fold_in(jax.random.key(10_000 + number), b)
        pops.append(random_population(key, template, spec, batch, ops))
        parts.append(analyse(pops[-1], spec))
    res = {k: np.concatenate([p[k] for p in parts])[:draws] for k in parts[0]}
    pop = Genome(*(np.concatenate([np.asarray(p[i]) for p in pops])[:draws] for i in range(5)))
    s = summary(res)
    return {"runs": own, "draws": s, "turing_fraction": interval(s["turing"], s["n"]),
            "seen_fraction": interval(s["turing_seen"], s["n"]),
            "from_fixed_point": from_fixed_point(pop, res, spec, rescue)}


def run_seeds(root: Path, number: int) -> list[int]:
    """The seeds of experiment ``number``'s run folders ``exp{number}-seed{seed}`` in ``root``."""
    return sorted(int(f.name.split("-seed")[1]) for f in root.glob(f"exp{number}-seed*"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("runs_dir", nargs="?", type=Path, default=Path("/work/netruns"))
    parser.add_argument("--draws", type=int, default=DRAWS)
    parser.add_argument("--batch", type=int, default=BATCH)
    parser.add_argument("--rescue", type=int, default=RESCUE)
    args = parser.parse_args()
    clock = time.process_time()
    report = {"settings": {"newton": NEWTON, "residual": RESIDUAL, "tol": TOL,
                           "t_end": T_END, "size": EVAL.size, "classes": CLASSES},
              "draws": args.draws, "table2": table2(), "final": final_populations(args.runs_dir),
              "generation0": {f"exp{n}": generation_zero(n, run_seeds(args.runs_dir, n),
                                                         args.draws, args.batch, args.rescue)
                              for n in (1, 2)}}
    report["cpu_seconds"] = time.process_time() - clock
    (HERE / "stability.json").write_text(json.dumps(report, indent=1) + "\n")
    print_table(report)


def print_table(r: dict) -> None:
    t, pat = r["table2"], r["table2"]["pattern"]
    print(f"Table 2: {t['class']}, u* = {np.round(t['u_star'], 4).tolist()}, "
          f"σ(0) = {t['sigma0']:.3g}, σ_max = {t['sigma_max']:.3g} (σ·3800 = "
          f"{t['efold_by_t_end']:.1f}) at κ² = {t['kappa2_fastest']:.3g}: λ = "
          f"{t['wavelength_fastest']:.2f} cells (2π/κ = {t['wavelength_continuous']:.2f}); "
          f"Euler ok {t['euler_ok']}")
    print(f"  its pattern at t = 3800: fitness {pat['fitness']:.1f}, {pat['peaks']} peaks "
          f"(median nearest-neighbour distance {pat['nearest_peak_median']:.2f} cells; a hexagonal "
          f"lattice of that many: {pat['hex_spacing_from_count']:.1f}), strongest Fourier modes "
          + ", ".join(f"({m}, {n}) λ {w:.2f}" for m, n, w in pat["strongest_modes"]))
    short = {"turing": "turing", "stable": "stable", "unstable_k0": "unst.k=0",
             "marginal": "marginal", "no_fixed_point": "no f.p."}
    print(f"{'population':<22}{'n':>6}" + "".join(f"{short[c]:>10}" for c in CLASSES)
          + f"{'s* bad':>8}{'σmax (all, in bounds)':>24}   Turing funnel")
    rows = list(r["final"].items())
    for e, g in r["generation0"].items():
        rows += [(f"{e} gen 0 {k}", s) for k, s in g["runs"].items()]
        rows.append((f"{e} gen 0 draws", g["draws"]))

    def num(x):
        return "-" if x is None else f"{x:.3g}"

    for name, s in rows:
        both = f"{num(s['sigma_max_largest'])}, {num(s['sigma_max_largest_in_bounds'])}"
        print(f"{name:<22}{s['n']:>6}" + "".join(f"{s[c]:>10}" for c in CLASSES)
              + f"{s['start_invalid']:>8}{both:>24}   "
              + " > ".join(str(v) for v in s["turing_funnel"].values()))
    print("funnel: Turing with u* in bounds > Euler stable > s* valid > s* near u* > σ·3800 >= 1")
    for e, g in r["generation0"].items():
        f = g["turing_fraction"]
        print(f"{e}: Turing fraction {f['fraction']:.2e} (95 % {f['low']:.2e}-{f['high']:.2e}, "
              f"{f['method']}); seen by the evaluation {g['draws']['turing_seen']}; from u*: "
              + ", ".join(f"{x['fitness_from_u']:.0f} (steady start {x['fitness_steady']:.0f},"
                          f" λ {x['wavelength']:.1f})" for x in g["from_fixed_point"]))
    print(f"CPU seconds {r['cpu_seconds']:.0f}")


if __name__ == "__main__":
    main()
