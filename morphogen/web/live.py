"""The live simulation behind the Explore page: one per browser tab.

A :class:`LiveSim` holds a state ``u`` of shape ``(S, h, w)`` on a periodic (or no-flux) grid
and advances it by ``steps`` steps per frame of one of the per-step schemes of
:mod:`morphogen.solvers.step` (:data:`morphogen.solvers.registry.LIVE`: explicit Euler, RK4,
IMEX, ETDRK4; see docs/schemes.md) with the jitted
:func:`morphogen.engine.simulate.integrate`, compiled once per model and grid and shared by the
tabs (:mod:`morphogen.web.engines`).
Parameters, ``dt``, the species shown and the colour scale are *runtime* arguments of the compiled
program, so moving a slider never recompiles; only the number of steps per frame is static, and it
is taken from :data:`STEP_CHOICES` so each value compiles once per model and grid.

A frame is the shown species quantised to ``uint8`` on the device,
``q = clip(255 (f - lo) / (hi - lo), 0, 255)``, with ``lo``/``hi`` following the field's range
smoothly (so the picture does not flicker); the page colours it with a 256-entry lookup table.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.engine.initial import make_initial
from morphogen.errors import MorphogenError
from morphogen.models.model import Model
from morphogen.runs.policy import default_dt, scheme_limit
from morphogen.solvers.registry import LIVE
from morphogen.web.brush import brush_values
from morphogen.web.catalog import check_params, resolve_model
from morphogen.web.engines import Engine, engine_for, pixels
from morphogen.web.image_input import image_field
from morphogen.web.limits import Limits, choice, integer, number
from morphogen.web.recording import Recorder
from morphogen.web.settings import INITIAL_KINDS, check

STEP_CHOICES = (1, 2, 4, 8, 16, 32, 64, 128, 256)
"""Allowed steps per frame (each value is one compiled program)."""

UNDO_DEPTH = 10
"""Brush strokes that can be undone (each keeps one copy of the state)."""
FRAMES_TO_PATTERN = 200
"""Default steps per frame: the model's suggested run (``t_end / dt``) in about this many
frames, i.e. about ten seconds at 20 frames/s."""
RANGE_EASING = 0.2
"""Fraction of the way the colour scale moves toward the field's range each frame."""


@dataclass
class Frame:
    """One picture of the live state: ``pixels`` ``(h, w)`` uint8, row 0 at the top."""

    pixels: np.ndarray
    frame: int
    t: float
    steps: int
    lo: float
    hi: float
    compute_s: float


class LiveSim:
    """One tab's simulation: model, parameters, ``dt``, state and colour scale.

    Every method takes the instance lock, so a frame, a paint stroke and a reset from the same
    tab never interleave; different tabs have different instances and share nothing mutable.
    """

    def __init__(self, limits: Limits):
        self.limits = limits
        self.lock = threading.Lock()
        self.last_used = time.monotonic()
        self.error: str | None = None
        self.frames = 0
        self.total_steps = 0
        self.seed = 0
        self.init = "square"
        self.steps_per_frame = 16
        self.cmap = "viridis"
        self.spec: dict[str, Any] = {"library": "gray-scott"}
        self.size = 256
        self.height = 256
        self.boundary = "periodic"
        self.scheme = "euler"
        self.dx = 1.0
        self.stencil: int | str | None = None
        self.fixed: tuple[float, float] | None = None
        self.undo_stack: list[Any] = []
        self.recorder = Recorder()
        self.maps: dict[str, tuple[np.ndarray, dict[str, Any]]] = {}
        self.limit: float | None = None  # the dt limit of the current settings, once computed

    # -- configuration --------------------------------------------------------------------
    def configure(self, spec: Mapping[str, Any], size: int = 256, boundary: str = "periodic",
                  params: Mapping[str, Any] | None = None, preset: str | None = None,
                  init: str | None = None, seed: int = 0, height: int | None = None,
                  scheme: str = "euler", dx: float = 1.0,
                  stencil: int | str | None = None) -> dict[str, Any]:
        """Choose the model, the grid (``size`` cells wide, ``height`` high, square when
        ``None``; cell spacing ``dx``; Laplacian ``stencil``, the grid's default when ``None``)
        and the time stepper, set parameters (defaults, a preset, then overrides) and reset to
        initial condition ``init`` (the model's suggestion when ``None``). Validates everything
        before changing anything."""
        lim = self.limits
        size = integer(size, "size", lim.min_size, lim.max_size)
        height = size if height is None else integer(height, "height", lim.min_size,
                                                     lim.max_size)
        boundary = check("boundary", boundary)
        scheme = check("scheme", scheme)
        dx = check("dx", dx)
        stencil = None if stencil is None else check("stencil", stencil)
        model, key = resolve_model(spec, lim)
        if preset is not None and preset not in model.presets:
            model.parameters(preset=preset)  # raises the one-line error listing presets
        values = model.parameters(check_params(params or {}, model), preset=preset or None)
        eng = engine_for(model, key, (height, size), boundary, scheme, dx=dx, stencil=stencil)
        values = {k: float(v) for k, v in values.items()}
        u0, init, seed = _initial(eng, values, init or _offered(model.init), seed)
        with self.lock:
            self.spec = dict(spec)
            self.engine, self.size, self.height, self.boundary = eng, size, height, boundary
            self.scheme, self.dx, self.stencil = scheme, dx, stencil
            self.fixed = None
            self.values, self.maps, self.limit = values, {}, None
            self.show = model.species.index(model.display_species)
            self.dt = self.chosen_dt = self._default_dt()
            self.steps_per_frame = _default_steps(model, self.dt)
            self._install(u0, init, seed)
        return self.describe()

    def set_params(self, values: Mapping[str, Any]) -> list[str]:
        """Change parameter values; returns notices (e.g. ``dt`` lowered for stability)."""
        with self.lock:
            self._touch()
            new = {**self.values, **check_params(values, self.engine.model)}
            self.values, self.limit = new, None
            return self._fit_dt()

    def set_dt(self, dt: Any) -> list[str]:
        """Set the time step, refusing one above the explicit stability limit."""
        with self.lock:
            self._touch()
            dt_max = self._dt_max()
            self.dt = self.chosen_dt = number(dt, "dt", 1e-6, dt_max)
            return []

    def set_map(self, name: str, grey: np.ndarray | None, lo: float = 0.0, hi: float = 1.0,
                resample: str = "bilinear") -> list[str]:
        """Make parameter ``name`` the field ``lo + (hi - lo) g`` of an image's grey levels
        ``grey`` resampled onto the grid (:func:`morphogen.web.image_input.image_field`), or its
        number again with ``None``; returns notices as :meth:`set_params`. A field the stepper
        cannot take (``etdrk4`` and a diffusion map) is refused by tracing one step."""
        with self.lock:
            self._touch()
            check_params({name: lo}, self.engine.model)  # a known parameter
            maps = {k: v for k, v in self.maps.items() if k != name}
            if grey is not None:
                field = image_field(grey, tuple(self.engine.grid.shape), lo, hi, resample)
                maps[name] = (field, {"lo": lo, "hi": hi, "resample": resample})
                p = {**self.values, **{k: f for k, (f, _) in maps.items()}}
                jax.eval_shape(self.engine.step, self.u, p, self.t, jnp.float32(self.dt),
                               self.key)
            self.maps, self.limit = maps, None
            return self._fit_dt()

    def set_view(self, *, species: str | None = None, steps_per_frame: Any = None,
                 cmap: str | None = None, value_range: Any = None) -> None:
        """Species shown, steps per frame (one of :data:`STEP_CHOICES`), colour map name and
        colour range: ``"auto"`` follows the field, ``[lo, hi]`` fixes it."""
        with self.lock:
            self._touch()
            if species is not None:
                self.show = self.engine.model.species_index(str(species))
                self.lo = self.hi = None
                self.fixed = None
            if value_range is not None:
                self._set_range(value_range)
            if steps_per_frame is not None:
                n = integer(steps_per_frame, "steps per frame", 1, self.limits.max_steps_per_frame)
                if n not in STEP_CHOICES:
                    raise MorphogenError(
                        f"steps per frame must be one of {', '.join(map(str, STEP_CHOICES))}"
                    )
                self.steps_per_frame = n
            if cmap is not None:
                from morphogen.render.colour import parse_cmap

                parse_cmap(cmap)
                self.cmap = cmap

    def reset(self, init: str, seed: Any = 0) -> None:
        """Restart from initial condition ``init`` (one of :data:`INITIAL_KINDS`)."""
        with self.lock:
            self._touch()
            self._reset(init, seed)

    def paint(self, x: Any, y: Any, radius: Any = 0.03, mode: str = "excite",
              stroke: bool = False, species: Any = None, value: Any = None) -> None:
        """Set a disc at ``(x, y)`` (fractions of the width and height from the top left) to the
        model's excited state (``mode='excite'``), its ground state (``'erase'``) or ``value``
        (``'value'``). With ``species`` only that species is painted (``'value'`` needs one).
        ``stroke=True`` starts a new stroke: the state before it is kept for :meth:`undo`."""
        x = number(x, "x", 0.0, 1.0)
        y = number(y, "y", 0.0, 1.0)
        r = number(radius, "radius", 0.0, 0.5)
        with self.lock:
            self._touch()
            vals = brush_values(self.engine.model, self.values, mode, species, value)
            if stroke:
                self.undo_stack = [*self.undo_stack, self.u][-UNDO_DEPTH:]
            self.engine.program(self.steps_per_frame)
            # row 0 of the picture is y = 0 of the grid (images are drawn top-down)
            self.u = self.engine.paint(self.u, x, y, r, jnp.asarray(vals, jnp.float32))
            self.error = None

    def load_species(self, species: Any, field: np.ndarray) -> int:
        """Replace one species' state by ``field`` ``(h, w)`` (an uploaded image); one undo
        step like a stroke. Returns the strokes that can be undone."""
        with self.lock:
            self._touch()
            index = self.engine.model.species_index(species)
            if field.shape != tuple(self.engine.grid.shape):
                raise MorphogenError(f"the field is {field.shape}, the grid "
                                     f"{self.engine.grid.shape}")
            self.undo_stack = [*self.undo_stack, self.u][-UNDO_DEPTH:]
            self.u = self.u.at[index].set(jnp.asarray(field, self.u.dtype))
            self.error = None
            return len(self.undo_stack)

    def load_state(self, state: np.ndarray, t: float | None = None) -> int:
        """Replace every species' state by ``state`` ``(S, h, w)`` (a checkpoint), and the
        time by ``t`` when given (the checkpoint's own, after a server restart); one undo step
        like a stroke. Returns the strokes that can be undone."""
        with self.lock:
            self._touch()
            if state.shape != tuple(self.u.shape):
                raise MorphogenError(f"the checkpoint holds {state.shape[1:]} cells, the grid "
                                     f"{tuple(self.u.shape[1:])}")
            self.undo_stack = [*self.undo_stack, self.u][-UNDO_DEPTH:]
            self.u = jnp.asarray(state, self.u.dtype)
            if t is not None:
                self.t = jnp.float32(t)
            self.error = None
            return len(self.undo_stack)

    def undo(self) -> int:
        """Put back the state from before the last brush stroke (time and everything that grew
        since stay as they are: only the painted cells' history is replaced, as in a paint
        program); returns the strokes left to undo."""
        with self.lock:
            self._touch()
            if not self.undo_stack:
                raise MorphogenError("nothing to undo: no brush stroke since the last reset")
            self.u = self.undo_stack.pop()
            self.error = None
            return len(self.undo_stack)

    def probe(self, x: Any, y: Any) -> dict[str, Any]:
        """Every species' value in the cell under ``(x, y)`` (fractions from the top left)."""
        x = number(x, "x", 0.0, 1.0)
        y = number(y, "y", 0.0, 1.0)
        with self.lock:
            h, w = self.engine.grid.shape
            i, j = min(int(y * h), h - 1), min(int(x * w), w - 1)
            cell = np.asarray(self.u[:, i, j], np.float64)
            species = self.engine.model.species
            return {"row": i, "col": j, "values": dict(zip(species, map(float, cell),
                                                           strict=True))}
    # -- stepping ---------------------------------------------------------------------------
    def frame(self) -> Frame:
        """Advance ``steps_per_frame`` steps and return the picture.

        On blow-up the previous state is kept, the simulation pauses and :attr:`error` says
        what happened (the page shows it); a later reset, paint or smaller ``dt`` resumes it.
        """
        with self.lock:
            self._touch()
            n = self.steps_per_frame
            if self.error is None:
                start = time.perf_counter()
                run = self.engine.program(n)
                p = {k: jnp.asarray(v, jnp.float32) for k, v in self._params().items()}
                lo, hi = self._scale()
                u, t, key, img, fmin, fmax, ok = run(
                    self.u, p, self.t, jnp.float32(self.dt), self.key, self.show, lo, hi
                )
                if bool(ok):
                    self.u, self.t, self.key = u, t, key
                    self.pixels = np.asarray(img)
                    self._follow(float(fmin), float(fmax))
                    self.recorder.add(self.pixels)
                    self.total_steps += n
                    self.frames += 1
                else:
                    self.error = (
                        f"the simulation blew up (NaN or overflow) within {n} steps after "
                        f"t={float(self.t):g}; lower dt, change the parameters or reset"
                    )
                self.compute_s = time.perf_counter() - start
            return Frame(self.pixels, self.frames, float(self.t), self.total_steps,
                         float(self.lo), float(self.hi), self.compute_s)

    def still(self) -> Frame:
        """The current state as a picture, without advancing time (what the page shows after a
        reset or a brush stroke while paused); the same colour scaling as :meth:`frame`."""
        with self.lock:
            self._touch()
            f = np.asarray(self.u[self.show], np.float32)
            self._scale()
            self._follow(float(f.min()), float(f.max()))  # a stroke beyond the range shows
            lo, hi = np.float32(self.lo), np.float32(self.hi)
            self.pixels = np.asarray(pixels(f, lo, hi))
            self.frames += 1
            return Frame(self.pixels, self.frames, float(self.t), self.total_steps,
                         float(self.lo), float(self.hi), self.compute_s)

    def field(self) -> np.ndarray:
        """The shown species as a float array ``(h, w)``."""
        with self.lock:
            return np.asarray(self.u[self.show], np.float64)

    def state(self) -> np.ndarray:
        """The whole state ``(S, h, w)`` as float32."""
        return self.snapshot()[0]

    def snapshot(self) -> tuple[np.ndarray, float]:
        """The whole state ``(S, h, w)`` as float32 and its time, read together."""
        with self.lock:
            return np.asarray(self.u, np.float32), float(self.t)

    # -- description ------------------------------------------------------------------------
    def describe(self) -> dict[str, Any]:
        """Settings as JSON (the page rebuilds its controls from this)."""
        model = self.engine.model
        return {
            "model": model.name,
            "spec": self.spec,
            "species": list(model.species),
            "show": model.species[self.show],
            "params": dict(self.values),
            "maps": {k: info for k, (_, info) in self.maps.items()},
            "dt": self.dt,
            "dt_max": self._dt_max(),
            "size": self.size,
            "height": self.height,
            "boundary": self.boundary,
            "scheme": self.scheme,
            "schemes": list(LIVE),
            "dx": self.dx,
            "stencil": self.stencil,
            "range": list(self.fixed) if self.fixed else "auto",
            "undo": len(self.undo_stack),
            "recording": self.recorder.describe(),
            "init": self.init,
            "seed": self.seed,
            "steps_per_frame": self.steps_per_frame,
            "cmap": self.cmap,
            "t": float(self.t),
            "steps": self.total_steps,
            "error": self.error,
            "step_choices": list(STEP_CHOICES),
            "init_kinds": list(INITIAL_KINDS),
        }

    # -- internals --------------------------------------------------------------------------
    def _touch(self) -> None:
        self.last_used = time.monotonic()

    def _reset(self, init: str, seed: Any) -> None:
        self._install(*_initial(self.engine, self.values, init, seed))

    def _install(self, u0: np.ndarray, init: str, seed: int) -> None:
        self.u = jnp.asarray(u0, jnp.float32)
        self.t = jnp.float32(0.0)
        self.key = jax.random.PRNGKey(seed)
        self.init, self.seed = init, seed
        self.total_steps = 0
        self.frames = 0
        self.error = None
        self.lo = self.hi = None
        self.compute_s = 0.0
        self.pixels = np.zeros((self.height, self.size), np.uint8)
        self.undo_stack = []

    def _set_range(self, value_range: Any) -> None:
        if value_range == "auto":
            self.fixed = None
            self.lo = self.hi = None
            return
        if not isinstance(value_range, list | tuple) or len(value_range) != 2:
            raise MorphogenError('colour range must be "auto" or [low, high]')
        lo = number(value_range[0], "colour range low", -1e30, 1e30)
        hi = number(value_range[1], "colour range high", -1e30, 1e30)
        if not hi > lo:
            raise MorphogenError(f"colour range needs low < high, got [{lo:g}, {hi:g}]")
        self.fixed = (lo, hi)
        self.lo, self.hi = lo, hi

    def _params(self) -> dict[str, Any]:
        """The values a step uses: the numbers, with parameter maps in place of theirs."""
        return {**self.values, **{k: f for k, (f, _) in self.maps.items()}}

    def _dt_max(self) -> float:
        """The scheme's ``dt`` limit for the current parameters and maps, computed once per
        change of them (it linearises about the ground state: :mod:`morphogen.web.engines`)."""
        if self.limit is None:
            self.limit = scheme_limit(self.engine.model, self.engine.grid, self._params(),
                                      self.scheme)
        return self.limit

    def _default_dt(self) -> float:
        """The run policy's step for the current scheme, parameters and maps
        (:func:`morphogen.runs.policy.resolve_run`: the model's ``dt`` within an explicit
        scheme's limit, the limit of a scheme that treats diffusion implicitly), the same as
        the command line's."""
        return default_dt(self.engine.model, self.scheme, self._dt_max())[0]

    def _fit_dt(self) -> list[str]:
        """Keep ``dt`` below the stability limit after a parameter change: the policy's step
        (:meth:`_default_dt`) while the chosen ``dt`` is above the limit, back to the chosen
        one once it fits."""
        dt_max = self._dt_max()
        before = self.dt
        self.dt = self.chosen_dt if self.chosen_dt <= dt_max else self._default_dt()
        if self.dt < before:
            return [f"dt lowered to {self.dt:.4g} to stay below the stability limit {dt_max:.4g}"]
        if self.dt > before:
            return [f"dt back up to {self.dt:.4g}"]
        return []

    def _scale(self) -> tuple[np.float32, np.float32]:
        if self.fixed is not None:
            self.lo, self.hi = self.fixed
        elif self.lo is None:
            f = np.asarray(self.u[self.show])
            self.lo, self.hi = float(f.min()), float(f.max())
        return np.float32(self.lo), np.float32(self.hi)

    def _follow(self, fmin: float, fmax: float) -> None:
        """Ease the colour scale toward ``[fmin, fmax]`` (jumping out at once if exceeded);
        a fixed range stays."""
        if self.fixed is not None:
            return
        lo = self.lo + RANGE_EASING * (fmin - self.lo)
        hi = self.hi + RANGE_EASING * (fmax - self.hi)
        self.lo, self.hi = min(lo, fmin), max(hi, fmax)


def _offered(kind: str) -> str:
    """The model's suggested initial condition if the page offers it, else ``square``."""
    return kind if kind in INITIAL_KINDS else "square"


def _default_steps(model: Model, dt: float) -> int:
    """The step choice nearest ``t_end / dt / FRAMES_TO_PATTERN``, between 4 and 64."""
    want = model.t_end / dt / FRAMES_TO_PATTERN
    options = [n for n in STEP_CHOICES if 4 <= n <= 64]
    return min(options, key=lambda n: abs(np.log(n / max(want, 1e-9))))


def _initial(eng: Engine, values: Mapping[str, float], init: Any,
             seed: Any) -> tuple[np.ndarray, str, int]:
    """Validated initial condition: ``(u0 (S, h, w), init, seed)``."""
    init = choice(init, "initial condition", INITIAL_KINDS)
    seed = integer(seed, "seed", 0, 2**31 - 1)
    return make_initial(init, eng.model, eng.grid, values, seed=seed), init, seed
