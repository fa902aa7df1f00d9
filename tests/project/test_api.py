"""The public API: ``import morphogen as mg`` is light, every curated name resolves, and no
module of the package imports from the top-level one (the README's example runs in
``test_docs_code.py``)."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import pkgutil
import subprocess
import sys
import tomllib

import pytest

import morphogen as mg
from tests.paths import ROOT


def test_every_public_name_resolves_to_its_home():
    assert dir(mg) == sorted(mg.__all__)
    for name in mg.__all__:
        home = importlib.import_module(mg._HOMES[name])
        assert getattr(mg, name) is getattr(home, name), name
    with pytest.raises(AttributeError, match="no attribute 'simulat'"):
        mg.simulat  # noqa: B018


def test_the_type_check_covers_every_module_behind_a_public_name():
    """``make lint``'s mypy reads ``[tool.mypy] files``: each module defining a name of
    ``mg.__all__`` is on it (and the package itself), nothing else, and ``py.typed`` ships."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    files = config["tool"]["mypy"]["files"]
    homes = {m.replace(".", "/") + ".py" for m in mg._HOMES.values()}
    assert sorted(files) == sorted(homes | {"morphogen/__init__.py"})
    assert (ROOT / "morphogen" / "py.typed").is_file()
    assert "py.typed" in config["tool"]["setuptools"]["package-data"]["morphogen"]


def test_import_morphogen_loads_no_heavy_library():
    code = ("import sys, morphogen\n"
            "heavy = {m.split('.')[0] for m in sys.modules} & "
            "{'jax', 'numpy', 'matplotlib', 'pydantic', 'scipy'}\n"
            "print(sorted(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


def test_no_module_imports_names_from_the_top_level_package():
    public = set(mg.__all__)
    offenders = []
    for path in (ROOT / "morphogen").rglob("*.py"):
        if path.name == "__init__.py" and path.parent.name == "morphogen":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module == "morphogen" and not node.level:
                offenders += [f"{path}: {a.name}" for a in node.names if a.name in public]
    assert offenders == []


def test_the_api_reference_check_catches_a_broken_docstring_reference():
    spec = importlib.util.spec_from_file_location("api_docs", ROOT / "docs" / "api.py")
    api = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(api)
    from morphogen.domains.grid import Grid
    from morphogen.engine import simulate as module

    assert api.resolves("simulate", module, None, {})
    assert api.resolves("~morphogen.engine.simulate.Solution", module, None, {})
    assert api.resolves("the grid <morphogen.domains.grid.Grid>", module, None, {})
    assert api.resolves("Grid.diffuse", module, None, {"Grid": Grid})
    assert not api.resolves("morphogen.engine.simulate.no_such_function", module, None, {})
    assert not api.resolves("no_such_name", module, None, {})
    assert not api.resolves("morphogen.no_such_module.name", module, None, {})


LIBRARY_PACKAGES = ("domains", "engine", "flowers", "learn", "match", "models", "patterns",
                    "render", "runs", "search", "solvers")


@pytest.mark.parametrize("name", LIBRARY_PACKAGES)
def test_each_library_package_lists_its_public_names(name):
    """``__all__`` resolves to the name's home, and no public name is also a submodule's name
    (importing the submodule would replace the function by the module on the package)."""
    package = importlib.import_module(f"morphogen.{name}")
    assert package.__all__ and dir(package) == sorted(package.__all__)
    submodules = {m.name for m in pkgutil.iter_modules(package.__path__)}
    assert sorted(set(package.__all__) & submodules) == []
    for public in package.__all__:
        assert getattr(package, public) is not None, public
    with pytest.raises(AttributeError, match="has no attribute 'nothing_here'"):
        package.nothing_here  # noqa: B018
