"""Splitting an equation into its reaction part and its diffusion coefficient.

A model-file equation is the right-hand side of (Skaggs eq. 2.2)

.. math::

    \\partial_t u_i = R_i(u, p, x, t) + D_i(p, x)\\,\\nabla^2 u_i .

Its top-level additive terms (through ``+``, ``-`` and unary minus) that contain ``lap`` must each
be ``coef * lap(u_i)`` for the equation's own species, where ``coef`` is a product or quotient
of factors that read only parameters, numbers and ``x, y, z`` (forms such as ``lap(u)/c``,
``-lap(u)`` and ``lap(u)*c`` are accepted); their coefficients add up to ``D_i``. Everything
else is the reaction ``R_i``. Cross-diffusion, nonlinear diffusion and ``lap`` inside a function
are rejected with the position of the offending ``lap``.
"""

from __future__ import annotations

import ast

from morphogen.models.expr import error_at
from morphogen.models.model import Array, Tensor

_SUPPORTED = "write diffusion as coef*lap(s) added to the equation of species s"


def split_equation(
    tree: ast.expr, text: str, own: str, species: tuple[str, ...]
) -> tuple[ast.expr | None, ast.expr | None]:
    """``(reaction, coefficient)`` nodes of a checked equation (see the module docstring).

    Either is ``None`` when absent (no reaction terms; no diffusion). Subtrees without ``lap``
    are kept as they are, so the reaction's arithmetic (and rounding) is exactly what was
    written.

    Raises:
        ExpressionError: ``lap`` in an unsupported position, with its line and column.
    """
    reaction, coefs = _split_terms(tree, text, own, species)
    if not coefs:
        return reaction, None
    total = coefs[0]
    for term in coefs[1:]:
        total = ast.copy_location(ast.BinOp(total, ast.Add(), term), term)
    return reaction, total


def principal_tensor(angle: Array, along: Array, across: Array) -> Tensor:
    """Diffusion tensor from a principal direction and two rates (Ringham et al. eq. 18).

    .. math::
        D = \\lambda_1 e e^T + \\lambda_2 e_\\perp e_\\perp^T,\\qquad
        e = (\\cos\\theta, \\sin\\theta),\\ e_\\perp = (-\\sin\\theta, \\cos\\theta)

    with ``along`` = :math:`\\lambda_1`, ``across`` = :math:`\\lambda_2`, ``angle`` =
    :math:`\\theta` in radians from the x axis; the flux is Ringham eq. 8.
    """
    import jax.numpy as jnp

    cos, sin = jnp.cos(angle), jnp.sin(angle)
    return Tensor(
        xx=along * cos * cos + across * sin * sin,
        xy=(along - across) * cos * sin,
        yy=along * sin * sin + across * cos * cos,
    )


def _has_lap(node: ast.AST) -> bool:
    return any(_is_lap(sub) for sub in ast.walk(node))


def _is_lap(node: ast.AST) -> bool:
    return isinstance(node, ast.Call) and node.func.id == "lap"


def _first_lap(node: ast.AST) -> ast.Call:
    return next(sub for sub in ast.walk(node) if _is_lap(sub))


def _negate(node: ast.expr) -> ast.expr:
    return ast.copy_location(ast.UnaryOp(ast.USub(), node), node)


def _split_terms(node, text, own, species) -> tuple[ast.expr | None, list[ast.expr]]:
    """Split an equation into its reaction part and its diffusion coefficients.

    The sum structure is walked through ``+``, ``-`` and unary minus; subtrees without ``lap``
    are kept unchanged (so the arithmetic, and its rounding, is exactly what was written).
    Returns ``(reaction or None, [coefficient of each coef*lap(own) term, signed])``.
    """
    if not _has_lap(node):
        return node, []
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add | ast.Sub):
        left, left_coefs = _split_terms(node.left, text, own, species)
        right, right_coefs = _split_terms(node.right, text, own, species)
        if isinstance(node.op, ast.Sub):
            right_coefs = [_negate(c) for c in right_coefs]
            if left is None and right is not None:
                right = _negate(right)
        if left is None or right is None:
            reaction = left if right is None else right
        else:
            reaction = ast.copy_location(ast.BinOp(left, node.op, right), node)
        return reaction, left_coefs + right_coefs
    if isinstance(node, ast.UnaryOp):
        inner, coefs = _split_terms(node.operand, text, own, species)
        if isinstance(node.op, ast.USub):
            return (None if inner is None else _negate(inner)), [_negate(c) for c in coefs]
        return inner, coefs
    coef = _diffusion_term(node, text, own, species)
    return None, [coef if coef is not None else ast.copy_location(ast.Constant(1.0), node)]


def _diffusion_term(node, text, own, species) -> ast.expr | None:
    """The coefficient of a ``coef*lap(own)`` term (``None`` for a bare ``lap(own)``)."""
    if _is_lap(node):
        arg = node.args[0]
        if not isinstance(arg, ast.Name) or arg.id not in species:
            raise error_at(arg, text, f"lap() takes a species name, e.g. lap({own})")
        if arg.id != own:
            raise error_at(
                node, text,
                f"lap({arg.id}) in the equation for {own}: an equation may only diffuse its own "
                f"species; {_SUPPORTED} (cross-diffusion is not supported)",
            )  # fmt: skip
        return None
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Mult | ast.Div):
        if _has_lap(node.right):
            if isinstance(node.op, ast.Div):
                reason = f"lap() in a denominator is not supported; {_SUPPORTED}"
                raise error_at(_first_lap(node.right), text, reason)
            if _has_lap(node.left):
                reason = f"a product of two lap() terms is not supported; {_SUPPORTED}"
                raise error_at(_first_lap(node.right), text, reason)
            factor, inner = node.left, _diffusion_term(node.right, text, own, species)
        else:
            factor, inner = node.right, _diffusion_term(node.left, text, own, species)
        check_coefficient(factor, text, species, f"lap({own}) multiplied by")
        if inner is None:
            if isinstance(node.op, ast.Mult):
                return factor
            inner = ast.copy_location(ast.Constant(1.0), node)
        return ast.copy_location(ast.BinOp(inner, node.op, factor), node)
    if isinstance(node, ast.UnaryOp):
        inner = _diffusion_term(node.operand, text, own, species)
        if isinstance(node.op, ast.UAdd):
            return inner
        return _negate(inner if inner is not None else ast.copy_location(ast.Constant(1.0), node))
    lap = _first_lap(node)
    if isinstance(node, ast.Call):
        where = f"inside {node.func.id}()"
    elif isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
        where = "in a power"
    else:
        where = "inside brackets"
    raise error_at(
        lap, text, f"lap() {where} is not supported; {_SUPPORTED} (coef of parameters, numbers, "
        "x, y, z)",
    )  # fmt: skip


def check_coefficient(node: ast.AST, text: str, species: tuple[str, ...], what: str) -> None:
    """Raise if a diffusion coefficient reads a species or time (``what`` starts the message)."""
    for sub in ast.walk(node):
        if isinstance(sub, ast.Name) and sub.id in species:
            raise error_at(
                sub, text,
                f"{what} species {sub.id!r}: diffusion coefficients may use parameters, numbers "
                "and x, y, z only (nonlinear diffusion is not supported)",
            )  # fmt: skip
        if isinstance(sub, ast.Name) and sub.id == "t":
            raise error_at(sub, text, "diffusion coefficients may not depend on time t")
