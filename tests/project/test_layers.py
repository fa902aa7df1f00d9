"""The layer rule and the ban on import circles (pyproject.toml ``[tool.importlinter]``, run by
``make lint``) hold for the package, and fail on a copy of it with one upward import or one
circle added: the check can fail."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.paths import ROOT

LINT = Path(sys.executable).with_name("lint-imports")


def _lint(package_parent: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(package_parent)}
    return subprocess.run([str(LINT), str(ROOT / "pyproject.toml"), "--no-cache"],
                          capture_output=True, text=True, env=env, cwd=package_parent,
                          timeout=300)


def _copy(tmp_path: Path) -> Path:
    shutil.copytree(ROOT / "morphogen", tmp_path / "morphogen",
                    ignore=shutil.ignore_patterns("__pycache__", "static", "*.npz", "*.json"))
    return tmp_path / "morphogen"


def test_the_package_keeps_both_contracts():
    result = _lint(ROOT)
    assert result.returncode == 0, result.stdout[-2000:]
    assert "2 kept, 0 broken" in result.stdout


@pytest.mark.parametrize("module, line, contract", [
    # a model importing the engine: an upward import
    ("models/model.py", "import morphogen.engine.simulate", "Layers"),
    # two util leaves importing each other: a circle inside one layer
    ("util/io.py", "import morphogen.util.guard", "No import circles"),
])
def test_an_added_upward_import_or_circle_breaks_the_build(tmp_path, module, line, contract):
    package = _copy(tmp_path)
    if contract == "No import circles":
        guard = package / "util" / "guard.py"
        guard.write_text(guard.read_text() + "\nimport morphogen.util.io  # noqa\n")
    target = package / module
    target.write_text(target.read_text() + f"\n{line}  # noqa\n")
    result = _lint(tmp_path)
    assert result.returncode != 0
    broken = result.stdout.split("Broken contracts")[-1]
    assert contract in broken
    if contract == "No import circles":  # a circle inside one layer breaks only that contract
        assert "Layers" not in broken
