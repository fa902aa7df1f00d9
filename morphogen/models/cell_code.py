"""A model's reaction and diffusion on one grid cell, as lines of code in another language.

The model's own ``reaction`` and ``diffusion`` (a library model's functions, or a model file's
expressions compiled by :mod:`morphogen.models.expr`) are traced by JAX on one cell
(:func:`cell_jaxpr`) into the list of primitive operations (a jaxpr) that the engine compiles;
an :class:`Emitter` turns each operation into one line of a target language described by a
:class:`Dialect`: GLSL for ``export-web``'s page (:mod:`morphogen.render.webgl`), Python for
Numba in the fused CPU step (:mod:`morphogen.solvers.fused`).

Every value is a numpy object array of expressions with the value's shape (a field of the grid
is one cell: shape ``(1,)``). The expressions hold only what the dialect writes: its operators,
names the emitter makes up (``t1``, ``t2``, …), the names the caller gives the inputs and float
literals; never a model's, species' or parameter's name.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model, Tensor

TRANSPARENT = frozenset({"copy", "copy_p", "stop_gradient", "optimization_barrier",
                         "reduce_precision"})
"""Operations that pass their value through."""

_CALLS = {"pjit": "jaxpr", "closed_call": "call_jaxpr", "custom_jvp_call": "call_jaxpr",
          "custom_vjp_call": "call_jaxpr", "custom_vjp_call_jaxpr": "fun_jaxpr",
          "remat": "jaxpr", "checkpoint": "jaxpr"}


@dataclass(frozen=True)
class Dialect:
    """How a target language writes each operation: format templates over the operands'
    expressions (``{}`` in order, or ``{0}``, ``{1}``, …).

    Attributes:
        binary, unary: templates by primitive name.
        zero, one: the float constants 0 and 1 as source text (for ``x**n``, written as
            repeated multiplication by :func:`integer_pow`).
        literal: a float constant as source text (float32).
        true, false: the boolean constants.
        declare: ``declare(kind, name, expr)``, the line that binds a temporary (``kind`` is
            ``"float"`` or ``"bool"``).
        select: ``pred, on_true, on_false``.
        clamp: ``lo, x, hi``.
        to_float, to_bool: conversions of a boolean to 0/1 and of a number to a boolean.
    """

    binary: Mapping[str, str]
    unary: Mapping[str, str]
    zero: str
    one: str
    literal: Callable[[float], str]
    true: str
    false: str
    declare: Callable[[str, str, str], str]
    select: str
    clamp: str
    to_float: str
    to_bool: str


def integer_pow(n: int, dialect: Dialect) -> str:
    """The template of ``x**n`` for an integer ``n``: repeated multiplication, as XLA computes a
    small integer power; ``x**0`` is ``x * 0 + 1`` (NaN stays NaN)."""
    if n == 0:
        return f"({{0}} * {dialect.zero} + {dialect.one})"
    body = " * ".join(["{0}"] * abs(n))
    return f"({body})" if n > 0 else f"({dialect.one} / ({body}))"


class Emitter:
    """Turns jaxpr equations into lines of a :class:`Dialect`, kept in the list ``lines``.

    An operation the target lacks is a :class:`~morphogen.errors.MorphogenError`,
    ``"{who}: model {model} uses the operation '{op}', which {target} does not support"``.
    """

    def __init__(self, dialect: Dialect, *, who: str, target: str, model: str):
        self.dialect = dialect
        self.lines: list[str] = []
        self.count = 0
        self.who, self.target, self.model = who, target, model

    def refuse(self, what: str) -> MorphogenError:
        return MorphogenError(f"{self.who}: model {self.model} uses the operation {what!r}, "
                              f"which {self.target} does not support")

    def temp(self, expr: str, kind: str) -> str:
        self.count += 1
        name = f"t{self.count}"
        self.lines.append(self.dialect.declare(kind, name, expr))
        return name

    def run(self, jaxpr: Any, consts: Sequence[Any], args: Sequence[np.ndarray]) -> list:
        env: dict[Any, np.ndarray] = {}
        for var, c in zip(jaxpr.constvars, consts, strict=True):
            env[var] = self.constant(c)
        for var, a in zip(jaxpr.invars, args, strict=True):
            env[var] = a
        for eqn in jaxpr.eqns:
            ins = [self.read(env, v) for v in eqn.invars]
            outs = self.equation(eqn, ins)
            for var, val in zip(eqn.outvars, outs, strict=True):
                env[var] = val
        return [self.read(env, v) for v in jaxpr.outvars]

    def read(self, env: Mapping[Any, np.ndarray], var: Any) -> np.ndarray:
        if hasattr(var, "val"):  # a literal
            return self.constant(var.val)
        return env[var]

    def constant(self, value: Any) -> np.ndarray:
        arr = np.asarray(value)
        d = self.dialect
        if arr.dtype == bool:
            return np.vectorize(lambda b: d.true if b else d.false, otypes=[object])(arr) \
                if arr.ndim else np.array(d.true if arr else d.false, dtype=object)
        flat = [d.literal(v) for v in arr.ravel()]
        return np.array(flat, dtype=object).reshape(arr.shape)

    def elementwise(self, template: str, ins: Sequence[np.ndarray], kind: str) -> np.ndarray:
        shape = np.broadcast_shapes(*(a.shape for a in ins))
        ins = [np.broadcast_to(a, shape) for a in ins]
        out = np.empty(shape, dtype=object)
        for idx in np.ndindex(shape):
            out[idx] = self.temp(template.format(*(a[idx] for a in ins)), kind)
        return out

    def equation(self, eqn: Any, ins: list[np.ndarray]) -> list[np.ndarray]:
        name = eqn.primitive.name
        p = eqn.params
        d = self.dialect
        boolean = str(eqn.outvars[0].aval.dtype) == "bool"
        kind = "bool" if boolean else "float"
        if name in d.binary:
            return [self.elementwise(d.binary[name], ins, kind)]
        if name in d.unary:
            return [self.elementwise(d.unary[name], ins, kind)]
        if name == "integer_pow":
            return [self.elementwise(integer_pow(int(p["y"]), d), ins, kind)]
        if name in TRANSPARENT:
            return ins
        if name == "convert_element_type":
            src = str(eqn.invars[0].aval.dtype)
            if src == "bool" and not boolean:
                return [self.elementwise(d.to_float, ins, kind)]
            if boolean and src != "bool":
                return [self.elementwise(d.to_bool, ins, kind)]
            return ins
        if name == "select_n":
            pred, *cases = ins
            if len(cases) != 2:
                raise self.refuse("select_n with more than two cases")
            if str(eqn.invars[0].aval.dtype) != "bool":
                pred = self.elementwise(d.to_bool, [pred], "bool")
            return [self.elementwise(d.select, [pred, cases[1], cases[0]], kind)]
        if name == "clamp":
            return [self.elementwise(d.clamp, ins, kind)]
        if name == "slice":
            index = tuple(slice(a, b, s) for a, b, s in zip(
                p["start_indices"], p["limit_indices"], p["strides"] or [1] * len(ins[0].shape),
                strict=True))
            return [ins[0][index]]
        if name == "squeeze":
            return [np.squeeze(ins[0], axis=tuple(p["dimensions"]))]
        if name == "reshape":
            return [ins[0].reshape(p["new_sizes"])]
        if name == "expand_dims":
            return [np.expand_dims(ins[0], p["dimensions"])]
        if name == "broadcast_in_dim":
            shape, dims = p["shape"], p["broadcast_dimensions"]
            view = [1] * len(shape)
            for src, dst in enumerate(dims):
                view[dst] = ins[0].shape[src]
            return [np.broadcast_to(ins[0].reshape(view), shape)]
        if name == "concatenate":
            return [np.concatenate(ins, axis=p["dimension"])]
        if name == "stack":
            return [np.stack(ins, axis=p.get("axis", 0))]
        if name in _CALLS or "jaxpr" in p or "call_jaxpr" in p:
            sub = p.get(_CALLS.get(name, ""), p.get("jaxpr", p.get("call_jaxpr")))
            inner = getattr(sub, "jaxpr", sub)
            consts = getattr(sub, "consts", getattr(sub, "literals", []))
            n = len(inner.invars)
            return self.run(inner, consts, ins[len(ins) - n:])
        raise self.refuse(name)


def cell_jaxpr(model: Model, names: Sequence[str], *, who: str, target: str) -> Any:
    """The closed jaxpr of ``(u, p, c) -> (R(u, p, c), *D(p, c))`` on one cell, in float32.

    Its inputs: ``u`` of shape ``(S, 1)``, one scalar per parameter of ``names`` (in order),
    and the coordinates ``x``, ``y`` (shape ``(1,)``) and ``t`` (``z`` is zero: a 2D grid).
    Anisotropic diffusion (a :class:`~morphogen.models.model.Tensor`) and a model JAX cannot
    trace on one cell are a :class:`~morphogen.errors.MorphogenError` naming ``who`` (the
    command) and ``target`` (what cannot hold it).
    """
    import jax
    import jax.numpy as jnp

    def traced(u, pv, cv):
        p = dict(zip(names, pv, strict=True))
        c = {"x": cv[0], "y": cv[1], "z": jnp.zeros((1,), jnp.float32), "t": cv[2]}
        d = model.diffusion(p, c)
        if any(isinstance(x, Tensor) for x in d):
            raise MorphogenError(f"{who}: model {model.name} has anisotropic diffusion, which "
                                 f"{target} does not support")
        return model.reaction(u, p, c), tuple(jnp.asarray(x, jnp.float32) for x in d)

    try:
        return jax.make_jaxpr(traced)(jnp.zeros((len(model.species), 1), jnp.float32),
                                      [jnp.float32(0)] * len(names),
                                      [jnp.zeros((1,), jnp.float32)] * 3)
    except MorphogenError:
        raise
    except Exception as exc:  # a model JAX cannot trace on one cell
        raise MorphogenError(f"{who}: model {model.name} cannot be traced into {target} "
                             f"({type(exc).__name__})") from None
