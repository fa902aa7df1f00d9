"""The API reference (``make docs``): pdoc's HTML for every module of morphogen, in ``out/api/``.

``python docs/api.py [--out DIR]`` imports each module, renders its docstrings (Google style) and
checks them; it exits with status 1, listing the problems, when

- a module cannot be imported, or a name in an ``__all__`` does not resolve;
- a docstring's cross-reference (``:func:`morphogen.engine.simulate.simulate```,
  ``:class:`Grid```, ``:mod:`...```, ...) names nothing: absolute names are imported, short ones
  are looked up in the class and module the docstring belongs to.

Nothing is fetched: pdoc renders with its bundled templates, and the pages load nothing from
the network (no search index precompilation, no maths or diagram scripts).
"""

from __future__ import annotations

import argparse
import builtins
import html
import importlib
import inspect
import pkgutil
import re
import shutil
import sys
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pdoc
import pdoc.doc
import pdoc.render

PACKAGE = "morphogen"

ROLE = re.compile(r":(?:py:)?(?:func|class|mod|meth|attr|data|exc|obj|const):`([^`]+)`")
"""A Sphinx-style cross-reference; group 1 is its target (``~name``, ``text <name>``)."""

FATAL = re.compile(r"^(Error importing|Error loading|Couldn't import|Cannot find spec|"
                   r"Error reloading|Found .* but it does not resolve)")
"""pdoc's warnings that mean a module or an exported name is broken (the others are about
type annotations it cannot evaluate, and only cost a link)."""


def _members(doc: pdoc.doc.Doc) -> Iterator[pdoc.doc.Doc]:
    """``doc`` and, for a module or class, everything defined in it, depth first."""
    yield doc
    if isinstance(doc, (pdoc.doc.Module, pdoc.doc.Class)):
        for member in doc.own_members:
            if member.taken_from[0].split(".")[0] == PACKAGE:  # not an alias of jax.Array
                yield from _members(member)


def _attribute_path(obj: Any, names: list[str]) -> bool:
    """Whether ``obj.a.b...`` exists for ``names = [a, b, ...]``."""
    for name in names:
        try:
            obj = getattr(obj, name)
        except Exception:  # noqa: BLE001 (a property may raise anything)
            # A dataclass field without a default is an annotation, not a class attribute.
            fields = [getattr(c, "__annotations__", {}) for c in getattr(obj, "__mro__", ())]
            if name == names[-1] and any(name in f for f in fields):
                return True
            return False
    return True


def _absolute(target: str) -> bool:
    """Whether a dotted name resolves as ``module.attribute...`` for its longest module prefix."""
    parts = target.split(".")
    for i in range(len(parts), 0, -1):
        try:
            module = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        return _attribute_path(module, parts[i:])
    return False


def _source(obj: Any) -> str:
    """The source of ``obj``, or ``""`` where there is none."""
    try:
        return inspect.getsource(obj)
    except (OSError, TypeError):
        return ""


def resolves(target: str, module: Any, scope: Any | None, package: dict[str, Any]) -> bool:
    """Whether a cross-reference ``target`` names something, seen from ``module``/``scope``.

    ``package`` maps every top-level name of the package's modules to one of its objects: a
    short name the module imports only for type checking resolves there.
    """
    if "<" in target:
        target = target[target.rindex("<") + 1:].rstrip(">")
    target = "".join(target.split()).lstrip("~").removesuffix("()")  # a wrapped line joined
    if not target:
        return False
    first, *rest = target.split(".")
    for namespace in (scope, module, builtins):
        if namespace is not None and hasattr(namespace, first):
            return _attribute_path(getattr(namespace, first), rest)
    if isinstance(scope, type) and not rest and f"self.{first} =" in _source(scope):
        return True  # an attribute each instance sets
    if first in package:
        return _attribute_path(package[first], rest)
    return _absolute(target)


def broken_references(modules: dict[str, pdoc.doc.Module]) -> list[str]:
    """``module: qualname: target`` for every cross-reference that names nothing."""
    package = {}
    for module_doc in modules.values():
        for key, value in vars(module_doc.obj).items():
            package.setdefault(key, value)
    problems = []
    for name, module_doc in modules.items():
        for doc in _members(module_doc):
            if doc.taken_from[0] != name:  # an imported name: checked where it is defined
                continue
            scope = None
            if "." in doc.qualname:
                owner = module_doc.get(doc.qualname.rsplit(".", 1)[0])
                scope = owner.obj if owner is not None else None
            elif isinstance(doc, pdoc.doc.Class):
                scope = doc.obj
            for target in ROLE.findall(doc.docstring):
                if not resolves(target, module_doc.obj, scope, package):
                    problems.append(f"{name}: {doc.qualname or '(module)'}: {target}")
    return problems


def build(out: Path) -> list[str]:
    """Render every module of the package into ``out``; returns the problems found."""
    problems: list[str] = []

    def record(message: Any, category: type, filename: str, lineno: int, file: Any = None,
               line: str | None = None) -> None:
        text = str(message)
        if FATAL.match(text):
            problems.append(text.strip().splitlines()[0] + "\n    "
                            + text.strip().splitlines()[-1])

    pdoc.render.configure(docformat="google", search=False, math=False, mermaid=False,
                          show_source=False, footer_text=f"{PACKAGE} API reference")
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = record
        modules = {}
        for name in module_names(problems):
            try:
                load_public_names(name)
                modules[name] = pdoc.doc.Module.from_name(name)
            except RuntimeError as exc:  # pdoc's "Error importing NAME", from the ImportError
                problems.append(f"{exc}: {exc.__cause__!r}")
        if out.exists():
            shutil.rmtree(out)
        out.mkdir(parents=True)
        for module in modules.values():
            path = out / f"{module.fullname.replace('.', '/')}.html"
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(pdoc.render.html_module(module, modules), encoding="utf-8")
        (out / "index.html").write_text(index_page(modules), encoding="utf-8")
    return problems + broken_references(modules)


def module_names(problems: list[str]) -> list[str]:
    """The package and every module under it. (pdoc's own walk follows a package's
    ``__all__``, which at the top level lists the public API, not the subpackages.)"""
    package = importlib.import_module(PACKAGE)

    def failed(name: str) -> None:
        problems.append(f"Error importing {name}: {sys.exc_info()[1]!r}")

    found = pkgutil.walk_packages(package.__path__, PACKAGE + ".", onerror=failed)
    return [PACKAGE, *sorted(m.name for m in found)]


def load_public_names(name: str) -> None:
    """Import every name of a package's ``__all__``: the packages list their public names
    lazily (``morphogen.util.exports``), and pdoc looks for them among what is already loaded."""
    module = importlib.import_module(name)
    for public in getattr(module, "__all__", ()):
        getattr(module, public)


def index_page(modules: dict[str, pdoc.doc.Module]) -> str:
    """``index.html``: every module, linked, with the first line of its docstring."""
    rows = []
    for name, module in modules.items():
        summary = html.escape(module.docstring.strip().split("\n")[0])
        rows.append(f'<li><a href="{name.replace(".", "/")}.html"><code>{name}</code></a> '
                    f"{summary}</li>")
    return ("<!doctype html><meta charset=utf-8><title>morphogen API reference</title>"
            "<style>body{font:15px/1.5 system-ui,sans-serif;max-width:60em;margin:2em auto;"
            "padding:0 1em}li{margin:.2em 0}</style><h1>morphogen API reference</h1>"
            f"<ul>{''.join(rows)}</ul>\n")


def main(argv: list[str] | None = None) -> int:
    """Build the reference; status 1 when a module or a docstring reference is broken."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="out/api", help="output folder (replaced)")
    args = parser.parse_args(argv)
    problems = build(Path(args.out))
    for problem in problems:
        print(f"api docs: {problem}", file=sys.stderr)
    if problems:
        print(f"api docs: {len(problems)} problem(s)", file=sys.stderr)
        return 1
    print(f"wrote {args.out}/index.html")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
