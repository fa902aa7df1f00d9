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
from morphogen.runs.settings import REQUIRED, SEED_MAX, SETTINGS
from morphogen.solvers.registry import NAMES

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Count = Annotated[int, Field(ge=1)]
Value = Annotated[float, Field(allow_inf_nan=False)] | StrictStr
Bound = Annotated[list[Finite], Field(min_length=2, max_length=2)]
Seed = Annotated[int, Field(ge=0, le=SEED_MAX)]

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


def _schema() -> type[BaseModel]:
    """:class:`RunSchema` from :data:`morphogen.runs.settings.SETTINGS`: each row's ``schema``
    text is its field's type (read in this module's namespace), its default the field's."""
    namespace: dict[str, Any] = {
        "__module__": __name__,
        "__qualname__": "RunSchema",
        "__doc__": "Every field of :class:`morphogen.runs.config.RunConfig`, one per row of "
                   ":data:`morphogen.runs.settings.SETTINGS`.",
        "__annotations__": {s.name: s.schema for s in SETTINGS},
        "model_config": ConfigDict(extra="forbid", strict=True),
        "_ordered": model_validator(mode="after")(_ordered),
    }
    namespace.update({s.name: s.default for s in SETTINGS if s.default is not REQUIRED})
    return type("RunSchema", (BaseModel,), namespace)


RunSchema = _schema()


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
