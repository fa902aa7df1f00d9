"""The run settings: one row per setting, from which every front end is built.

Each :class:`Setting` row names a setting of ``run.json``'s ``config`` object and says
everything the front ends need to know about it:

- its validation type (``schema``), from which :mod:`morphogen.runs.schema` builds the pydantic
  :class:`~morphogen.runs.schema.RunSchema` (one line on the first bad value);
- its Python type and default, from which :mod:`morphogen.runs.config` builds the
  :class:`~morphogen.runs.config.RunConfig` dataclass;
- its command-line flag, help and metavar, and the commands that take it, from which
  :func:`morphogen.cli.options.add_run_arguments` declares the same flag with the same help in
  ``simulate``, ``evolve``, ``atlas`` and ``fit``;
- the name, check and bounds of its value in a web request body, from which
  :func:`morphogen.web.settings.read_settings` reads the routes' JSON bodies.

Scheme choices are :mod:`morphogen.solvers.registry`'s: ``NAMES`` for a single run,
``POPULATION`` for the commands that advance a batch with one ``dt`` (search, atlas, fitting),
``LIVE`` for the web app's live view.

Adding a run setting
--------------------
One row in :data:`SETTINGS` (name, types, default, help, flag, commands, web check), then its
use where a run is resolved (:mod:`morphogen.runs.prepare`) or carried out
(:mod:`morphogen.runs.execute`). From the row follow the ``RunSchema`` field (with its
validation), the ``RunConfig`` field and its default, ``run.json``, the flag with its help in
every command the row names (:func:`morphogen.cli.options.add_run_arguments`, read back by
:func:`morphogen.cli.options.run_settings`) and the web body reader. Beyond the row:

- a flag with a textual syntax of its own (like ``--clamp LO:HI``) needs its parser in
  :data:`morphogen.cli.options.PARSERS`, named by ``parse``;
- a web route that should take it adds its name to the tuple of settings it reads
  (``LIVE_SETTINGS`` of :mod:`morphogen.web.explore`, ``BATCH_SETTINGS`` of
  :mod:`morphogen.web.batch`, ``EVOLVE_SETTINGS``, ``MESH_SETTINGS``) and passes it on;
- a population command (``evolve``, ``fit``) passes it to its
  :class:`~morphogen.search.evaluate.Problem` where the search should honour it.

This module imports neither JAX nor pydantic, so building ``--help`` stays fast.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from morphogen.solvers.registry import (
    ERROR_CONTROLLED,
    IMPLICIT_DIFFUSION,
    LIVE,
    NAMES,
    POPULATION,
    SCHEMES,
)

REQUIRED: Any = object()
"""Default of a setting that every run must give (``model``)."""

SEED_MAX = 2**32 - 1
"""Largest seed: JAX keys without x64 keep 32 bits, so larger seeds would repeat."""

COMMANDS = ("simulate", "evolve", "atlas", "fit")
"""The commands that run simulations from run settings."""
POPULATION_COMMANDS = ("evolve", "atlas", "fit")
"""The commands that advance a batch with one ``dt`` (``--scheme`` from ``POPULATION``)."""


@dataclass(frozen=True)
class Setting:
    """One run setting.

    Attributes:
        name: the key in ``run.json``'s ``config`` and the field of ``RunConfig``/``RunSchema``.
        type: its Python type, as text (the dataclass annotation).
        schema: its validation type, as text read in :mod:`morphogen.runs.schema`'s namespace
            (``Positive | None``, ``Scheme``, ...).
        default: the value of a run that does not give it (:data:`REQUIRED`: none).
        help: the flag's help, the same in every command.
        flag: the command-line flag (``--dx``), or ``None`` when there is none.
        short: a one-letter alias (``-p``).
        metavar: what ``--help`` shows for the value.
        arg: how argparse takes it: ``"value"`` (one value, checked by ``argtype``),
            ``"append"`` (repeatable), ``"switch"`` (present or not).
        argtype: name of the argparse type in :data:`morphogen.cli.options.ARG_TYPES`
            (``positive_float``, ``seed``, ...), or ``None`` for text.
        parse: name of the parser in :data:`morphogen.cli.options.PARSERS` that turns the
            flag's text into the setting's value (``size``, ``clamp``, ...), or ``None`` when
            argparse's value is the setting's.
        switch_value: the value a ``"switch"`` flag sets.
        choices: the choices (text), the same for every command, or by command and front end
            (``"web"``).
        commands: the commands that take the flag.
        web: how a web request body's value is checked (``"number"``, ``"integer"``,
            ``"choice"``, ``"stencil"``, ``"cmap"``; ``"text"`` and ``"params"`` pass as given,
            for the route to check against the model), or ``None`` when no web route reads it.
        label: its name in the web app's one-line errors (default: ``name``).
        lo, hi: the web value's bounds (a route may narrow them, e.g. to its size limits; the
            web's ``size`` is cells per side of a square or live grid).
    """

    name: str
    type: str
    schema: str
    default: Any = None
    help: str = ""
    flag: str | None = None
    short: str | None = None
    metavar: str | None = None
    arg: str = "value"
    argtype: str | None = None
    parse: str | None = None
    switch_value: Any = True
    choices: tuple | Mapping[str, tuple] | None = None
    commands: tuple[str, ...] = ()
    web: str | None = None
    label: str | None = None
    lo: float | None = None
    hi: float | None = None

    def choices_for(self, where: str) -> tuple | None:
        """The choices offered by command or front end ``where`` (``"web"`` for the live view)."""
        if isinstance(self.choices, Mapping):
            return self.choices.get(where)
        return self.choices

    @property
    def message_name(self) -> str:
        """The setting's name in the web app's one-line errors."""
        return self.label or self.name


_SCHEME_HELP = (f"time stepper ({', '.join(IMPLICIT_DIFFUSION)}: stiff diffusion on grids; "
                f"{', '.join(ERROR_CONTROLLED)}: error-controlled steps, one run at a time; "
                f"auto: {SCHEMES['auto'].summary}; see docs/schemes.md)")
"""``--scheme``'s help, its names from the scheme registry."""

SETTINGS: tuple[Setting, ...] = (
    Setting("model", "str", "Annotated[StrictStr, Field(min_length=1)]", REQUIRED),
    Setting("model_source", "str | None", "StrictStr | None"),
    Setting("preset", "str | None", "StrictStr | None",
            help="named parameter preset of the model", flag="--preset",
            commands=("simulate", "evolve", "fit"), web="text"),
    Setting("params", "dict[str, Any]", "dict[StrictStr, Value]", {},
            help="parameter: a number, an expression of x, y, z, or a .npy field (repeatable)",
            flag="--param", short="-p", metavar="NAME=VALUE", arg="append", parse="assignments",
            commands=COMMANDS, web="params"),
    Setting("size", "list[int]", "Size", [256, 256], help="grid size, e.g. 256x256 or 64x64x64",
            flag="--size", parse="size", commands=COMMANDS, web="integer", lo=8, hi=512),
    Setting("mesh", "str | None", "StrictStr | None",
            help="simulate on a triangle mesh instead", flag="--mesh", metavar="FILE.ply",
            commands=("simulate",)),
    Setting("mesh_fields", "list[str]", "list[StrictStr]", [],
            help="use the mesh's field NAME as the parameter or species of that name "
            "(repeatable; 'all' for every such field, 'none' to ignore them); a mesh field "
            "named like one is otherwise an error", flag="--mesh-field", metavar="NAME",
            arg="append", commands=("simulate",)),
    Setting("dx", "float", "Positive", 1.0, help="cell spacing", flag="--dx",
            argtype="positive_float", commands=("simulate", "evolve", "atlas"), web="number",
            lo=1e-6, hi=1e6),
    Setting("boundary", "Any", "StrictStr | dict[StrictStr, StrictStr]", "periodic",
            help="periodic | neumann | dirichlet=VALUE, or SPECIES=SPEC (repeatable)",
            flag="--boundary", metavar="SPEC", arg="append", parse="boundary",
            commands=("simulate", "evolve", "atlas"), web="choice",
            choices={"web": ("periodic", "neumann")}),
    Setting("stencil", "int | str | None", 'Literal[5, 7, 9, "spectral"] | None',
            help="Laplacian: stencil points, or spectral (periodic grids)", flag="--stencil",
            parse="stencil", choices=("5", "7", "9", "spectral"), commands=COMMANDS,
            web="stencil"),
    Setting("dt", "float | None", "Positive | None",
            help="time step (default: the model's suggestion)", flag="--dt",
            argtype="positive_float", commands=COMMANDS, web="number", lo=1e-6, hi=1e3),
    Setting("steps", "int | None", "Count | None", help="number of steps", flag="--steps",
            argtype="positive_int", commands=COMMANDS, web="integer", lo=1, hi=200_000),
    Setting("time", "float | None", "Positive | None", help="simulated time", flag="--time",
            argtype="positive_float", commands=("simulate", "evolve", "atlas")),
    Setting("scheme", "str", "Scheme", "euler", help=_SCHEME_HELP, flag="--scheme",
            choices={"simulate": NAMES, **dict.fromkeys(POPULATION_COMMANDS, POPULATION),
                     "web": LIVE},
            commands=COMMANDS, web="choice"),
    Setting("rtol", "float | None", "Positive | None",
            help="relative error tolerance of --scheme adaptive (default 1e-3)", flag="--rtol",
            argtype="positive_float", commands=("simulate",)),
    Setting("atol", "float | None", "Positive | None",
            help="absolute error tolerance of --scheme adaptive (default 1e-6)", flag="--atol",
            argtype="positive_float", commands=("simulate",)),
    Setting("seed", "int", "Seed", 0, help="random seed",
            flag="--seed", argtype="seed", commands=COMMANDS, web="integer", lo=0,
            hi=2**31 - 1),
    Setting("init", "str | None", "StrictStr | None",
            help="initial condition (default: the model's): uniform, noise, square, blobs, "
            "skaggs, seeds, random (U[low, high], --init-opt high=2), or a .npz/image file",
            flag="--init", metavar="KIND|FILE", commands=COMMANDS, web="choice",
            choices={"web": ("square", "noise", "blobs", "seeds", "skaggs", "uniform")},
            label="initial condition"),
    Setting("init_options", "dict[str, Any]", "dict[StrictStr, Value]", {},
            help="option of the initial condition, e.g. count=20, or for blobs spacing=16 "
            "sigma=2 (cells per blob, width in cells) (repeatable)", flag="--init-opt",
            metavar="NAME=VALUE", arg="append", parse="init_options",
            commands=("simulate", "evolve", "fit", "atlas")),
    Setting("noise", "dict[str, Any] | None", "NoiseSchema | None",
            help="additive or multiplicative noise, e.g. 0.01:multiplicative:u", flag="--noise",
            metavar="AMP[:KIND[:SPECIES]]", parse="noise", commands=("simulate",)),
    Setting("clamp", "Any", 'Literal["model"] | Bound | None', "model",
            help="bound values after each step", flag="--clamp", metavar="LO:HI|none",
            parse="clamp", commands=("simulate", "evolve")),
    Setting("every", "int | None", "Count | None", help="snapshot every N steps",
            flag="--every", argtype="positive_int", commands=("simulate",)),
    Setting("species", "str | None", "StrictStr | None",
            help="species to draw (default: the model's display species)", flag="--species",
            commands=("simulate", "atlas"), web="text"),
    Setting("cmap", "str | None", "StrictStr | None",
            help="matplotlib colormap, ramp '#000,#f80,#fff', or transfer function "
            "'step: #fff < 0.5 < #a00', 'ramp: 0 #fff, 0.3 #f80, 1 #000'", flag="--cmap",
            commands=("simulate", "evolve", "atlas"), web="cmap"),
    Setting("vmin", "float | None", "Finite | None", help="colour scale minimum",
            flag="--vmin", argtype="float", commands=("simulate",)),
    Setting("vmax", "float | None", "Finite | None", help="colour scale maximum",
            flag="--vmax", argtype="float", commands=("simulate",)),
    Setting("threshold", "float | None", "Finite | None",
            help="two-colour map split at this value", flag="--threshold", argtype="float",
            commands=("simulate",)),
    Setting("fps", "float", "Rate", 12.0),
    Setting("animation", "str", 'Literal["gif", "mp4"]', "gif", help="animation format",
            flag="--animation", choices=("gif", "mp4"), commands=("simulate",)),
    Setting("unsafe", "bool", "bool", False, help="skip the stability check on dt",
            flag="--unsafe", arg="switch", commands=("simulate", "atlas")),
    Setting("precision", "str", 'Literal["float32", "float64"]', "float32",
            help="compute in float64 (default float32)", flag="--x64", arg="switch",
            switch_value="float64", commands=("simulate", "atlas")),
)
"""Every run setting, in ``run.json``'s order."""

BY_NAME: dict[str, Setting] = {s.name: s for s in SETTINGS}
"""The rows by setting name."""


def default(name: str) -> Any:
    """A fresh copy of setting ``name``'s default (lists and dicts are not shared)."""
    value = BY_NAME[name].default
    return type(value)(value) if isinstance(value, list | dict) else value


def for_command(command: str) -> tuple[Setting, ...]:
    """The settings that ``command`` takes as flags, in table order."""
    return tuple(s for s in SETTINGS if command in s.commands)
