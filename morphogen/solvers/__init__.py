"""How a state steps: the scheme registry, one Stepper per scheme, stability limits and the
choice of a scheme for a problem."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "SCHEMES": "morphogen.solvers.registry",
    "SchemeInfo": "morphogen.solvers.registry",
    "Stepper": "morphogen.solvers.base",
    "Advance": "morphogen.solvers.base",
    "make_step": "morphogen.solvers.step",
    "max_stable_dt": "morphogen.solvers.step",
    "check_stability": "morphogen.solvers.step",
    "Noise": "morphogen.solvers.step",
    "Step": "morphogen.solvers.step",
    "choose_scheme": "morphogen.solvers.auto",
})
