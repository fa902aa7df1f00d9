"""A model's explicit Euler step as a WebGL2 fragment shader (GLSL ES 3.00).

The shader is not a second, hand-written copy of the model: the model's own ``reaction`` and
``diffusion`` (a library model's functions, or a model file's expressions compiled by
:mod:`morphogen.models.expr`) are traced by JAX into the very list of primitive operations
(a jaxpr) that the engine compiles, and each operation becomes one line of GLSL
(:mod:`morphogen.models.cell_code`, in the :data:`GLSL` dialect). The step is
the engine's forward Euler, ``u + dt * (R(u) + D * lap(u))`` (:mod:`morphogen.solvers.explicit`),
with the 5- or 9-point stencil of :mod:`morphogen.domains.stencils` term for term and the ghost
cells of :mod:`morphogen.domains.grid` (wrap for periodic, the edge value for no flux).

Anything the page cannot reproduce (more than four species, parameter fields, anisotropic
diffusion, an operation GLSL lacks) is a :class:`~morphogen.errors.MorphogenError` naming it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.cell_code import Dialect, Emitter, cell_jaxpr
from morphogen.models.model import Model

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


def _declare(kind: str, name: str, expr: str) -> str:
    return f"  {kind} {name} = {expr};"


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


GLSL = Dialect(
    binary=_BINARY, unary=_UNARY, zero="0.0", one="1.0", literal=glsl_float, true="true",
    false="false", declare=_declare, select="({} ? {} : {})", clamp="clamp({1}, {0}, {2})",
    to_float="({} ? 1.0 : 0.0)", to_bool="({} != 0.0)")
"""How GLSL ES 3.00 writes each operation."""


def step_shader(model: Model, params: Mapping[str, Any], *, boundary: str, stencil: int,
                dx: float) -> StepShader:
    """The fragment shader of one forward-Euler step of ``model`` on a 2D grid."""
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

    s = len(species)
    closed = cell_jaxpr(model, names, who="export-web", target="the exported page")
    em = Emitter(GLSL, who="export-web", target="the exported page", model=model.name)
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
