"""Differentiable training of reaction-diffusion rules (Mordvintsev et al., seed 002): texture
descriptors, the rotation-invariant texture loss, seed states, pool training (Algorithm 1) and
resumable training runs on disk."""

from morphogen.learn.extractors import EXTRACTORS as EXTRACTORS
from morphogen.learn.extractors import make_extractor as make_extractor
from morphogen.learn.features import RandomFeatures as RandomFeatures
from morphogen.learn.features import SpectrumFeatures as SpectrumFeatures
from morphogen.learn.loss import TextureLoss as TextureLoss
from morphogen.learn.loss import texture_loss as texture_loss
from morphogen.learn.rollout import rollout as rollout
from morphogen.learn.seeds import seed_batch as seed_batch
from morphogen.learn.seeds import seed_state as seed_state
from morphogen.learn.session import Run as Run
from morphogen.learn.session import load_checkpoint as load_checkpoint
from morphogen.learn.session import new_run as new_run
from morphogen.learn.session import train as train
from morphogen.learn.textures import load_texture as load_texture
from morphogen.learn.textures import state_to_rgb as state_to_rgb
from morphogen.learn.textures import synthetic_texture as synthetic_texture
from morphogen.learn.train import PRESETS as PRESETS
from morphogen.learn.train import TrainConfig as TrainConfig
from morphogen.learn.train import preset as preset
