"""The schema of a run: every setting of ``run.json``'s ``config`` object, type and range.

One schema serves run files, ``--config`` and the command line (whose flags become the same
settings), so a run is refused with one line before anything is computed or written:
types are strict (``steps: 2.5``, ``size: "a"`` or ``model: 5`` are errors, never coerced),
numbers are finite, bounds are ordered, and display settings (colour map, ``fps``,
``animation``) are checked as well as the simulation's. The fields are the rows of
:data:`morphogen.runs.settings.SETTINGS`; the names their ``schema`` texts use are defined here.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictStr, ValidationError, model_validator

from morphogen.errors import MorphogenError
from morphogen.runs.settings import SEED_MAX
from morphogen.solvers.registry import NAMES

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Count = Annotated[int, Field(ge=1)]
Value = Annotated[float, Field(allow_inf_nan=False)] | StrictStr
Bound = Annotated[list[Finite], Field(min_length=2, max_length=2)]
Seed = Annotated[int, Field(ge=0, le=SEED_MAX)]
Size = Annotated[list[Annotated[int, Field(ge=3)]], Field(min_length=2, max_length=3)]
Rate = Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)]

Scheme = Literal[NAMES]
"""``scheme``: a name of :data:`morphogen.solvers.registry.NAMES`."""


class NoiseSchema(BaseModel):
    """``noise``: amplitude, kind, and the species it acts on (all when absent)."""

    model_config = ConfigDict(extra="forbid", strict=True)
    amplitude: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    kind: Literal["additive", "multiplicative"] = "additive"
    species: list[StrictStr] | tuple[StrictStr, ...] = ()


def _ordered(self: BaseModel) -> BaseModel:
    """Checks across settings: ordered bounds, ``steps`` or ``time``, a known colour map."""
    if isinstance(self.clamp, list) and not self.clamp[0] < self.clamp[1]:
        raise ValueError(f"clamp needs LO < HI, got {self.clamp}")
    if self.vmin is not None and self.vmax is not None and not self.vmin < self.vmax:
        raise ValueError(f"vmin must be below vmax, got {self.vmin:g} and {self.vmax:g}")
    if self.steps is not None and self.time is not None:
        raise ValueError("give either steps or time, not both")
    if self.cmap is not None:
        from morphogen.render.colour import check_cmap

        check_cmap(self.cmap)
    return self


class RunSchema(BaseModel):
    """Every field of :class:`morphogen.runs.config.RunConfig`, one per row of
    :data:`morphogen.runs.settings.SETTINGS`: the row's ``schema`` text is the field's type, its
    default the field's (``tests/runs/test_settings_table.py`` checks that they agree)."""

    model_config = ConfigDict(extra="forbid", strict=True)

    model: Annotated[StrictStr, Field(min_length=1)]
    model_source: StrictStr | None = None
    preset: StrictStr | None = None
    params: dict[StrictStr, Value] = {}
    size: Size = [256, 256]
    mesh: StrictStr | None = None
    mesh_fields: list[StrictStr] = []
    dx: Positive = 1.0
    boundary: StrictStr | dict[StrictStr, StrictStr] = "periodic"
    stencil: Literal[5, 7, 9, 'spectral'] | None = None
    dt: Positive | None = None
    steps: Count | None = None
    time: Positive | None = None
    scheme: Scheme = "euler"
    rtol: Positive | None = None
    atol: Positive | None = None
    seed: Seed = 0
    init: StrictStr | None = None
    init_options: dict[StrictStr, Value] = {}
    noise: NoiseSchema | None = None
    clamp: Literal["model"] | Bound | None = "model"
    every: Count | None = None
    species: StrictStr | None = None
    cmap: StrictStr | None = None
    vmin: Finite | None = None
    vmax: Finite | None = None
    threshold: Finite | None = None
    fps: Rate = 12.0
    animation: Literal["gif", "mp4"] = "gif"
    unsafe: bool = False
    precision: Literal["float32", "float64"] = "float32"

    _ordered = model_validator(mode="after")(_ordered)


def validate_config(data: Any, where: str = "run") -> None:
    """Check a ``config`` mapping against :class:`RunSchema`; one line on the first error."""
    if not isinstance(data, dict):
        raise MorphogenError(f"{where}: the config must be an object, not {type(data).__name__}")
    try:
        RunSchema.model_validate(data)
    except ValidationError as exc:
        raise MorphogenError(f"{where}: {_first(exc)}") from None


def _first(exc: ValidationError) -> str:
    """The first error as ``setting 'a.b': message (got VALUE)``."""
    err = exc.errors(include_url=False)[0]
    loc = ".".join(str(part) for part in err["loc"] if not _is_union_tag(part))
    got = repr(err.get("input"))
    got = got if len(got) <= 60 else got[:57] + "..."
    msg = err["msg"].removeprefix("Value error, ")
    if not loc:
        return msg
    return f"setting {loc!r}: {msg} (got {got})"


def _is_union_tag(part: Any) -> bool:
    """Pydantic names union members in locations (``function-after[...]``, ``list[...]``)."""
    return isinstance(part, str) and ("[" in part or part in ("str", "int", "float", "bool",
                                                                "literal['model']"))
