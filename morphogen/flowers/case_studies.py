"""The flower case studies shipped with morphogen (Ringham et al. 2021, §4).

Each flower pipeline under ``examples/flowers/*.toml``, plus the two older mesh pipelines
``examples/mimulus-mesh-pipeline.toml`` (§4.5) and ``examples/kohleria-mesh-pipeline.toml``
(§4.7), is a case study; its section is the first ``§N.M`` of the file's leading comment. A
file that is not a pipeline (a model file such as ``dianthus-diffusion.toml``, which has no
``[mesh]`` table) is not a flower. ``morphogen gallery flowers`` runs them all and the web app's
Mesh page offers them.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from morphogen.models.text import toml_text

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
"""The repository's ``examples/`` directory."""

_EXTRA = ("mimulus-mesh-pipeline.toml", "kohleria-mesh-pipeline.toml")
_SECTION = re.compile(r"§\s*(\d+(?:\.\d+)*)")
_KNOWN_SECTIONS = {"mimulus": "4.5", "kohleria": "4.7"}


@dataclass(frozen=True)
class Flower:
    """One case study: its short name, pipeline file and Ringham et al. section (or None)."""

    name: str
    path: Path
    section: str | None

    @property
    def caption(self) -> str:
        return f"{self.name} (Ringham §{self.section})" if self.section else self.name


def _is_pipeline(path: Path) -> bool:
    try:
        data = toml_text.loads(path.read_text())
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return True  # let the pipeline loader report it as that flower's error
    return isinstance(data.get("mesh"), dict) and "stage" in data


def _section(path: Path, name: str) -> str | None:
    """The first ``§N.M`` in the file's leading comment block, else a known section."""
    header = []
    for line in path.read_text(errors="replace").splitlines():
        if not line.startswith("#"):
            break
        header.append(line)
    found = _SECTION.search("\n".join(header))
    return found.group(1) if found else _KNOWN_SECTIONS.get(name)


def find_flowers(examples: Path = EXAMPLES) -> list[Flower]:
    """The flower pipelines under ``examples``, sorted by section, then name."""
    paths = sorted((examples / "flowers").glob("*.toml"))
    paths += [examples / f for f in _EXTRA if (examples / f).is_file()]
    flowers = []
    for path in paths:
        if not _is_pipeline(path):
            continue
        name = path.stem.removesuffix("-mesh-pipeline")
        flowers.append(Flower(name, path, _section(path, name)))

    def key(f: Flower) -> tuple:
        sec = tuple(int(p) for p in f.section.split(".")) if f.section else (99,)
        return sec, f.name

    return sorted(flowers, key=key)
