"""A model's explicit Euler step as a WebGL2 fragment shader (GLSL ES 3.00).

The shader is not a second, hand-written copy of the model: the model's own ``reaction`` and
``diffusion`` (a library model's functions, or a model file's expressions compiled by
:mod:`morphogen.models.expr`) are traced by JAX into the very list of primitive operations
(a jaxpr) that the engine compiles, and each operation becomes one line of GLSL. The step is
the engine's forward Euler, ``u + dt * (R(u) + D * lap(u))`` (:mod:`morphogen.solvers.explicit`),
with the 5- or 9-point stencil of :mod:`morphogen.domains.stencils` term for term and the ghost
cells of :mod:`morphogen.domains.grid` (wrap for periodic, the edge value for no flux).

Anything the page cannot reproduce (more than four species, parameter fields, anisotropic
diffusion, an operation GLSL lacks) is a :class:`~morphogen.errors.MorphogenError` naming it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Model, Tensor

MAX_SPECIES = 4
"""Species held in one RGBA float texture."""

_BINARY = {"add": "({} + {})", "sub": "({} - {})", "mul": "({} * {})", "div": "({} / {})",
           "max": "max({}, {})", "min": "min({}, {})", "pow": "pow({}, {})",
           "atan2": "atan({}, {})", "rem": "mod({}, {})",
           "lt": "({} < {})", "le": "({} <= {})", "gt": "({} > {})", "ge": "({} >= {})",
           "eq": "({} == {})", "ne": "({} != {})", "and": "({} && {})", "or": "({} || {})"}
_UNARY = {"neg": "(-{})", "exp": "exp({})", "log": "log({})", "sqrt": "sqrt({})",
          "rsqrt": "inversesqrt({})", "tanh": "tanh({})", "sin": "sin({})", "cos": "cos({})",
          "tan": "tan({})", "abs": "abs({})", "sign": "sign({})", "floor": "floor({})",
          "ceil": "ceil({})", "logistic": "(1.0 / (1.0 + exp(-{})))", "exp2": "exp2({})",
          "log1p": "log(1.0 + {})", "expm1": "(exp({}) - 1.0)", "square": "({0} * {0})",
          "not": "(!{})", "asin": "asin({})", "acos": "acos({})", "atan": "atan({})",
          "sinh": "sinh({})", "cosh": "cosh({})", "round": "floor({} + 0.5)"}
_TRANSPARENT = {"copy", "copy_p", "stop_gradient", "optimization_barrier", "reduce_precision"}
_CALLS = {"pjit": "jaxpr", "closed_call": "call_jaxpr", "custom_jvp_call": "call_jaxpr",
          "custom_vjp_call": "call_jaxpr", "custom_vjp_call_jaxpr": "fun_jaxpr",
          "remat": "jaxpr", "checkpoint": "jaxpr"}


@dataclass(frozen=True)
class StepShader:
    """The generated step: GLSL source and the uniforms it reads, in order."""

    source: str
    params: tuple[str, ...]
    uniforms: tuple[str, ...]


def glsl_float(value: float) -> str:
    """A float32 value as a GLSL literal that parses back to the same float32."""
    v = float(np.float32(value))
    if not np.isfinite(v):
        raise MorphogenError(f"the exported page cannot hold the constant {value!r}")
    text = repr(v)
    return text if ("." in text or "e" in text) else text + ".0"


class _Emitter:
    """Turns jaxpr equations into GLSL lines; every value is a numpy object array of GLSL
    expressions with the value's shape (a field of the grid is one cell: shape ``(1,)``)."""

    def __init__(self, model_name: str):
        self.lines: list[str] = []
        self.count = 0
        self.model = model_name

    def temp(self, expr: str, kind: str) -> str:
        self.count += 1
        name = f"t{self.count}"
        self.lines.append(f"  {kind} {name} = {expr};")
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
        if arr.dtype == bool:
            return np.vectorize(lambda b: "true" if b else "false", otypes=[object])(arr) \
                if arr.ndim else np.array("true" if arr else "false", dtype=object)
        flat = [glsl_float(v) for v in arr.ravel()]
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
        boolean = str(eqn.outvars[0].aval.dtype) == "bool"
        kind = "bool" if boolean else "float"
        if name in _BINARY:
            return [self.elementwise(_BINARY[name], ins, kind)]
        if name in _UNARY:
            return [self.elementwise(_UNARY[name], ins, kind)]
        if name == "integer_pow":
            return [self.elementwise(_integer_pow(int(p["y"])), ins, kind)]
        if name in _TRANSPARENT:
            return ins
        if name == "convert_element_type":
            src = str(eqn.invars[0].aval.dtype)
            if src == "bool" and not boolean:
                return [self.elementwise("({} ? 1.0 : 0.0)", ins, kind)]
            if boolean and src != "bool":
                return [self.elementwise("({} != 0.0)", ins, kind)]
            return ins
        if name == "select_n":
            pred, *cases = ins
            if len(cases) != 2:
                raise self.unsupported("select_n with more than two cases")
            if str(eqn.invars[0].aval.dtype) != "bool":
                pred = self.elementwise("({} != 0.0)", [pred], "bool")
            return [self.elementwise("({} ? {} : {})", [pred, cases[1], cases[0]], kind)]
        if name == "clamp":
            lo, x, hi = ins
            return [self.elementwise("clamp({1}, {0}, {2})", [lo, x, hi], kind)]
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
        raise self.unsupported(name)

    def unsupported(self, what: str) -> MorphogenError:
        return MorphogenError(f"export-web: model {self.model} uses the operation {what!r}, "
                              "which the exported page does not support")


def _integer_pow(n: int) -> str:
    """``x**n`` as repeated multiplication (what XLA does for a small integer power)."""
    if n == 0:
        return "(1.0 + 0.0 * {0})"
    body = " * ".join(["{0}"] * abs(n))
    return f"({body})" if n > 0 else f"(1.0 / ({body}))"


def step_shader(model: Model, params: Mapping[str, Any], *, boundary: str, stencil: int,
                dx: float) -> StepShader:
    """The fragment shader of one forward-Euler step of ``model`` on a 2D grid."""
    import jax
    import jax.numpy as jnp

    species = model.species
    if len(species) > MAX_SPECIES:
        raise MorphogenError(f"export-web: model {model.name} has {len(species)} species; the "
                             f"exported page holds at most {MAX_SPECIES}")
    names = list(params)
    for k in names:
        if np.ndim(params[k]) != 0:
            raise MorphogenError(f"export-web: parameter {k} is a field (a map); the exported "
                                 "page takes one number per parameter")
    if boundary not in ("periodic", "neumann"):
        raise MorphogenError(f"export-web: boundary {boundary!r} is not supported; use "
                             "periodic or neumann (no flux)")
    if stencil not in (5, 9):
        raise MorphogenError(f"export-web: stencil {stencil!r} is not supported; use 5 or 9")

    def traced(u, pv, cv):
        p = dict(zip(names, pv, strict=True))
        c = {"x": cv[0], "y": cv[1], "z": jnp.zeros((1,), jnp.float32), "t": cv[2]}
        d = model.diffusion(p, c)
        if any(isinstance(x, Tensor) for x in d):
            raise MorphogenError(f"export-web: model {model.name} has anisotropic diffusion, "
                                 "which the exported page does not support")
        return model.reaction(u, p, c), tuple(jnp.asarray(x, jnp.float32) for x in d)

    s = len(species)
    try:
        closed = jax.make_jaxpr(traced)(jnp.zeros((s, 1), jnp.float32),
                                        [jnp.float32(0)] * len(names),
                                        [jnp.zeros((1,), jnp.float32)] * 3)
    except MorphogenError:
        raise
    except Exception as exc:  # a model JAX cannot trace on one cell
        raise MorphogenError(f"export-web: model {model.name} cannot be traced into a shader "
                             f"({type(exc).__name__})") from None
    em = _Emitter(model.name)
    cell = np.array([[f"c.{'xyzw'[i]}"] for i in range(s)], dtype=object)
    pvals = [np.array(f"p_{i}", dtype=object) for i in range(len(names))]
    coords = [np.array(["cx"], dtype=object), np.array(["cy"], dtype=object),
              np.array(["u_t"], dtype=object)]
    outs = em.run(closed.jaxpr, closed.consts, [cell, *pvals, *coords])
    reaction = np.broadcast_to(outs[0], (s, 1))
    diffusion = [np.broadcast_to(d, (1,)).ravel()[0] for d in outs[1:1 + s]]
    lines = em.lines
    rates = [f"  float r{i} = {reaction[i, 0]};" for i in range(s)]
    coefs = [f"  float d{i} = {diffusion[i]};" for i in range(s)]
    clamp = ""
    if model.clamp is not None:
        lo, hi = (glsl_float(v) for v in model.clamp)
        clamp = f"  o = clamp(o, {lo}, {hi});\n"
    update = "\n".join(f"  o.{'xyzw'[i]} = c.{'xyzw'[i]} + u_dt * (r{i} + d{i} * lap.{'xyzw'[i]});"
                       for i in range(s))
    uniforms = "\n".join(f"uniform float p_{i}; // {n}" for i, n in enumerate(names))
    wrap = ("ivec2 n = textureSize(u_state, 0);\n  q = ((q % n) + n) % n;" if boundary == "periodic"
            else "q = clamp(q, ivec2(0), textureSize(u_state, 0) - 1);")
    h2 = f"({glsl_float(dx)} * {glsl_float(dx)})"
    at = "at(q + ivec2({}, {}))"
    edges = _sum(at.format(*d) for d in ((0, -1), (0, 1), (-1, 0), (1, 0)))
    if stencil == 5:
        lap = f"({edges} - 4.0 * c) / {h2}"
    else:
        corners = _sum(at.format(*d) for d in ((-1, -1), (1, -1), (-1, 1), (1, 1)))
        lap = (f"(({edges} * {glsl_float(2 / 3)} + {corners} * {glsl_float(1 / 6)}) "
               f"- c * {glsl_float(10 / 3)}) / {h2}")
    source = f"""#version 300 es
precision highp float;
precision highp int;
precision highp sampler2D;
uniform sampler2D u_state;
uniform float u_dt;
uniform float u_t;
{uniforms}
out vec4 o;
vec4 at(ivec2 q) {{
  {wrap}
  return texelFetch(u_state, q, 0);
}}
void main() {{
  ivec2 q = ivec2(gl_FragCoord.xy);
  vec2 size = vec2(textureSize(u_state, 0));
  float cx = (float(q.x) + 0.5) / size.x;
  float cy = (float(q.y) + 0.5) / size.y;
  vec4 c = at(q);
  vec4 lap = {lap};
{chr(10).join(lines)}
{chr(10).join(rates)}
{chr(10).join(coefs)}
  o = c;
{update}
{clamp}}}
"""
    return StepShader(source, tuple(names), ("u_state", "u_dt", "u_t"))


def _sum(terms: Any) -> str:
    """``((a + b) + c) + d``: left to right, as numpy adds the stencil's shifted arrays."""
    out = ""
    for t in terms:
        out = t if not out else f"({out} + {t})"
    return out


def safe_name(text: str) -> str:
    """A model name fit for a file name."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-") or "model"
