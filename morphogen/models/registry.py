"""Find a model by name or file: the one entry point every front end uses.

A name is looked up in the library (:mod:`morphogen.models.library`, neural rules included); a
path is read by its suffix: a model file (``.toml``, :mod:`morphogen.models.text.equations`), a
trained neural rule (``.npz``, :mod:`morphogen.models.neural`) or a mass-action network
(``.ant``/``.antimony``/``.xml``/``.sbml``, :mod:`morphogen.models.text.sbml`).
"""

from __future__ import annotations

import os

from morphogen.models.model import Model
from morphogen.models.text.equations import load_model_file


def load_model(name_or_path: str | os.PathLike) -> Model:
    """A library model by name, or a model file.

    A path ending in ``.toml`` is parsed, one ending in ``.npz`` is read as a trained neural RD
    model, one ending in ``.ant``/``.antimony``/``.xml``/``.sbml`` is read as a mass-action
    network (:mod:`morphogen.models.text.sbml`); otherwise a library name is looked up, and an
    existing file of that name is parsed.
    """
    text = os.fspath(name_or_path)
    if text.endswith(".toml"):
        return load_model_file(text)
    if text.endswith(".npz"):
        from morphogen.models.neural import load_neural_model

        return load_neural_model(text)
    if text.lower().endswith((".ant", ".antimony", ".xml", ".sbml")):
        from morphogen.models.text.sbml import load_network_file

        return load_network_file(text)
    from morphogen.models.library import LIBRARY, get_model

    if text not in LIBRARY and os.path.exists(text):
        return load_model_file(text)  # read through check_input_file: a device or FIFO named
    return get_model(text)
