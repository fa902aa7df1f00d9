"""Text put into HTML pages: escaped for the context it lands in, and templates filled in one pass.

Every page the project writes (``export-web``'s page, the gallery and demo indexes) holds text
that came from a user: model names from a model file's free-text ``name``, parameter names,
colour-map names, captions. Each value is escaped for where it goes:

- HTML text and attribute values: ``&``, ``<``, ``>``, ``"`` and ``'`` become character
  references (:func:`html_text`), so a value can neither open a tag nor leave a quoted attribute;
- JSON inside ``<script>`` (:func:`script_json`): the JSON text with ``<``, ``>``, ``&``,
  U+2028 and U+2029 written as ``\\u003c``-style escapes, so neither ``</script>`` nor ``<!--``
  can appear inside the element and the text is still the same JSON (and JavaScript) value.

:func:`fill` replaces every ``@NAME@`` placeholder of a template in one regular-expression pass
over the template only, so a placeholder that appears inside a value (a model named
``x@DATA@``) is never replaced again.
"""

from __future__ import annotations

import html
import json
import re
from collections.abc import Mapping
from typing import Any

_PLACEHOLDER = re.compile(r"@([A-Z][A-Z0-9_]*)@")

_SCRIPT_ESCAPES = {
    "<": "\\u003c",
    ">": "\\u003e",
    "&": "\\u0026",
    "\u2028": "\\u2028",
    "\u2029": "\\u2029",
}
_SCRIPT_UNSAFE = re.compile("[<>&\u2028\u2029]")


def html_text(text: str) -> str:
    """``text`` escaped for HTML element content and for a quoted attribute value."""
    return html.escape(str(text), quote=True)


def script_json(value: Any) -> str:
    """``value`` as JSON that can sit inside a ``<script>`` element (a JSON data block or a
    JavaScript expression): no ``<``, ``>``, ``&``, U+2028 or U+2029 appears literally, so the
    element cannot be closed or turned into an HTML comment by the data.

    Raises ``ValueError`` for NaN or infinities, which ``JSON.parse`` would refuse.
    """
    text = json.dumps(value, ensure_ascii=False, allow_nan=False)
    return _SCRIPT_UNSAFE.sub(lambda m: _SCRIPT_ESCAPES[m.group(0)], text)


def fill(template: str, values: Mapping[str, str]) -> str:
    """``template`` with each ``@NAME@`` replaced by ``values[NAME]``, in one pass: the
    replacements are never searched for placeholders. Every placeholder of the template must
    have a value and every value a placeholder (``KeyError`` names the first that does not);
    the values must already be escaped for where they go."""
    used: set[str] = set()

    def put(match: re.Match[str]) -> str:
        key = match.group(1)
        if key not in values:
            raise KeyError(f"template placeholder @{key}@ has no value")
        used.add(key)
        return values[key]

    out = _PLACEHOLDER.sub(put, template)
    unused = sorted(set(values) - used)
    if unused:
        raise KeyError(f"no placeholder @{unused[0]}@ in the template")
    return out
