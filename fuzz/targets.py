"""Coverage-guided fuzz targets (atheris / libFuzzer) for the parsers that read untrusted files.

Each target takes the fuzzer's bytes and feeds them to one reader. The contract is the project's
bad-input rule: the input loads, or the reader raises :class:`MorphogenError` (one line for the
user). Any other exception, a hang (libFuzzer's ``-timeout``) or a memory blow-up
(``-rss_limit_mb``) is a finding, and libFuzzer stops with the input saved as ``crash-*``.

Run through ``python -m fuzz.run TARGET`` (``make fuzz`` runs every target for longer).
"""

from __future__ import annotations

import functools
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import atheris

from fuzz.run import CANARY, CANARY_TEXT

with atheris.instrument_imports(include=["morphogen"]):
    from morphogen.domains.ply import load_mesh
    from morphogen.errors import MorphogenError
    from morphogen.models.text.equations import parse_model
    from morphogen.models.text.sbml import load_network_file

_SCRATCH = Path(tempfile.mkdtemp(prefix="morphogen-fuzz-", dir="/dev/shm" if
                                 os.path.isdir("/dev/shm") else None))


def equations(data: bytes) -> None:
    """Model-file text (any bytes, decoded as UTF-8 with replacement) through ``parse_model``."""
    text = data.decode("utf-8", errors="replace")
    try:
        parse_model(text, name="fuzz")
    except MorphogenError:
        pass


def ply(data: bytes) -> None:
    """PLY bytes, written to a scratch file, through ``load_mesh`` (header, elements, mesh)."""
    path = _SCRATCH / "input.ply"
    path.write_bytes(data)
    try:
        load_mesh(path)
    except MorphogenError:
        pass


@functools.cache
def _canary() -> Path:
    """The canary file, written (once per process) before the first network input."""
    CANARY.write_text(CANARY_TEXT, encoding="utf-8")
    return CANARY


class FileRead(AssertionError):
    """libAntimony read another file while loading a network (the ``import`` canary)."""


def network(data: bytes) -> None:
    """Antimony or SBML bytes (SBML when they start with ``<``, after blanks), written to a
    scratch ``.xml``/``.ant`` file, through ``load_network_file`` (libAntimony, libSBML, the
    mass-action check, the network model) and back through ``parse_model`` of the model file a
    run records for it, so whatever loads also replays. A trace of the canary file
    (:data:`fuzz.run.CANARY`, which the seeds ``import``) in the model or the message means a
    file was read: a finding."""
    canary = _canary()
    path = _SCRATCH / ("input.xml" if data.lstrip()[:1] == b"<" else "input.ant")
    path.write_bytes(data)
    try:
        model = load_network_file(path)
        parse_model(model.source, name="fuzz")
        seen = model.source
    except MorphogenError as exc:
        seen = str(exc)
    if "FUZZ_CANARY" in seen or f"file '{canary}'" in seen:
        raise FileRead(f"a network file made libAntimony read {canary}: {seen[:200]}")


TARGETS: dict[str, Callable[[bytes], None]] = {"equations": equations, "ply": ply,
                                               "network": network}


def main(argv: list[str]) -> None:
    """``targets.py TARGET [libFuzzer flags...] CORPUS``: run one target under atheris."""
    target = TARGETS[argv[1]]
    atheris.Setup([argv[0], *argv[2:]], target)
    atheris.Fuzz()


if __name__ == "__main__":
    main(sys.argv)
