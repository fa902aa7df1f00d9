"""From a picture to a model: :func:`match` finds the reaction-diffusion model, parameters and
scale that grow a pattern like the one in a picture (see :mod:`morphogen.match.api`)."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "POLARITIES": "morphogen.match.api",
    "MatchResult": "morphogen.match.api",
    "describe_picture": "morphogen.match.api",
    "match": "morphogen.match.api",
    "BOXES": "morphogen.match.boxes",
    "DEFAULT_MODELS": "morphogen.match.boxes",
    "CHANNELS": "morphogen.match.picture",
    "load_picture": "morphogen.match.picture",
})
