"""Every Python code block in README.md and docs/*.md runs, so a page cannot drift from the code.

Each block runs on its own (a fresh namespace) in a temporary folder that holds links to the
repository's ``examples/`` and ``docs/``, so a block reads the files it names by the same
relative paths a reader uses from the project root, and what it writes stays out of the tree.
A block may be preceded by a comment that shrinks it for the suite, e.g.
``<!-- suite: (256, 256) -> (24, 24); steps=8000 -> steps=40 -->``: each ``old -> new`` must
occur in the block (a stale comment fails), and nothing else is changed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import morphogen as mg
from tests.paths import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
_BLOCK = re.compile(r"(?:<!-- suite: (?P<subs>.*?) -->\s*\n)?```python\n(?P<code>.*?)```", re.S)


@dataclass(frozen=True)
class Block:
    """One ``python`` code block of a page and the suite comment before it (``subs``)."""

    page: str
    index: int
    text: str
    subs: str | None

    @property
    def id(self) -> str:
        return f"{self.page}#{self.index}"

    @property
    def code(self) -> str:
        """The block with the suite's substitutions applied."""
        return _shrink(self.text, self.subs, self.id)


def _shrink(code: str, subs: str | None, where: str) -> str:
    for pair in filter(None, (s.strip() for s in (subs or "").split(";"))):
        old, new = (part.strip() for part in pair.split("->"))
        assert old in code, f"{where}: the suite comment replaces {old!r}, not in the block"
        code = code.replace(old, new)
    return code


def blocks() -> list[Block]:
    """Every ``python`` block of README.md and docs/*.md, in page order."""
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        rel = page.relative_to(ROOT).as_posix()
        for i, m in enumerate(_BLOCK.finditer(text)):
            found.append(Block(rel, i, m["code"], m["subs"]))
    return found


def run(block: Block, folder: Path, monkeypatch: pytest.MonkeyPatch) -> dict:
    """Run ``block`` in ``folder`` (with ``examples/`` and ``docs/`` linked in); its namespace."""
    for name in ("examples", "docs"):
        (folder / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(folder)
    namespace: dict = {"__name__": "__docs__"}
    exec(compile(block.code, block.id, "exec"), namespace)  # noqa: S102
    return namespace


BLOCKS = blocks()


def test_the_pages_have_code_to_run():
    pages = {b.page for b in BLOCKS}
    assert "README.md" in pages and "docs/equations.md" in pages
    assert len(BLOCKS) >= 5


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.id != "README.md#0"],
                         ids=lambda b: b.id)
def test_a_documented_block_runs(block, tmp_path, monkeypatch):
    run(block, tmp_path, monkeypatch)


def test_the_readme_example_gives_what_it_says(tmp_path, monkeypatch):
    (block,) = [b for b in BLOCKS if b.id == "README.md#0"]
    assert "mg.Grid((24, 24)" in block.code and "steps=40" in block.code
    namespace = run(block, tmp_path, monkeypatch)
    assert namespace["v"].shape == (24, 24)
    assert namespace["frames"].shape == (5, 2, 24, 24)
    assert isinstance(namespace["solution"], mg.Solution)
    assert np.all(np.isfinite(namespace["v"]))


def test_a_stale_suite_comment_fails():
    with pytest.raises(AssertionError, match="not in the block"):
        _shrink("steps=10", "steps=8000 -> steps=40", "page")
    assert _shrink("grid (256, 256)", "(256, 256) -> (8, 8)", "page") == "grid (8, 8)"
