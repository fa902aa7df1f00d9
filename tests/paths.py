"""Where the tests find the repository's own files, wherever in tests/ a test file lives."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
"""The repository's root: the folder of pyproject.toml, README.md, docs/ and examples/."""
EXAMPLES = ROOT / "examples"
"""The example models, networks, meshes and flower pipelines."""
