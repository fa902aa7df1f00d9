"""The time loop: integrate (the pure, differentiable core), simulate and simulate_batch with
their monitors, adaptive runs, initial states and batches."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "simulate_batch": "morphogen.engine.simulate",
    "integrate": "morphogen.engine.simulate",
    "Solution": "morphogen.engine.simulate",
    "simulate_adaptive": "morphogen.engine.adaptive_loop",
    "AdaptiveRun": "morphogen.engine.adaptive_loop",
    "make_initial": "morphogen.engine.initial",
    "load_state": "morphogen.engine.initial",
    "stack_params": "morphogen.engine.batch",
    "stack_states": "morphogen.engine.batch",
    "resolve_params": "morphogen.engine.fields",
})
