"""Public names of a package, imported from their modules on first use (PEP 562).

Every package of morphogen lists its public names the same way::

    from morphogen.util.exports import lazy_exports

    __all__, __getattr__, __dir__ = lazy_exports(__name__, {
        "Grid": "morphogen.domains.grid",
        "Mesh": "morphogen.domains.mesh",
    })

so ``from morphogen.domains import Grid`` works, ``__all__`` is the list of public names (what
the API reference and ``import *`` show), and importing the package (or any of its modules,
which runs the package's ``__init__``) loads nothing heavy until a name is used: the printing
commands start without JAX (``tests/project/test_startup.py``).
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, homes: Mapping[str, str]
                 ) -> tuple[list[str], Callable[[str], Any], Callable[[], list[str]]]:
    """``(__all__, __getattr__, __dir__)`` for ``package`` whose public names live in ``homes``
    (name -> module path). A name is imported from its module on first access and then kept in
    the package's namespace."""
    homes = dict(homes)

    def __getattr__(name: str) -> Any:
        home = homes.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(home), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(homes)

    return list(homes), __getattr__, __dir__
