"""The search: every candidate model's box as batched populations, in three stages.

Each population is one batched simulation (:class:`morphogen.search.evaluate.Evaluator` over
:func:`morphogen.engine.simulate.integrate`) on the model's 64² search grid
(:mod:`morphogen.match.boxes`); each final display species is scored against the picture.

1. **explore** (:data:`SHARES` ``[0]`` of the budget, split evenly between the models): the
   model's presets inside its box, then uniform samples of it, scored by the descriptor
   distance of :mod:`morphogen.match.signature` (families first: a mismatch alone costs 1).
2. **exploit** (``[1]``): CMA-ES (:class:`morphogen.search.cmaes.CMAES`, the library's ask/tell
   strategy) on the two best models, each in its box narrowed to ±25 % of the ranges around its
   best sample, minimising the same distance.
3. **refine** (``[2]``): CMA-ES again around the two best candidates, ±10 %, now minimising the
   distance plus the rotation-invariant texture loss of seed 002
   (:func:`morphogen.learn.loss.texture_loss` with random-filter statistics) against the
   picture rescaled so that its wavelength equals the candidate's.

Every sample's score is ``distance + TEXTURE_WEIGHT * texture`` (the texture loss is measured
for every population, so the ranking is one scale); the wavelength never enters the score, since
the answer fits the grid spacing to it (:mod:`morphogen.match.answer`). Gradient refinement is
not used: through an unrolled Gray-Scott simulation its loss has flat plateaus bounded by cliffs
at the bifurcation boundaries, and the population stages above cross them.

Every population is written to a journal (one ``.npz`` per population, keyed by stage, model
and generation) before the next starts. Randomness is a pure function of the seed and that key,
so an interrupted search resumed from its journal re-asks the same genomes, reads their scores
back instead of simulating them, and continues exactly as the uninterrupted search would have.
"""

from __future__ import annotations

import json
import shutil
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.match.boxes import SEARCH_SIZE, Box, preset_genomes
from morphogen.match.signature import Signature, distance, normalise, signature
from morphogen.search.genes import Gene
from morphogen.util.io import read_text, write_json, write_npz

SHARES = (0.4, 0.4, 0.2)
"""Shares of the budget for explore, exploit and refine."""

POPULATION = 8
"""CMA-ES population of the exploit and refine stages."""

TEXTURE_WEIGHT = 1.0
"""Weight of the texture loss in a sample's score."""

TEXTURE_SIDE = 68
"""Side of the rescaled picture the texture loss is built from (its rotated crops are 48²)."""

FLAT = 5.0
"""Distance given to a uniform or invalid field (no pattern)."""

UNRESOLVED = 1.0
"""Extra distance for a pattern whose wavelength is under 4 cells or over a third of the grid:
the search grid does not resolve it, so its descriptors cannot be trusted."""


@dataclass
class Samples:
    """Every scored sample of a search, in the order evaluated (one row per sample)."""

    model: list[str] = field(default_factory=list)
    stage: list[str] = field(default_factory=list)
    genome: list[np.ndarray] = field(default_factory=list)
    distance: list[float] = field(default_factory=list)
    texture: list[float] = field(default_factory=list)
    invert: list[bool] = field(default_factory=list)
    family: list[str] = field(default_factory=list)
    wavelength: list[float] = field(default_factory=list)

    def add(self, model: str, stage: str, rec: dict[str, np.ndarray]) -> None:
        for i in range(len(rec["distance"])):
            self.model.append(model)
            self.stage.append(stage)
            self.genome.append(np.asarray(rec["genomes"][i], np.float64))
            self.distance.append(float(rec["distance"][i]))
            self.texture.append(float(rec["texture"][i]))
            self.invert.append(bool(rec["invert"][i]))
            self.family.append(str(rec["family"][i]))
            self.wavelength.append(float(rec["wavelength"][i]))

    @property
    def score(self) -> np.ndarray:
        """``distance + TEXTURE_WEIGHT * texture`` per sample, shape ``(N,)``."""
        return np.asarray(self.distance) + TEXTURE_WEIGHT * np.asarray(self.texture)

    def __len__(self) -> int:
        return len(self.distance)


class Journal:
    """Populations already scored, one ``.npz`` each in ``directory`` (``None``: kept in memory).

    ``identity`` (the picture's signature and the search settings) is written first; a journal
    made for another picture or other settings is refused rather than mixed in.
    """

    def __init__(self, directory: Path | None, identity: dict):
        self.directory = directory
        self.memory: dict[str, dict[str, np.ndarray]] = {}
        self.made = False
        self.written = False
        if directory is None:
            return
        stamp = directory / "identity.json"
        if stamp.exists():
            try:
                same = json.loads(read_text(stamp, "match journal")) == \
                    json.loads(json.dumps(identity))
            except (MorphogenError, ValueError):
                same = False
            if not same:
                raise MorphogenError(
                    f"{directory} holds an unfinished match of another picture or with other "
                    "settings; delete it or choose another --out")
            return
        self.made = not directory.exists()
        try:
            directory.mkdir(parents=True, exist_ok=True)
            write_json(stamp, identity)
        except (OSError, MorphogenError) as exc:
            self.discard_if_empty()
            reason = exc.strerror if isinstance(exc, OSError) else str(exc)
            raise MorphogenError(f"cannot create the match's work directory {directory}: "
                                 f"{reason}") from None

    def discard_if_empty(self) -> None:
        """Remove the directory this journal made if no population was written to it (a
        refusal before the search began leaves nothing behind)."""
        if self.made and not self.written:
            self.remove()

    def remove(self) -> None:
        """Remove the journal's directory (the answer is written, or nothing can resume)."""
        if self.directory is not None:
            shutil.rmtree(self.directory, ignore_errors=True)

    def get(self, key: str) -> dict[str, np.ndarray] | None:
        if key in self.memory:
            return self.memory[key]
        path = self.directory / f"{key}.npz" if self.directory else None
        if path is not None and path.is_file():
            from morphogen.util.npz import read_npz

            try:  # the one checked reader; a damaged record is scored again
                self.memory[key] = read_npz(path, "match journal record", kinds="biufU")
            except MorphogenError:
                return None
            return self.memory[key]
        return None

    def put(self, key: str, rec: dict[str, np.ndarray]) -> None:
        self.memory[key] = rec
        if self.directory is not None:
            write_npz(self.directory / f"{key}.npz", rec)
            self.written = True


class Scorer:
    """Simulate populations of one box and score them against the picture."""

    def __init__(self, box: Box, target: Signature, picture: np.ndarray, polarity: str, seed: int):
        from morphogen.models.registry import load_model
        from morphogen.search.evaluate import Problem, cached_evaluator, policy_problem

        self.box = box
        model = load_model(box.model)
        problem = Problem(
            model=box.model, genes=box.genes, model_source=model.source,
            size=(SEARCH_SIZE, SEARCH_SIZE), dx=box.dx, seed=seed, init=model.init)
        # dt and steps from the run policy, as every front end's
        self.problem = policy_problem(problem, time=box.time, model=model)
        self.evaluator = cached_evaluator(json.dumps(self.problem.to_dict(), sort_keys=True))
        self.target, self.picture, self.polarity = target, picture, polarity

    def __call__(self, genomes: np.ndarray, key: int, progress: Callable[[int], None]
                 ) -> dict[str, np.ndarray]:
        import jax

        fitness, metrics = self.evaluator(np.asarray(genomes, np.float32),
                                          jax.random.PRNGKey(key))
        progress(len(genomes))
        return score_fields(metrics["fields"], metrics["valid"], self.target, self.picture,
                            self.polarity, genomes)


def _flat(f: np.ndarray) -> bool:
    spread = float(np.ptp(f)) if np.all(np.isfinite(f)) else 0.0
    return spread <= 1e-3 * max(1.0, float(np.max(np.abs(f))))


def score_fields(fields: np.ndarray, valid: np.ndarray, target: Signature, picture: np.ndarray,
                 polarity: str, genomes: np.ndarray) -> dict[str, np.ndarray]:
    """Score simulated fields ``(P, H, W)`` against the picture's signature: the journal record
    (``genomes``, ``distance``, ``texture``, ``invert``, ``family``, ``wavelength``)."""
    n, size = len(fields), fields.shape[-1]
    out = {"genomes": np.asarray(genomes, np.float64), "distance": np.full(n, FLAT),
           "texture": np.zeros(n), "invert": np.zeros(n, bool),
           "family": np.full(n, "uniform", "<U10"), "wavelength": np.full(n, float(size))}
    flips = {"auto": (False, True), "as-is": (False,), "inverted": (True,)}[polarity]
    for i, f in enumerate(fields):
        if not valid[i] or _flat(f):
            continue
        best = min((distance(s, target), flip, s) for flip in flips
                   for s in [signature(f, periodic=True, invert=flip)])
        d, flip, sig = best
        if not 4.0 <= sig.wavelength <= size / 3.0:
            d += UNRESOLVED
        out["distance"][i], out["invert"][i] = d, flip
        out["family"][i], out["wavelength"][i] = sig.family, sig.wavelength
    ok = out["distance"] < FLAT
    if np.any(ok):
        lam = float(np.median(out["wavelength"][ok]))
        for flip in (False, True):
            sel = ok & (out["invert"] == flip)
            if np.any(sel):
                out["texture"][sel] = texture(fields[sel], picture, target.wavelength, lam, flip)
    out["texture"][~ok] = texture_ceiling()
    return out


def texture_ceiling() -> float:
    """The texture loss given to a field with no pattern."""
    return 10.0


def texture(fields: np.ndarray, picture: np.ndarray, lam_picture: float, lam_cells: float,
            invert: bool) -> np.ndarray:
    """Texture loss (seed 002) of fields ``(P, H, W)`` against the picture rescaled by
    ``lam_cells / lam_picture`` (its wavelength then equals the fields'), ``(P,)``."""
    import jax.numpy as jnp
    from scipy import ndimage

    from morphogen.learn.loss import texture_loss

    img = normalise(picture)
    img = 1.0 - img if invert else img
    scaled = ndimage.zoom(img, lam_cells / lam_picture, order=1, mode="mirror")
    while min(scaled.shape) < TEXTURE_SIDE:
        scaled = np.concatenate([scaled, scaled[::-1]], axis=0)
        scaled = np.concatenate([scaled, scaled[:, ::-1]], axis=1)
    top = (scaled.shape[0] - TEXTURE_SIDE) // 2
    left = (scaled.shape[1] - TEXTURE_SIDE) // 2
    crop = scaled[top:top + TEXTURE_SIDE, left:left + TEXTURE_SIDE]
    loss = texture_loss(np.repeat(crop[..., None], 3, axis=-1), _extractor(), n_rot=4)
    rgb = np.stack([normalise(f) for f in fields])
    rgb = 1.0 - rgb if invert else rgb
    return np.asarray(_apply(loss, jnp.repeat(jnp.asarray(rgb)[..., None], 3, axis=-1)),
                      np.float64)


def _extractor():  # noqa: ANN202 (a frozen extractor shared by every call)
    from morphogen.learn.features import RandomFeatures

    return RandomFeatures(levels=3, width=16, quantiles=16)


def _apply(loss, rgb):  # noqa: ANN001, ANN202 (jitted once per shape)
    global _APPLY
    if _APPLY is None:
        import jax

        _APPLY = jax.jit(lambda lo, x: lo(x))
    return _APPLY(loss, rgb)


_APPLY = None


def narrowed(genes: Sequence[Gene], centre: np.ndarray, fraction: float) -> tuple[Gene, ...]:
    """``genes`` restricted to ``centre ± fraction`` of each range (inside the box)."""
    out = []
    for g, c in zip(genes, centre, strict=True):
        half = fraction * g.width
        lo = max(g.low, float(c) - half)
        hi = min(g.high, float(c) + half)
        if hi - lo < 1e-9 * max(1.0, abs(hi)):
            lo, hi = g.low, g.high
        out.append(Gene(g.name, lo, hi, g.sigma))
    return tuple(out)


@dataclass
class Budget:
    """Simulations left and the wall-clock limit."""

    total: int
    minutes: float | None
    started: float = field(default_factory=time.perf_counter)
    used: int = 0

    def over(self) -> bool:
        late = (self.minutes is not None
                and time.perf_counter() - self.started > 60.0 * self.minutes)
        return late or self.used >= self.total


def run_search(boxes: Sequence[Box], target: Signature, picture: np.ndarray, *, budget: Budget,
               journal: Journal, polarity: str, seed: int,
               progress: Callable[[int], None]) -> Samples:
    """Explore, exploit, refine (module docstring); returns every scored sample."""
    samples = Samples()
    scorers: dict[str, Scorer] = {}

    def scorer(box: Box) -> Scorer:
        if box.model not in scorers:
            scorers[box.model] = Scorer(box, target, picture, polarity, seed)
        return scorers[box.model]

    def population(key: str, box: Box, genomes: np.ndarray, stage: str) -> dict | None:
        rec = journal.get(key)
        if rec is None:
            if budget.over():
                return None
            rec = scorer(box)(genomes, seed, progress)
            journal.put(key, rec)
        else:
            if not np.allclose(rec["genomes"], genomes, rtol=1e-6, atol=1e-9):
                raise MorphogenError(f"the journal's population {key} differs from the one "
                                     "asked again; delete the unfinished match and start over")
            progress(len(genomes))
        budget.used += len(genomes)
        samples.add(box.model, stage, rec)
        return rec

    each = max(4, round(SHARES[0] * budget.total / len(boxes)))
    draws = []
    for m, box in enumerate(boxes):
        low = np.array([g.low for g in box.genes])
        high = np.array([g.high for g in box.genes])
        uniform = np.random.default_rng([seed, 1, m]).uniform(low, high, (each, len(low)))
        draws.append(np.concatenate([preset_genomes(box), uniform])[:each])
    for c in range(0, each, 2 * POPULATION):  # round robin, so a time limit cuts every model
        for m, box in enumerate(boxes):
            population(f"explore-{m}-{c}", box, draws[m][c:c + 2 * POPULATION], "explore")
    ranked = _best_per_model(samples, boxes)
    gens = max(1, round(SHARES[1] * budget.total / (2 * POPULATION)))
    for m, box, centre in ranked[:2]:
        _cmaes(population, f"exploit-{m}", box, narrowed(box.genes, centre, 0.25), gens,
               seed, "exploit", budget)
    finalists = _best_per_model(samples, boxes)[:2]
    gens = max(1, round(SHARES[2] * budget.total / (len(finalists) * POPULATION)))
    for m, box, centre in finalists:
        _cmaes(population, f"refine-{m}", box, narrowed(box.genes, centre, 0.1), gens, seed,
               "refine", budget)
    return samples


def _best_per_model(samples: Samples, boxes: Sequence[Box]) -> list[tuple[int, Box, np.ndarray]]:
    """``(index, box, best genome)`` of each model that has samples, best score first."""
    score = samples.score
    out = []
    for m, box in enumerate(boxes):
        rows = [i for i, name in enumerate(samples.model) if name == box.model]
        if rows:
            i = min(rows, key=lambda r: score[r])
            out.append((float(score[i]), m, box, samples.genome[i]))
    out.sort(key=lambda t: t[0])
    return [(m, box, g) for _, m, box, g in out]


def _cmaes(population: Callable, key: str, box: Box, genes: tuple[Gene, ...], generations: int,
           seed: int, stage: str, budget: Budget) -> None:
    """CMA-ES generations on ``genes`` (a narrowed box), minimising the score."""
    import jax

    from morphogen.search.cmaes import CMAES

    strategy = CMAES(population_size=POPULATION, sigma_init=0.3)
    master = jax.random.fold_in(jax.random.PRNGKey(seed), zlib.crc32(key.encode()) % (2**31))
    state = strategy.init(jax.random.fold_in(master, 0), genes)
    for gen in range(generations):
        if budget.over():
            return
        genomes, state = strategy.ask(jax.random.fold_in(master, gen + 1), state)
        genomes = np.asarray(genomes, np.float64)
        rec = population(f"{key}-{gen}", box, genomes, stage)
        if rec is None:
            return
        fitness = -(rec["distance"] + TEXTURE_WEIGHT * rec["texture"])
        state, _ = strategy.tell(np.asarray(genomes, np.float32), fitness.astype(np.float32),
                                 state)
