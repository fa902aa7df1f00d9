"""Population evaluation and the generation loop of network evolution (Yamamoto §3.1, §3.3, §3.4).

Evaluation of a population ``(P, …)`` of genomes: every generation draws one random field
shared by all individuals, "like exposing them to the same environment" (§3.1); survivors are
re-evaluated under it. The seed does not say how its random initial conditions are drawn;
:attr:`Evaluation.init` chooses (:data:`INIT_KINDS`):

- ``"fixed"`` (default): every individual starts at its own homogeneous fixed point, ``u* · (1 +
  init_noise · ξ)``, ``u*`` a root of its reaction found by the batched Newton solver of
  :mod:`morphogen.models.fixed_points` (:func:`fixed_states`) and ``ξ`` uniform in ``[-1, 1)``
  drawn from the shared field; a genome without a valid fixed point starts from the shared
  field itself, uniform in ``[0, init_high)``. The shared noise is the "new, random initial
  condition" (§3.1); a Turing-unstable genome grows its pattern from it, whatever its
  well-mixed system does from other starts.
- ``"steady"``: every individual starts near its own homogeneous state, ``s* · (1 +
  init_noise · ξ)`` per cell and species, with ``ξ`` uniform in ``[-1, 1)`` (the shared field)
  and ``s*`` the state its well-mixed system (the reaction alone, one cell, explicit Euler at
  ``dt``) reaches from ``s = 1`` after ``init_relax`` time units: the homogeneous steady state
  when that is an attractor of the well-mixed system, so a Turing instability grows from the
  noise. A network whose well-mixed system leaves the valid range starts invalid.
- ``"uniform"``: every individual starts from the same state, uniform in ``[0, init_high)``
  (the earlier default). Far from the homogeneous state of many valid networks, it makes
  e.g. the seed's own Fig. 4 rates (Table 2) blow up.

The system is integrated with explicit Euler (``dt``, periodic grid, 5-point Laplacian) to
``t_start``, then scored every ``interval`` time units, ``rounds`` times; the fitness is the
mean of the rounds (Table 1: ``t = 2000``, every 200, 10 rounds). An individual that is invalid
at any round (NaN, Inf, beyond ``s_max`` or negative: the bounds of
:func:`~morphogen.search.networks.cluster.valid_cells` with ``nonnegative``) scores ``INVALID``
and its state is zeroed, so it can no longer produce NaN for the rest of the evaluation.

Stage one of the seed's incremental evaluation (§3.3: "eliminate these invalid individuals as
soon as possible") is also applied on the way to ``t_start``: the bounds are checked
:data:`CHECKS` times (every ``max(ceil(start_steps / CHECKS), round_steps)`` steps), and after
every check or round only the individuals still valid are integrated further (an invalid one
keeps its zeroed state), gathered into a batch padded to the next power of two, at
least 8 (so a run compiles at most ``log2(P) - 1`` batch sizes per chunk length).

Each chunk is one ``lax.scan`` over the batch laid out with the member axis innermost
(:mod:`morphogen.search.networks.lanes`), the network structure as runtime data: one compile
per batch size and number of used evolvable slots, never per topology.

The loop state (population, fitness history, PRNG key, generation) is saved after every
generation to ``state.npz`` in the run folder, written atomically; :func:`run` resumes from it,
and the random stream depends only on ``(seed, generation)``, so a resumed run is
bit-identical to an uninterrupted one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.fixed_points import fixed_points_batch
from morphogen.models.model import Model
from morphogen.search.fitness import INVALID
from morphogen.search.networks.cluster import S_MAX, STAGE2, cluster_head_fitness
from morphogen.search.networks.genome import Genome, NetworkSpec
from morphogen.search.networks.lanes import advance_population
from morphogen.search.networks.operators import Operators, next_generation, random_population
from morphogen.search.networks.reaction import genome_params, padded_model, padded_reaction

Array = Any
INIT_KINDS = ("fixed", "steady", "uniform")
"""Initial conditions of the evaluation (module docstring)."""
LEGACY_EV = {"init": "uniform", "init_noise": 0.1, "init_relax": 5000.0, "stage2": "literal",
             "reject_checkerboards": False}
"""Settings of a run saved before an option existed: uniform starts (before
:attr:`Evaluation.init`), the literal stage two and checkerboards scored (before
:attr:`Evaluation.stage2` and :attr:`Evaluation.reject_checkerboards`)."""
LEGACY_OPS = {"draw": "log-uniform"}
"""Operator settings of a run saved before :attr:`Operators.draw` existed."""
CHECKS = 10
"""Bounds checks on the way to the first scoring round (0: none, every individual runs to it)."""
MIN_BATCH = 8
"""Smallest batch the valid individuals are gathered into (fewer compiled batch sizes)."""


@dataclass(frozen=True)
class Evaluation:
    """Phenotype and evaluation settings (Table 1 defaults).

    ``init`` picks the initial condition (module docstring). ``stage2`` reads §3.3's second
    stage, "presence of any non-homogeneous pattern"
    (:data:`~morphogen.search.networks.cluster.STAGE2`): ``"stationary"`` (default) tests
    homogeneity on the activator and ranks a non-homogeneous state without a peak by how close
    it is to one (:func:`~morphogen.search.networks.cluster.pattern_grade`) and how settled it is
    since the previous round or check
    (:func:`~morphogen.search.networks.cluster.stationarity`), ``"graded"`` by the first
    alone, ``"activator"`` only
    tests the activator, ``"literal"`` every species (the seed's words; a non-diffusing
    species keeps its start noise, so every valid genome passed). ``reject_checkerboards``
    makes a grid-scale checkerboard (a numerical artefact of the step) invalid.
    """

    size: int = 32
    dt: float = 0.1
    t_start: float = 2000.0
    interval: float = 200.0
    rounds: int = 10
    init_high: float = 2.0
    activator: int = 0
    init: str = "fixed"
    init_noise: float = 0.1
    init_relax: float = 5000.0
    stage2: str = "stationary"
    reject_checkerboards: bool = True

    def __post_init__(self) -> None:
        if self.size < 3 or self.rounds < 1 or not self.dt > 0:
            raise MorphogenError("need size >= 3, rounds >= 1 and dt > 0")
        if self.init not in INIT_KINDS:
            raise MorphogenError(f"unknown initial condition {self.init!r}; use one of "
                                 f"{', '.join(INIT_KINDS)}")
        if not 0 <= self.init_noise < 1 or self.init_relax < 0 or not self.init_high > 0:
            raise MorphogenError("need 0 <= init_noise < 1, init_relax >= 0, init_high > 0")
        if self.t_start < 0 or self.interval <= 0:
            raise MorphogenError("need t_start >= 0 and interval > 0")
        if self.stage2 not in STAGE2:
            raise MorphogenError(f"unknown stage-2 test {self.stage2!r}; use one of "
                                 f"{', '.join(STAGE2)}")

    @property
    def start_steps(self) -> int:
        return int(round(self.t_start / self.dt))

    @property
    def round_steps(self) -> int:
        return max(1, int(round(self.interval / self.dt)))

    @property
    def steps(self) -> int:
        """Steps of one individual's evaluation: to ``t_start``, then ``rounds - 1`` rounds."""
        return self.start_steps + (self.rounds - 1) * self.round_steps


def _advance(spec: NetworkSpec, size: int, steps: int, dt: float) -> Callable:
    """``advance(u, params) -> u``: ``steps`` Euler steps of a batch ``(B, n, size, size)``,
    by the population kernel of :mod:`morphogen.search.networks.lanes`."""
    return lambda u, p: advance_population(u, p, spec, steps, dt)


@lru_cache(maxsize=16)
def _breeder(spec: NetworkSpec, ops: Operators) -> Callable:
    return jax.jit(lambda k, p, f: next_generation(k, p, f, spec, ops))


@lru_cache(maxsize=16)
def _score(activator: int, stage2: str, reject_checkerboards: bool) -> Callable:
    return cluster_head_fitness(species=activator, nonnegative=True, stage2=stage2,
                                checkerboards_invalid=reject_checkerboards)


def network_fitness(ev: Evaluation) -> Callable[[Array], Array]:
    """The evaluation's staged cluster-head fitness of states ``(P, n, H, W) -> (P,)``: the
    activator scored, negative concentrations invalid, and :attr:`Evaluation.stage2` and
    :attr:`Evaluation.reject_checkerboards` as set (:func:`cluster_head_fitness`)."""
    return _score(ev.activator, ev.stage2, ev.reject_checkerboards)


def within_bounds(u: Array) -> Array:
    """Bool ``(P,)``: every value of each state ``(P, n, …)`` finite and in ``[0, s_max]``."""
    return jnp.all(jnp.isfinite(u) & (u >= 0) & (u <= S_MAX), axis=tuple(range(1, u.ndim)))


def initial_state(key: Array, spec: NetworkSpec, ev: Evaluation) -> Array:
    """The generation's shared random field ``(n, size, size)``: the initial state itself
    (``"uniform"``, and ``"fixed"``, which derives its noise factor from it), or the noise
    factor ``1 + init_noise · ξ`` (``"steady"``); the start of each individual is
    :func:`starts`."""
    shape = (spec.n, ev.size, ev.size)
    if ev.init in ("uniform", "fixed"):
        return jax.random.uniform(key, shape, jnp.float32, 0.0, ev.init_high)
    return 1.0 + ev.init_noise * jax.random.uniform(key, shape, jnp.float32, -1.0, 1.0)


@lru_cache(maxsize=16)
def _relax(spec: NetworkSpec, steps: int, dt: float) -> Callable:
    def one(p):
        def body(s, _):
            return s + dt * padded_reaction(s, p["k"], p["Me"], p["Mp"]), None

        return jax.lax.scan(body, jnp.ones(spec.n, jnp.float32), None, length=steps)[0]

    return jax.jit(jax.vmap(one))


def homogeneous_states(params: dict, spec: NetworkSpec, ev: Evaluation) -> Array:
    """``s*`` ``(P, n)``: each well-mixed system after ``init_relax`` from ``s = 1`` (Euler,
    ``dt``); non-finite or out of bounds when it leaves the valid range."""
    steps = int(round(ev.init_relax / ev.dt))
    return _relax(spec, steps, float(ev.dt))({k: params[k] for k in ("k", "Me", "Mp")})


@lru_cache(maxsize=16)
def _fixed_point_model(spec: NetworkSpec) -> Model:
    """One padded model per spec, so the fixed-point finder's compiled program is kept."""
    return padded_model(spec)


def fixed_states(params: dict, spec: NetworkSpec) -> tuple[Array, Array]:
    """Each genome's homogeneous fixed point ``u*`` ``(P, n)`` and whether it has a valid one
    ``(P,)``: a root of its reaction, ``R(u*) = 0`` (Yamamoto eqs. 2-3 without diffusion),
    found by :func:`morphogen.models.fixed_points.fixed_points_batch` (Newton in ``u`` from
    ``u = 1``, then in log-concentrations with every subset of species held at 0; float32,
    relative residual ``<= 2e-5`` of the gross rates). Of the roots found, the first with
    every species positive (an activator at 0 cannot grow a pattern), else the first; valid
    when there is one and it lies in ``[0, s_max]``."""
    model = _fixed_point_model(spec)
    points = fixed_points_batch(model, {k: params[k] for k in ("k", "Me", "Mp")},
                                jnp.ones((1, spec.n), jnp.float32), balance="mass-action")
    positive = points.found & jnp.all(points.u > 0, axis=-1)
    pick = jnp.argmax(jnp.where(positive.any(axis=-1, keepdims=True), positive, points.found),
                      axis=-1)
    u = jnp.take_along_axis(points.u, pick[:, None, None], axis=1)[:, 0]
    ok = points.found.any(axis=-1) & jnp.all(jnp.isfinite(u) & (u >= 0) & (u <= S_MAX), axis=-1)
    return u, ok


def starts(u0: Array, params: dict, spec: NetworkSpec, ev: Evaluation) -> Array:
    """Initial states ``(P, n, size, size)`` from the shared field ``u0``.

    ``"fixed"``: ``u* · (1 + init_noise · ξ)`` with ``u*`` the genome's own fixed point
    (:func:`fixed_states`) and ``ξ = 2 u0 / init_high - 1`` (uniform in ``[-1, 1)``, the same
    draw as the shared field); a genome without a valid fixed point starts from ``u0``."""
    size = params["k"].shape[0]
    if ev.init == "uniform":
        return jnp.broadcast_to(u0, (size, *u0.shape))
    if ev.init == "fixed":
        u_star, ok = fixed_states(params, spec)
        noise = 1.0 + ev.init_noise * (2.0 * u0 / ev.init_high - 1.0)
        return jnp.where(ok[:, None, None, None], u_star[:, :, None, None] * noise[None],
                         u0[None])
    return homogeneous_states(params, spec, ev)[:, :, None, None] * u0[None]


def evaluate(pop: Genome, u0: Array, spec: NetworkSpec, ev: Evaluation,
             progress: Callable[[int], None] | None = None,
             checks: int = CHECKS) -> tuple[np.ndarray, np.ndarray]:
    """Fitness ``(P,)`` (mean cluster-head score over the rounds, or ``INVALID``) and the final
    states ``(P, n, size, size)`` of a population started from the shared field ``u0``
    (:func:`initial_state`, :func:`starts`; an invalid start is invalid at once).

    ``checks`` bounds checks before ``t_start`` drop invalid individuals from the integration
    (module docstring); ``progress`` is told every chunk's nominal steps, dropped or not.
    """
    size = pop.mantissa.shape[0]
    params = genome_params(pop, spec)
    u = starts(u0, params, spec, ev)
    ok = within_bounds(u)
    u = jnp.where(ok[:, None, None, None], u, 0.0)
    total = jnp.zeros(size, jnp.float32)
    score = network_fitness(ev)
    for steps, scored in _plan(ev, checks):
        alive = np.flatnonzero(np.asarray(ok))
        before = u
        if steps and alive.size:
            u = _integrate_alive(u, params, alive, spec, ev, steps)
        within = within_bounds(u)
        if scored:
            f = score(u, before, ev.round_steps / max(steps, 1))
            ok = ok & (f != INVALID) & within
            total = total + jnp.where(ok, f, 0.0)
        else:
            ok = ok & within
        u = jnp.where(ok[:, None, None, None], u, 0.0)
        if progress is not None:
            progress(steps)
    fitness = jnp.where(ok, total / ev.rounds, INVALID)
    return np.asarray(fitness, np.float32), np.asarray(u, np.float32)


def _plan(ev: Evaluation, checks: int) -> list[tuple[int, bool]]:
    """``(steps, scored)`` chunks: the run-up to ``t_start`` cut for ``checks`` bounds checks,
    then one chunk per scoring round. A check chunk is at least a round long, so the compiled
    program of a round is reused (Table 1: 2000 steps each)."""
    start = ev.start_steps
    chunk = max(-(-start // checks), ev.round_steps) if checks > 0 and start else start
    plan = [(chunk, False)] * (start // chunk - 1) if chunk else []
    plan.append((start - chunk * len(plan), True))
    return plan + [(ev.round_steps, True)] * (ev.rounds - 1)


def _integrate_alive(u: Array, params: dict, alive: np.ndarray, spec: NetworkSpec,
                     ev: Evaluation, steps: int) -> Array:
    """Advance the individuals ``alive`` by ``steps``; the others keep their (zeroed) state.
    The batch is padded to a power of two, at least :data:`MIN_BATCH` and at most the
    population, by repeating one of them."""
    size = u.shape[0]
    batch = min(max(1 << int(np.ceil(np.log2(alive.size))), MIN_BATCH), size)
    if batch == size:
        return _advance(spec, ev.size, steps, float(ev.dt))(u, params)
    idx = jnp.asarray(np.concatenate([alive, np.full(batch - alive.size, alive[0])]))
    sub = _advance(spec, ev.size, steps, float(ev.dt))(
        u[idx], {k: v[idx] for k, v in params.items()})
    return u.at[idx[: alive.size]].set(sub[: alive.size])


def save_state(path: Path, pop: Genome, history: np.ndarray, generation: int,
               meta: dict) -> None:
    """Write a run folder's ``state.npz`` atomically (read back by :func:`load_state`)."""
    import json

    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, *[np.asarray(x) for x in pop], history=history, generation=generation,
             meta=json.dumps(meta))
    tmp.replace(path)


def load_state(path: Path, population: int | None = None
               ) -> tuple[Genome, np.ndarray, int, dict]:
    """A run folder's ``state.npz``: population, fitness history, generations done, settings;
    every part checked first (:func:`morphogen.search.networks.state_file.read_state`)."""
    from morphogen.search.networks.state_file import read_state

    pop, history, done, meta = read_state(path, population)
    return Genome(*(jnp.asarray(x) for x in pop)), history, done, meta


def run(
    spec: NetworkSpec,
    template: Genome,
    out: str | Path,
    *,
    ops: Operators,
    ev: Evaluation,
    population: int = 150,
    generations: int = 100,
    seed: int = 0,
    resume: bool = False,
    log: Callable[[str], Any] = print,
    progress: Callable[[int], None] | None = None,
    evaluator: Callable[..., tuple[np.ndarray, np.ndarray]] | None = None,
    on_generation: Callable[[int, Genome, np.ndarray], None] | None = None,
) -> tuple[Genome, np.ndarray, np.ndarray]:
    """Evolve; returns the final population, its fitness ``(P,)`` and the fitness history
    ``(generations, P)``. Saves ``state.npz`` every generation and resumes from it.

    ``evaluator`` replaces :func:`evaluate` (same signature; e.g. a Ray executor's);
    ``on_generation(gen, population, fitness)`` (0-based ``gen``) runs after each evaluation,
    before ``state.npz`` is saved (the run archive's record).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "state.npz"
    meta = {"spec": asdict(spec), "ops": asdict(ops), "ev": asdict(ev),
            "population": population, "seed": seed}
    meta = _jsonable(meta)
    root = jax.random.key(seed)
    if resume:
        if not path.exists():
            raise MorphogenError(f"nothing to resume in {out}: no state.npz")
        pop, history, done, saved = load_state(path)
        saved["ev"] = {**LEGACY_EV, **saved["ev"]}
        saved["ops"] = {**LEGACY_OPS, **saved["ops"]}
        if saved != meta:
            raise MorphogenError(f"{out} holds a run with other settings; resume it with "
                                 "those (give only --out, --resume and --generations)")
    else:
        if path.exists():
            raise MorphogenError(f"{out} already holds a run; use --resume or another --out")
        pop = random_population(jax.random.fold_in(root, 0), template, spec, population, ops)
        history = np.zeros((0, population), np.float32)
        done = 0
    breed = _breeder(spec, ops)
    fitness = history[-1] if len(history) else None
    for gen in range(done, generations):
        if gen > 0:
            pop = breed(jax.random.fold_in(root, 2 * gen + 1), pop, jnp.asarray(fitness))
        u0 = initial_state(jax.random.fold_in(root, 2 * gen + 2), spec, ev)
        fitness, _ = (evaluator or evaluate)(pop, u0, spec, ev, progress)
        history = np.concatenate([history, fitness[None]])
        if on_generation is not None:
            on_generation(gen, pop, fitness)
        save_state(path, pop, history, gen + 1, meta)
        valid = fitness > INVALID
        log(f"generation {gen + 1}/{generations}: best {fitness.max():.2f}, "
            f"mean valid {fitness[valid].mean() if valid.any() else float('nan'):.2f}, "
            f"valid {int(valid.sum())}/{population}")
    return pop, np.asarray(fitness), history


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    return x


def completed(out: str | Path, population: int | None = None) -> int:
    """Generations already saved in the run folder ``out`` (0 if none); its ``state.npz``
    checked whole (``population``: the run's ``P``)."""
    path = Path(out) / "state.npz"
    if not path.exists() and not path.is_symlink():
        return 0
    return load_state(path, population)[2]
