"""``match(picture) -> MatchResult``: from a picture to a model that grows a pattern like it.

Skaggs (seed 000, §6.4) wished for "an automatic fitness function which could be initialized to
target patterns which look similar to a photograph or drawing"; Richard et al. (seed 001) and
Pearson mapped Gray-Scott's ``(F, k)`` by eye, and Ringham et al. (§6) spent hours to days per
flower model. This puts the library's pieces together: the picture is described with the
simulator's own descriptors (:mod:`morphogen.match.signature`), every candidate model's box is
searched as batched populations (:mod:`morphogen.match.search`), and the best candidates come
back at the picture's scale, each a ``run.json`` that ``morphogen simulate --config`` replays
(:mod:`morphogen.match.answer`). A mesh (a ``.ply`` file, e.g. a flower pipeline's
``final.ply``) is matched through one of its vertex fields flattened onto the mesh's plane
(:mod:`morphogen.match.mesh_picture`); its wavelengths are then quoted in mesh units too.

Files (with ``out``): ``run.json`` (the best candidate), ``candidate_K.json`` and
``candidate_K.png`` (each candidate's replay), ``sheet.png`` (target | best | next best),
``report.txt`` and ``match.json``. They are written into a staging directory renamed into place
at the end, so a failed or interrupted match leaves no half-written answer; the populations
already scored are kept in a hidden work directory beside ``out`` (``.NAME.match-work``), from
which the same command resumes, and which is removed once the answer is written.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.match.answer import Candidate, answer, report_text, write_answer
from morphogen.match.boxes import DEFAULT_MODELS, resolve_boxes
from morphogen.match.mesh_picture import is_mesh_target, load_mesh_picture
from morphogen.match.picture import Picture, load_picture
from morphogen.match.search import Budget, Journal, Samples, run_search
from morphogen.match.signature import Signature, signature

POLARITIES = ("auto", "as-is", "inverted")
"""``auto``: a species' high may be the picture's light or dark; the others fix it."""

MAX_BUDGET = 100_000
"""Most simulations one match may be asked for (days of CPU; the search's draws and records
grow with it, so a mistyped ``--budget 1e12`` is refused before anything is allocated)."""


@dataclass
class MatchResult:
    """The outcome of a match.

    Attributes:
        candidates: the best candidates, best first.
        target: the picture's signature (wavelength in the picture's work pixels; times
            ``scale`` for original pixels).
        samples: every scored search sample.
        directory: where the answer was written (``None`` without ``out``).
        seconds: wall time.
        pixel_size: mesh units per pixel of a mesh target (``None`` for a picture).
    """

    candidates: list[Candidate]
    target: Signature
    scale: float
    samples: Samples
    directory: Path | None
    seconds: float
    pixel_size: float | None = None

    @property
    def best(self) -> Candidate:
        return self.candidates[0]


def describe_picture(picture: Picture) -> Signature:
    """The signature of a picture (not periodic: mirrored before it is described; a mesh's
    picture only where its mask is)."""
    return signature(picture.field, periodic=False, mask=picture.mask)


def load_target(image: str | Path | bytes | np.ndarray, *, channel: str = "auto",
                crop: tuple[int, int, int, int] | None = None,
                field: str | None = None) -> Picture:
    """A picture file or array (:func:`~morphogen.match.picture.load_picture`), or a mesh file
    with one vertex field flattened (:func:`~morphogen.match.mesh_picture.load_mesh_picture`)."""
    if is_mesh_target(image):
        if crop is not None:
            raise MorphogenError("--crop applies to a picture, not to a mesh target")
        return load_mesh_picture(image, field=field, channel=channel)  # type: ignore[arg-type]
    if field is not None:
        raise MorphogenError("--field applies to a mesh target (.ply), not to a picture")
    return load_picture(image, channel=channel, crop=crop)


def match(
    image: str | Path | bytes | np.ndarray,
    *,
    models: Sequence[str] = DEFAULT_MODELS,
    genes: Sequence[str] = (),
    budget: int = 96,
    minutes: float | None = None,
    channel: str = "auto",
    crop: tuple[int, int, int, int] | None = None,
    field: str | None = None,
    polarity: str = "auto",
    seed: int = 0,
    top: int = 3,
    out: str | Path | None = None,
    progress: bool = False,
    log: Callable[[str], Any] | None = None,
    report: Callable[[int, int], Any] | None = None,
) -> MatchResult:
    """Find the models, parameters and scale that grow a pattern like ``image``.

    Args:
        image: a picture file, an array ``(H, W)`` / ``(H, W, 3)`` in ``[0, 1]``, or a mesh
            (``.ply``) whose vertex field ``field`` is matched.
        models: library names or model files (a model without a box needs ``genes``).
        genes: ``NAME=LOW:HIGH`` ranges replacing the models' boxes.
        budget: simulations of the search (the answer's verification runs come on top).
        minutes: stop searching after this wall time (then answer with what was found).
        channel, crop: see :mod:`morphogen.match.picture` (``crop``: pictures only).
        field: a mesh target's vertex field, or ``"colours"``; ``None`` chooses (see
            :mod:`morphogen.match.mesh_picture`).
        polarity: one of :data:`POLARITIES`.
        top: number of candidates in the answer.
        out: answer directory (resumable; see the module docstring); ``None`` writes nothing.
        progress: show a progress bar with ETA on standard error.
        log: receives the lines the command prints (the target's description first).
        report: told ``(done, total)`` simulations after every population and verification
            run (``total`` is ``budget + top + 1``, as the progress bar counts); an exception
            it raises stops the match (the web app's cancel), leaving what ``out`` resumes from.

    Raises:
        MorphogenError: bad picture, model, gene, option or output directory (nothing written).
    """
    from morphogen.runs.settings import SEED_MAX
    from morphogen.util.io import check_run_dir, staged_dir
    from morphogen.util.progress import ProgressBar

    started = time.perf_counter()
    if not 8 <= int(budget) <= MAX_BUDGET:
        raise MorphogenError(f"the budget must be at least 8 and at most {MAX_BUDGET:,} "
                             f"simulations, got {budget:,}")
    if not 0 <= int(seed) <= SEED_MAX:
        raise MorphogenError(f"the seed must be a whole number from 0 to {SEED_MAX}, got {seed}")
    if minutes is not None and not minutes > 0:
        raise MorphogenError(f"minutes must be positive, got {minutes}")
    if polarity not in POLARITIES:
        raise MorphogenError(f"polarity must be one of {', '.join(POLARITIES)}, got {polarity!r}")
    if not 1 <= int(top) <= 6:
        raise MorphogenError(f"top must be between 1 and 6, got {top}")
    if out is not None:
        check_run_dir(out)
    picture = load_target(image, channel=channel, crop=crop, field=field)
    boxes = resolve_boxes(list(models), list(genes))
    target = describe_picture(picture)
    identity = {"picture": hashlib.sha256(picture.field.tobytes()).hexdigest(),
                "models": [b.model for b in boxes],
                "genes": [[g.to_dict() for g in b.genes] for b in boxes],
                "budget": int(budget), "polarity": polarity, "seed": int(seed)}
    if picture.mask is not None:
        identity["mask"] = hashlib.sha256(np.packbits(picture.mask).tobytes()).hexdigest()
    journal = Journal(_work_dir(out), identity)
    say = log or (lambda _line: None)
    if picture.note:
        say(f"{Path(picture.source).name}: {picture.note}")
    units = "" if picture.pixel_size is None else \
        f" ({target.wavelength * picture.pixel_size:.4g} mesh units)"
    say(f"target: {target.family}, wavelength {target.wavelength * picture.scale:.1f} px{units}; "
        f"searching {', '.join(b.model for b in boxes)} ({budget} simulations)")
    total = int(budget) + int(top) + 1
    bar = ProgressBar(total, enabled=progress, unit="sim", desc="match")
    done = 0

    def tick(n: int) -> None:
        nonlocal done
        bar.update(n)
        done += n
        if report is not None:
            report(min(done, total), total)

    try:
        samples = run_search(boxes, target, picture.inner, budget=Budget(int(budget), minutes),
                             journal=journal, polarity=polarity, seed=int(seed), progress=tick)
        if not any(d < 5.0 for d in samples.distance):
            journal.remove()  # a finished search: nothing to resume from
            raise MorphogenError("no candidate formed a pattern; raise --budget or name other "
                                 "--models")
        candidates = answer(samples, boxes, target, picture.field.shape, picture.scale,
                            top=int(top), seed=int(seed), journal=journal, progress=tick)
    except MorphogenError:
        journal.discard_if_empty()  # a refusal before any population leaves no journal
        raise
    finally:
        bar.close()
    seconds = time.perf_counter() - started
    result = MatchResult(candidates, target, picture.scale, samples, None, seconds,
                         picture.pixel_size)
    if out is not None:
        summary = {"picture": picture.source, "target": target.to_dict(),
                   "scale": picture.scale, "settings": identity, "seconds": round(seconds, 1),
                   "simulations": len(samples),
                   "candidates": [c.summary() for c in candidates]}
        if picture.pixel_size is not None:
            summary.update(mesh={"note": picture.note, "pixel_size": picture.pixel_size,
                                 "wavelength": target.wavelength * picture.pixel_size})
        source = f"{picture.source} ({picture.note})" if picture.note else picture.source
        text = report_text(source, target, picture.scale, candidates, samples, seconds,
                           pixel_size=picture.pixel_size)
        with staged_dir(out) as stage:
            write_answer(stage, picture.rgb, target, picture.scale, candidates, summary, text,
                         centre=picture.centre)
        journal.remove()
        result.directory = Path(out)
    return result


def _work_dir(out: str | Path | None) -> Path | None:
    """The hidden journal directory beside ``out`` (``None`` without ``out``)."""
    if out is None:
        return None
    p = Path(out).absolute()
    return p.parent / f".{p.name}.match-work"
