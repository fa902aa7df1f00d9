"""Differentiable training of reaction-diffusion rules (Mordvintsev et al., seed 002): texture
descriptors, the rotation-invariant texture loss, seed states and pool training."""
