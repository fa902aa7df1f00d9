"""The schema of a neural model file's ``config`` entry (:mod:`morphogen.models.neural`).

The entry is one JSON object::

    {"format": "morphogen-neural-rd", "version": 1,
     "config": {"channels": 12, "hidden": 64, "learn_diffusion": false},
     "metadata": {"target": "dots.png", ...}}

``format`` names the kind of file, ``version`` is a whole number no newer than this morphogen
reads, ``config`` holds exactly the :class:`~morphogen.models.neural.NeuralConfig` fields, and
``metadata`` is a free-form object whose ``target`` (when present) is a text. Pydantic is
imported here only, when a file is read, so listing models stays light.
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, StrictStr, ValidationError

from morphogen.errors import MorphogenError


class _Shape(BaseModel):
    model_config = ConfigDict(extra="forbid")

    channels: StrictInt = Field(ge=3)
    hidden: StrictInt = Field(ge=1)
    learn_diffusion: StrictBool = False


class _Metadata(BaseModel):
    model_config = ConfigDict(extra="allow")

    target: StrictStr | None = None


class _Info(BaseModel):
    model_config = ConfigDict(extra="forbid")

    format: StrictStr
    version: StrictInt = 1
    config: _Shape
    metadata: _Metadata = Field(default_factory=_Metadata)


def check_info(info: Any, where: str, kind: str, newest: int) -> tuple[dict, dict]:
    """``(NeuralConfig fields, metadata)`` of a decoded ``config`` entry.

    Args:
        info: the decoded JSON.
        where: the file, for messages.
        kind: the expected ``format``; newest: the newest ``version`` this morphogen reads.

    Raises:
        MorphogenError: one line naming the first field at fault.
    """
    if not isinstance(info, dict):
        raise MorphogenError(f"{where}: the 'config' entry must be a JSON object, not "
                             f"{type(info).__name__}; is it a morphogen neural model?")
    if info.get("format") != kind:
        raise MorphogenError(
            f"{where} is not a morphogen neural model (format {_shown(info.get('format'))}, "
            f"expected {kind!r})"
        )
    version = info.get("version", 1)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise MorphogenError(f"{where}: format version must be a whole number >= 1, got "
                             f"{_shown(version)}")
    if version > newest:
        raise MorphogenError(
            f"{where} was written by a newer morphogen (format version {version}; this one "
            f"reads version {newest} and older); upgrade morphogen to run it"
        )
    try:
        checked = _Info.model_validate(info)
    except ValidationError as exc:
        err = exc.errors(include_url=False)[0]
        loc = ".".join(str(part) for part in err["loc"]) or "config"
        if err["type"] == "missing":
            raise MorphogenError(f"{where}: the entry {loc!r} is missing") from None
        message = _MESSAGES.get(err["type"], err["msg"])
        raise MorphogenError(
            f"{where}: {loc}: {message} (got {_shown(err.get('input'))})"
        ) from None
    return checked.config.model_dump(), checked.metadata.model_dump()


_MESSAGES = {"model_type": "must be a JSON object", "dict_type": "must be a JSON object",
             "extra_forbidden": "is not a known field"}


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
