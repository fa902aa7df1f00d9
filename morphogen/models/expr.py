"""A safe compiler for user-written arithmetic expressions.

Equation text is untrusted (model files, the web app), so it is never handed to ``eval``,
``exec`` or ``compile``. Instead it goes through three stages:

1. :func:`parse`: Python's own parser (``ast.parse(mode="eval")``) builds a syntax tree, which is
   then walked with a strict whitelist: numbers, names, ``+ - * / **``, unary ``-``/``+``, calls
   of the functions in :data:`FUNCTIONS` with positional arguments, and comparisons
   ``< <= > >= == !=`` inside the condition of ``where()``. Everything else (attributes,
   subscripts, strings, lambdas, keyword arguments, names starting with ``_``, ...) is rejected
   with the line and column where it occurs.
2. :func:`compile_node`: every name must be one the caller allows (parameters, species,
   coordinates); unknown names are reported with their position.
3. The result is a tree of closures over :mod:`jax.numpy`: evaluating it with an environment
   ``{name: array}`` traces ordinary JAX operations, so compiled expressions are jit-, vmap- and
   grad-friendly and parameters stay runtime values (never pasted into the program as literals).
   JAX itself is imported when a compiled expression is first evaluated, so parsing and checking
   names (model files, ``morphogen models``) do not load it.
"""

from __future__ import annotations

import ast
import unicodedata
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import Any

from morphogen.errors import MorphogenError

Array = Any
Env = Mapping[str, Array]
Evaluator = Callable[[Env], Array]

MAX_LENGTH = 20_000
"""Longest accepted expression, in characters."""

MAX_DEPTH = 300
"""Deepest accepted syntax tree (a sum of ``n`` terms is ``n`` levels deep)."""

MAX_INTEGER_POWER = 64
"""``x**n`` with an integer literal ``|n|`` up to this is exact repeated multiplication."""


def _jnp(name: str) -> Callable[..., Array]:
    """The function ``jax.numpy.<name>``, looked up when called (JAX is imported then)."""

    def call(*args: Array) -> Array:
        import jax.numpy as jnp

        return getattr(jnp, name)(*args)

    call.__name__ = name
    return call


def _sigmoid(x: Array) -> Array:
    """``1 / (1 + exp(-x))``."""
    import jax

    return jax.nn.sigmoid(x)


def _integer_pow(x: Array, n: int) -> Array:
    """``x**n`` by repeated multiplication (exact for a small integer ``n``)."""
    import jax
    import jax.numpy as jnp

    return jax.lax.integer_pow(jnp.asarray(x), n)


def _lerp(a: Array, b: Array, t: Array) -> Array:
    """``a + (b - a) * t``."""
    import jax.numpy as jnp

    return jnp.add(a, jnp.multiply(jnp.subtract(b, a), t))


FUNCTIONS: dict[str, tuple[int, Callable[..., Array], str]] = {
    "exp": (1, _jnp("exp"), "exp(x)"),
    "log": (1, _jnp("log"), "natural logarithm log(x)"),
    "sqrt": (1, _jnp("sqrt"), "sqrt(x)"),
    "abs": (1, _jnp("abs"), "abs(x)"),
    "tanh": (1, _jnp("tanh"), "tanh(x)"),
    "sin": (1, _jnp("sin"), "sin(x)"),
    "cos": (1, _jnp("cos"), "cos(x)"),
    "sigmoid": (1, _sigmoid, "1 / (1 + exp(-x))"),
    "min": (2, _jnp("minimum"), "elementwise min(a, b)"),
    "max": (2, _jnp("maximum"), "elementwise max(a, b)"),
    "pow": (2, _jnp("power"), "pow(a, b) = a**b"),
    "where": (3, _jnp("where"), "where(condition, a, b): a where condition holds, else b"),
    "lerp": (3, _lerp, "lerp(a, b, t) = a + (b - a)*t"),
    "clip": (3, _jnp("clip"), "clip(x, lo, hi)"),
}

RESERVED = frozenset(FUNCTIONS) | {"lap", "x", "y", "z", "t"}
"""Names a parameter or species may not take (functions, ``lap``, coordinates and time)."""
"""Whitelisted functions: name -> (number of arguments, implementation, description)."""

_BINARY = {
    ast.Add: (_jnp("add"), "+"),
    ast.Sub: (_jnp("subtract"), "-"),
    ast.Mult: (_jnp("multiply"), "*"),
    ast.Div: (_jnp("divide"), "/"),
    ast.Pow: (_jnp("power"), "**"),
}
_COMPARE = {
    ast.Lt: _jnp("less"),
    ast.LtE: _jnp("less_equal"),
    ast.Gt: _jnp("greater"),
    ast.GtE: _jnp("greater_equal"),
    ast.Eq: _jnp("equal"),
    ast.NotEq: _jnp("not_equal"),
}
_ALLOWED = (
    "numbers, names, + - * / **, unary -, comparisons < <= > >= == != inside where(), "
    "and calls " + ", ".join(f"{name}()" for name in FUNCTIONS)
)
_DESCRIBE = {
    ast.Attribute: "attribute access ('.')",
    ast.Subscript: "indexing ('[...]')",
    ast.Lambda: "lambda",
    ast.BoolOp: "'and'/'or' (use where() with comparisons)",
    ast.IfExp: "'... if ... else ...' (use where(condition, a, b))",
    ast.NamedExpr: "assignment (':=')",
    ast.Tuple: "a tuple (',')",
    ast.List: "a list",
    ast.Dict: "a dict",
    ast.Set: "a set",
    ast.ListComp: "a comprehension",
    ast.SetComp: "a comprehension",
    ast.DictComp: "a comprehension",
    ast.GeneratorExp: "a generator",
    ast.JoinedStr: "an f-string",
    ast.Starred: "'*' unpacking",
    ast.Await: "await",
    ast.Yield: "yield",
    ast.YieldFrom: "yield",
    ast.Slice: "slicing",
}


class ExpressionError(MorphogenError):
    """A problem at a place in an expression.

    Attributes:
        reason: what is wrong, without the position.
        line: 1-based line inside the expression text.
        column: 1-based column (in characters) inside that line.
    """

    def __init__(self, reason: str, line: int, column: int):
        self.reason = reason
        self.line = line
        self.column = column
        super().__init__(f"line {line}, column {column}: {reason}")


def error_at(node: ast.AST, text: str, reason: str) -> ExpressionError:
    """An :class:`ExpressionError` at ``node``'s position in ``text``.

    ``ast`` gives columns as UTF-8 byte offsets; they are converted to characters.
    """
    line, offset = getattr(node, "lineno", 1), getattr(node, "col_offset", 0)
    return _error_at_offset(line, offset, text, reason)


def _error_at_offset(line: int, offset: int, text: str, reason: str) -> ExpressionError:
    lines = text.splitlines() or [""]
    source = lines[line - 1] if 0 < line <= len(lines) else ""
    column = len(source.encode("utf-8")[:offset].decode("utf-8", "replace")) + 1
    return ExpressionError(reason, line, column)


@dataclass(frozen=True)
class Expression:
    """A compiled expression.

    Attributes:
        text: the source text.
        names: the free names it reads (parameters, species, coordinates).
        evaluate: ``evaluate(env) -> array``; ``env`` maps every name in ``names`` to a scalar or
            an array, and the result broadcasts them together.
    """

    text: str
    names: frozenset[str]
    evaluate: Evaluator

    def __call__(self, env: Env) -> Array:
        return self.evaluate(env)


def compile_expression(
    text: str, names: Collection[str], *, what: str = "known names:"
) -> Expression:
    """Parse, check and compile ``text`` in one go (see the module docstring).

    Args:
        text: the expression, e.g. ``"a - u + u**2*v"``.
        names: the names it may read; anything else is an error.
        what: how to describe ``names`` in error messages.

    Raises:
        ExpressionError: with the line and column of the first problem.
    """
    tree = parse(text)
    return Expression(text, frozenset(free_names(tree)), compile_node(tree, text, names, what=what))


def _check_normal_form(lines: list[str]) -> None:
    """Refuse characters that NFKC normalisation changes (fullwidth ``ｕ``, ligatures, ...):
    Python's parser would silently read them as other names (``ｕ`` as ``u``)."""
    for number, line in enumerate(lines, 1):
        for column, char in enumerate(line, 1):
            if unicodedata.normalize("NFKC", char) != char:
                raise ExpressionError(
                    f"character {char!r} (U+{ord(char):04X}) would be read as "
                    f"{unicodedata.normalize('NFKC', char)!r}; type the plain character",
                    number, column,
                )


def parse(text: str, *, extra_functions: Mapping[str, int] | None = None) -> ast.expr:
    """Parse ``text`` and check it against the whitelist; returns the expression node.

    Args:
        text: one expression; it may span several lines.
        extra_functions: further call names accepted by the syntax check, with their number of
            arguments (e.g. ``{"lap": 1}`` for equations); they are not compiled here.

    Raises:
        ExpressionError: a syntax error or a construct outside the whitelist.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression as text, got {type(text).__name__}", 1, 1)
    if not text.strip():
        raise ExpressionError("the expression is empty", 1, 1)
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"the expression is longer than {MAX_LENGTH} characters", 1, 1)
    lines = text.splitlines()
    _check_normal_form(lines)
    _check_brackets(lines)
    # Inside brackets, line breaks and indentation are free; the bracket sits on a line of its
    # own, so every node keeps its column and moves down by exactly one line.
    try:
        tree = ast.parse(f"(\n{text}\n)", mode="eval")
    except SyntaxError as exc:
        message = (exc.msg or "invalid syntax").split("\n")[0]
        line, column = (exc.lineno or 2) - 1, exc.offset or 0
        if column < 1 or not 1 <= line <= len(lines):
            line, column = len(lines), len(lines[-1]) + 1
            message = "the expression ends too early"
        raise ExpressionError(f"syntax error: {message}", line, column) from None
    except (ValueError, RecursionError, MemoryError):
        raise ExpressionError("the expression is too deeply nested or malformed", 1, 1) from None
    ast.increment_lineno(tree, -1)
    functions = {name: arity for name, (arity, _, _) in FUNCTIONS.items()}
    functions.update(extra_functions or {})
    _check(tree.body, text, functions, depth=0, in_condition=False)
    return tree.body


def _check_brackets(lines: list[str]) -> None:
    """Report an unmatched or unclosed bracket where it is."""
    pairs = {")": "(", "]": "[", "}": "{"}
    stack: list[tuple[str, int, int]] = []
    for number, line in enumerate(lines, start=1):
        for column, char in enumerate(line, start=1):
            if char == "#":
                break
            if char in "([{":
                stack.append((char, number, column))
            elif char in pairs:
                if not stack or stack[-1][0] != pairs[char]:
                    raise ExpressionError(f"syntax error: unmatched {char!r}", number, column)
                stack.pop()
    if stack:
        char, number, column = stack[-1]
        raise ExpressionError(f"syntax error: {char!r} was never closed", number, column)


def free_names(node: ast.AST) -> set[str]:
    """Names read by a checked expression (called function names excluded)."""
    called = {id(sub.func) for sub in ast.walk(node) if isinstance(sub, ast.Call)}
    return {
        sub.id for sub in ast.walk(node) if isinstance(sub, ast.Name) and id(sub) not in called
    }


def _check(
    node: ast.AST, text: str, functions: Mapping[str, int], *, depth: int, in_condition: bool
) -> None:
    """Raise for anything outside the whitelist (see :func:`parse`)."""
    if depth > MAX_DEPTH:
        raise error_at(node, text, f"the expression nests deeper than {MAX_DEPTH} levels")
    deeper = depth + 1
    if isinstance(node, ast.Constant):
        value = node.value
        if isinstance(value, bool) or not isinstance(value, int | float):
            kind = "strings are" if isinstance(value, str | bytes) else f"{value!r} is"
            raise error_at(node, text, f"{kind} not allowed; use {_ALLOWED}")
        return
    if isinstance(node, ast.Name):
        if node.id.startswith("_"):
            raise error_at(node, text, f"names starting with '_' are not allowed ({node.id!r})")
        return
    if isinstance(node, ast.BinOp):
        if type(node.op) not in _BINARY:
            symbol = _OPERATOR_SYMBOLS.get(type(node.op), type(node.op).__name__)
            raise error_at(node, text, f"operator {symbol} is not allowed; use {_ALLOWED}")
        _check(node.left, text, functions, depth=deeper, in_condition=in_condition)
        _check(node.right, text, functions, depth=deeper, in_condition=in_condition)
        return
    if isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, ast.USub | ast.UAdd):
            raise error_at(node, text, f"unary {type(node.op).__name__} is not allowed; use -x")
        _check(node.operand, text, functions, depth=deeper, in_condition=in_condition)
        return
    if isinstance(node, ast.Compare):
        if not in_condition:
            raise error_at(
                node, text, "comparisons are only allowed in the condition of where(cond, a, b)"
            )
        for op in node.ops:
            if type(op) not in _COMPARE:
                raise error_at(node, text, "only the comparisons < <= > >= == != are allowed")
        for sub in (node.left, *node.comparators):
            _check(sub, text, functions, depth=deeper, in_condition=True)
        return
    if isinstance(node, ast.Call):
        _check_call(node, text, functions, depth=deeper, in_condition=in_condition)
        return
    kind = _DESCRIBE.get(type(node), f"'{type(node).__name__}'")
    if isinstance(node, ast.Attribute):  # point at the '.', not at the start of the object
        end = node.value
        raise _error_at_offset(
            end.end_lineno, end.end_col_offset, text, f"{kind} is not allowed; use {_ALLOWED}"
        )
    raise error_at(node, text, f"{kind} is not allowed; use {_ALLOWED}")


_OPERATOR_SYMBOLS = {
    ast.Mod: "%",
    ast.FloorDiv: "//",
    ast.MatMult: "@",
    ast.BitAnd: "&",
    ast.BitOr: "|",
    ast.BitXor: "^",
    ast.LShift: "<<",
    ast.RShift: ">>",
}


def _check_call(
    node: ast.Call, text: str, functions: Mapping[str, int], *, depth: int, in_condition: bool
) -> None:
    if not isinstance(node.func, ast.Name):
        _check(node.func, text, functions, depth=depth, in_condition=in_condition)
        raise error_at(node, text, f"only named functions can be called; use {_ALLOWED}")
    name = node.func.id
    if name.startswith("_"):
        raise error_at(node, text, f"names starting with '_' are not allowed ({name!r})")
    if name not in functions:
        known = ", ".join(sorted(functions))
        raise error_at(node, text, f"unknown function {name!r}; functions are {known}")
    if node.keywords:
        raise error_at(node, text, f"{name}() takes positional arguments only, no keywords")
    for arg in node.args:
        if isinstance(arg, ast.Starred):
            raise error_at(arg, text, f"'*' unpacking is not allowed in {name}()")
    if len(node.args) != functions[name]:
        raise error_at(
            node, text, f"{name}() takes {functions[name]} argument(s), got {len(node.args)}"
        )
    for i, arg in enumerate(node.args):
        condition = in_condition or (name == "where" and i == 0)
        _check(arg, text, functions, depth=depth, in_condition=condition)


def compile_node(
    node: ast.expr, text: str, names: Collection[str], *, what: str = "known names:"
) -> Evaluator:
    """Compile a checked node (from :func:`parse`) into ``evaluate(env) -> array``.

    Args:
        node: a node returned by :func:`parse` (or a subtree of one).
        text: the expression text, for error positions.
        names: the names the expression may read.
        what: how to describe ``names`` in error messages.

    Raises:
        ExpressionError: an unknown name, a function used as a value, or a call of a function
            that is not in :data:`FUNCTIONS`.
    """
    allowed = frozenset(names)
    try:
        return _compile(node, text, allowed, what)
    except RecursionError:
        raise error_at(node, text, "the expression is too deeply nested") from None


def _compile(node: ast.AST, text: str, names: frozenset[str], what: str) -> Evaluator:
    if isinstance(node, ast.Constant):
        return _constant(node, text)
    if isinstance(node, ast.Name):
        return _name(node, text, names, what)
    if isinstance(node, ast.UnaryOp):
        operand = _compile(node.operand, text, names, what)
        if isinstance(node.op, ast.UAdd):
            return operand
        negative = _jnp("negative")
        return lambda env: negative(operand(env))
    if isinstance(node, ast.BinOp):
        left = _compile(node.left, text, names, what)
        if isinstance(node.op, ast.Pow) and _small_integer(node.right):
            n = int(node.right.value)
            return lambda env: _integer_pow(left(env), n)
        right = _compile(node.right, text, names, what)
        fn = _BINARY[type(node.op)][0]
        return lambda env: fn(left(env), right(env))
    if isinstance(node, ast.Compare):
        return _comparison(node, text, names, what)
    if isinstance(node, ast.Call):
        name = node.func.id
        if name not in FUNCTIONS:
            raise error_at(node, text, f"{name}() cannot be used here")
        fn = FUNCTIONS[name][1]
        args = tuple(_compile(arg, text, names, what) for arg in node.args)
        if len(args) == 1:
            (a,) = args
            return lambda env: fn(a(env))
        if len(args) == 2:
            a, b = args
            return lambda env: fn(a(env), b(env))
        return lambda env: fn(*(arg(env) for arg in args))
    raise error_at(node, text, f"'{type(node).__name__}' is not allowed; use {_ALLOWED}")


def _constant(node: ast.Constant, text: str) -> Evaluator:
    try:
        value = float(node.value)
    except OverflowError:
        raise error_at(node, text, "number too large") from None
    return lambda env: value


def _name(node: ast.Name, text: str, names: frozenset[str], what: str) -> Evaluator:
    name = node.id
    if name not in names:
        if name in FUNCTIONS:
            raise error_at(node, text, f"{name} is a function: call it as {FUNCTIONS[name][2]}")
        known = ", ".join(sorted(names)) or "none"
        raise error_at(node, text, f"unknown name {name!r}; {what} {known}")
    return lambda env: _lookup(env, name)


def _lookup(env: Env, name: str) -> Array:
    try:
        return env[name]
    except KeyError:
        raise MorphogenError(f"no value for {name!r} here (this domain or call lacks it)") from None


def _small_integer(node: ast.AST) -> bool:
    return (
        isinstance(node, ast.Constant)
        and isinstance(node.value, int)
        and not isinstance(node.value, bool)
        and abs(node.value) <= MAX_INTEGER_POWER
    )


def _comparison(node: ast.Compare, text: str, names: frozenset[str], what: str) -> Evaluator:
    """``a < b <= c`` means ``(a < b) and (b <= c)``, as in Python."""
    operands = [_compile(sub, text, names, what) for sub in (node.left, *node.comparators)]
    tests = [_COMPARE[type(op)] for op in node.ops]
    logical_and = _jnp("logical_and")

    def evaluate(env: Env) -> Array:
        values = [f(env) for f in operands]
        result = tests[0](values[0], values[1])
        for i, test in enumerate(tests[1:], start=1):
            result = logical_and(result, test(values[i], values[i + 1]))
        return result

    return evaluate


__all__ = [
    "FUNCTIONS",
    "Expression",
    "ExpressionError",
    "compile_expression",
    "compile_node",
    "error_at",
    "free_names",
    "parse",
]
