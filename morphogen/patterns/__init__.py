"""Pattern descriptors and families (Richard et al. §5.2.2): measure a pattern, name its kind."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "describe": "morphogen.patterns.descriptors",
    "describe_batch": "morphogen.patterns.descriptors",
    "describe_all": "morphogen.patterns.descriptors",
    "describe_dynamics": "morphogen.patterns.descriptors",
    "radial_spectrum": "morphogen.patterns.spectrum",
    "power_spectrum": "morphogen.patterns.spectrum",
    "spectrum_distribution": "morphogen.patterns.spectrum",
    "wasserstein_1d": "morphogen.patterns.spectrum",
    "euler_characteristic": "morphogen.patterns.descriptors",
    "classify_presets": "morphogen.patterns.presets",
    "PresetResult": "morphogen.patterns.presets",
    "simulate_watched": "morphogen.patterns.watch",
})
