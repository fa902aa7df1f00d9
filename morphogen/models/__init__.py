"""What reacts: the Model, the library of classic models, GenRD, mass-action networks, neural
rules, model-file and Antimony/SBML readers, and linear stability."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "Model": "morphogen.models.model",
    "Tensor": "morphogen.models.model",
    "reaction_jacobian": "morphogen.models.model",
    "load_model": "morphogen.models.registry",
    "parse_model": "morphogen.models.text.equations",
    "load_model_file": "morphogen.models.text.equations",
    "LIBRARY": "morphogen.models.library",
    "get_model": "morphogen.models.library",
    "register": "morphogen.models.library",
    "mass_action": "morphogen.models.network",
    "ReactionNetwork": "morphogen.models.network",
    "NeuralConfig": "morphogen.models.neural",
    "neural_model": "morphogen.models.neural",
    "load_neural_model": "morphogen.models.neural",
    "save_neural_model": "morphogen.models.neural",
    "TuringMode": "morphogen.models.linear",
    "fastest_mode": "morphogen.models.linear",
    "growth_rates": "morphogen.models.linear",
    "jacobian": "morphogen.models.linear",
})
