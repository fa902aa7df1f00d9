"""From a picture to a model: :func:`match` finds the reaction-diffusion model, parameters and
scale that grow a pattern like the one in a picture (see :mod:`morphogen.match.api`)."""

from morphogen.match.api import POLARITIES as POLARITIES
from morphogen.match.api import MatchResult as MatchResult
from morphogen.match.api import describe_picture as describe_picture
from morphogen.match.api import match as match
from morphogen.match.boxes import BOXES as BOXES
from morphogen.match.boxes import DEFAULT_MODELS as DEFAULT_MODELS
from morphogen.match.picture import CHANNELS as CHANNELS
from morphogen.match.picture import load_picture as load_picture
