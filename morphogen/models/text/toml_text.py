"""TOML text read with bounds: nesting depth checked before :mod:`tomllib` sees it, and the
lines of a file indexed once so that every key's line and column is found in constant time.

:mod:`tomllib` parses arrays and inline tables recursively, so ``a = [[[[...]]]]`` a few hundred
levels deep raises :class:`RecursionError` (where exactly depends on how deep the caller's stack
already is). :func:`too_deep` scans the text once, skipping strings and comments, and reports the
first bracket beyond :data:`MAX_DEPTH`; no model file needs more than two levels.
"""

from __future__ import annotations

import re

MAX_DEPTH = 16
"""Deepest nesting of arrays and inline tables accepted in a model file (``species = [...]``
and ``s = { angle = ... }`` are one level)."""

_SPECIAL = re.compile(r"""[\[\]{}#"'\n]""")
_STRINGS = {
    '"""': re.compile(r'"""(?:\\[\s\S]|[^\\])*?"""'),
    "'''": re.compile(r"'''[\s\S]*?'''"),
    '"': re.compile(r'"(?:\\.|[^"\\\n])*"?'),
    "'": re.compile(r"'[^'\n]*'?"),
}
_HEADER = re.compile(r"^\s*\[\s*([^\[\]]+?)\s*\]")
_DOTS = re.compile(r"\s*\.\s*")
_KEY = re.compile(r"""^\s*(?:"([^"]*)"|'([^']*)'|([^\s="'\[\]#]+))\s*=\s*""")


def too_deep(text: str, limit: int = MAX_DEPTH) -> tuple[int, int] | None:
    """``(line, column)`` of the first ``[`` or ``{`` nested deeper than ``limit`` outside
    strings and comments, or ``None``. One pass over the text."""
    depth, line, line_start, pos, end = 0, 1, 0, 0, len(text)
    while pos < end:
        match = _SPECIAL.search(text, pos)
        if match is None:
            break
        i, c = match.start(), match.group()
        pos = i + 1
        if c == "\n":
            line, line_start = line + 1, pos
        elif c == "#":
            newline = text.find("\n", i)
            pos = end if newline < 0 else newline
        elif c in "\"'":
            quote = c * 3 if text.startswith(c * 3, i) else c
            string = _STRINGS[quote].match(text, i)
            pos = end if string is None else string.end()
            newlines = text.count("\n", i, pos)
            if newlines:
                line, line_start = line + newlines, text.rfind("\n", i, pos) + 1
        elif c in "[{":
            depth += 1
            if depth > limit:
                return line, i - line_start + 1
        else:
            depth = max(depth - 1, 0)
    return None


def loads(text: str) -> dict:
    """:func:`tomllib.loads` with the nesting bound: text nested deeper than :data:`MAX_DEPTH`
    raises :class:`tomllib.TOMLDecodeError` (never :class:`RecursionError`), so a reader that
    already turns TOML errors into one line needs no other change."""
    import tomllib

    deep = too_deep(text)
    if deep is not None:
        raise tomllib.TOMLDecodeError(f"arrays or tables nested more than {MAX_DEPTH} deep "
                                      f"(at line {deep[0]}, column {deep[1]})")
    try:
        return tomllib.loads(text)
    except RecursionError:
        raise tomllib.TOMLDecodeError(f"arrays or tables nested more than {MAX_DEPTH} "
                                      "deep") from None


class KeyIndex:
    """Where each ``key = value`` line of a TOML text is: built in one pass over the lines,
    then looked up by ``(table, key)`` (``None`` for the top level) in constant time.

    Only the first line that assigns a key in a table is kept (a repeated key is a TOML error
    anyway). Table headers ``[a.b]`` set the table of the lines below; ``[[...]]`` headers and
    dotted keys are not indexed (a lookup of them finds nothing).
    """

    def __init__(self, lines: list[str]):
        self.lines = lines
        self._where: dict[tuple[str | None, str], tuple[int, int]] = {}
        table: str | None = None
        for number, line in enumerate(lines, start=1):
            header = _HEADER.match(line)
            if header:
                table = _DOTS.sub(".", header.group(1))
                continue
            key = _KEY.match(line)
            if key:
                name = next(g for g in key.groups() if g is not None)
                self._where.setdefault((table, name), (number, key.end()))

    def find(self, table: str | None, key: str) -> tuple[int, str, int] | None:
        """``(line number, line, index after the '=' and blanks)`` of ``key`` in ``table``."""
        hit = self._where.get((table, key))
        if hit is None:
            return None
        number, after = hit
        return number, self.lines[number - 1], after
