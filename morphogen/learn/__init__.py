"""Differentiable training of reaction-diffusion rules (Mordvintsev et al., seed 002): texture
descriptors, the rotation-invariant texture loss, seed states, pool training (Algorithm 1) and
resumable training runs on disk."""

from morphogen.util.exports import lazy_exports

__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    "EXTRACTORS": "morphogen.learn.extractors",
    "make_extractor": "morphogen.learn.extractors",
    "RandomFeatures": "morphogen.learn.features",
    "SpectrumFeatures": "morphogen.learn.features",
    "TextureLoss": "morphogen.learn.loss",
    "texture_loss": "morphogen.learn.loss",
    "seed_batch": "morphogen.learn.seeds",
    "seed_state": "morphogen.learn.seeds",
    "Run": "morphogen.learn.session",
    "load_checkpoint": "morphogen.learn.session",
    "new_run": "morphogen.learn.session",
    "load_texture": "morphogen.learn.textures",
    "state_to_rgb": "morphogen.learn.textures",
    "synthetic_texture": "morphogen.learn.textures",
    "PRESETS": "morphogen.learn.train",
    "TrainConfig": "morphogen.learn.train",
    "preset": "morphogen.learn.train",
})
