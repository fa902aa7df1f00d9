"""Neural reaction-diffusion: a small MLP as the reaction term (Mordvintsev et al., seed 002).

The model is the PDE system ("Differentiable Reaction-Diffusion Model")

.. math::

    \\partial_t x_i = c_i\\nabla^2 x_i + f_\\theta(x_0, \\dots, x_{n-1}),\\qquad
    f_\\theta(\\mathbf x) = \\mathrm{act}(\\mathbf x W_0 + b_0)\\, W_1,\\qquad
    \\mathrm{act}(x) = x\\,\\sigma(5x)

with ``W0`` of shape ``(n, h)``, ``b0`` ``(h,)`` and ``W1`` ``(h, n)``. Its discrete update rule
(eq. 1) is

.. math::

    x_i^{t+1} = x_i^t + c_i\\,(K_{lap} * x_i^t)\\, d + f_\\theta(\\mathbf x^t)\\, r,
    \\qquad d = \\Delta_t/\\Delta_h^2,\\quad r = \\Delta_t

Here it is an ordinary :class:`~morphogen.models.model.Model`: the reaction is ``r * f(x)`` and
the diffusion coefficient of channel ``i`` is ``c_i * d * KERNEL_SCALE``; one explicit Euler step
with ``dt = 1`` on a unit grid is exactly eq. 1 with ``K_lap = KERNEL_SCALE * (domain
Laplacian)``. ``r`` and ``d`` are parameters (scalars or fields, fig. 4). The network weights
are runtime parameters too: passed in the parameter pytree (``W0``, ``b0``, ``W1``) they override
the model's own, so the same compiled program runs any weights and ``jax.grad`` flows to them.
The model runs unchanged on any domain that has a diffusion operator (2D or 3D grid, triangle
mesh).

The diffusion coefficients are fixed in four groups ``c = 1/8, 1/4, 1/2, 1`` (the paper's texture
experiments, so the RGB channels ``x0..x2`` diffuse slowest) or learned as
``c_i = sigmoid(c_hat_i)``.

A trained model is saved as a small ``.npz`` file holding the weights and a JSON configuration
(:func:`save_neural_model`, :func:`load_neural_model`).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.models.model import Array, Model, Params
from morphogen.util.io import write_npz

DIFFUSION_GROUPS = (1.0 / 8.0, 1.0 / 4.0, 1.0 / 2.0, 1.0)
"""Fixed per-channel diffusion coefficients, one value per quarter of the channels."""

KERNEL_SCALE = 0.25
"""``K_lap = KERNEL_SCALE * Laplacian``: the 3x3 kernel of eq. 1 is a quarter of the unit-grid
Laplacian (as is ``[[1, 2, 1], [2, -12, 2], [1, 2, 1]] / 16``, which approximates a quarter of
it), so the fastest channel (``c = 1``) is stable at ``r = d = dt = 1``: the 9-point stencil's
spectral radius is ``16/3``, times ``1/4`` gives ``4/3 < 2``."""

SEED_SPACING = 16.0
"""Seed states have one Gaussian blob per ``16^d`` cells (per ``(16 h)^2`` of mesh area)."""
SEED_SIGMA = 2.0
"""Standard deviation of a seed blob, in cells (mesh edge lengths). The training pool's seeds
(:mod:`morphogen.learn.seeds`) use the same two numbers, so a run starts as training did."""

FORMAT = "morphogen-neural-rd"
FORMAT_VERSION = 1


@dataclass(frozen=True)
class NeuralConfig:
    """Shape of a neural RD model.

    Attributes:
        channels: number of "chemicals" ``n`` (at least 3: the first three are RGB).
        hidden: hidden units ``h`` of the reaction network.
        learn_diffusion: learn ``c_i = sigmoid(c_hat_i)`` instead of the fixed groups.
    """

    channels: int = 12
    hidden: int = 64
    learn_diffusion: bool = False

    def __post_init__(self) -> None:
        if int(self.channels) < 3:
            raise MorphogenError(
                f"a neural RD model needs at least 3 channels (RGB), got {self.channels}"
            )
        if int(self.hidden) < 1:
            raise MorphogenError(f"hidden units must be >= 1, got {self.hidden}")

    @property
    def parameter_count(self) -> int:
        """Number of trained numbers: ``n h + h + h n`` (+ ``n`` if diffusion is learned);
        8320 for the paper's ``n = 32, h = 128``."""
        n, h = self.channels, self.hidden
        return 2 * n * h + h + (n if self.learn_diffusion else 0)


def fixed_diffusion(channels: int) -> np.ndarray:
    """The fixed coefficients: channel ``i`` gets ``DIFFUSION_GROUPS[floor(4 i / n)]``, shape
    ``(n,)``; for ``n = 32``: ``c_0..7 = 1/8, c_8..15 = 1/4, c_16..23 = 1/2, c_24..31 = 1``."""
    groups = (4 * np.arange(channels)) // channels
    return np.asarray(DIFFUSION_GROUPS, np.float32)[groups]


def activation(x: Array) -> Array:
    """``act(x) = x * sigmoid(5 x)`` (a Swish variant, seed 002 "Texture synthesis")."""
    return x * jax.nn.sigmoid(5.0 * x)


def reaction_network(u: Array, p: Params) -> Array:
    """``f_theta`` applied at every cell; ``u`` has shape ``(n, *spatial)``, so does the result.

    The network sees only the cell's own state: ``f(x) = act(x W0 + b0) W1``.
    """
    lift = (-1,) + (1,) * (u.ndim - 1)
    z = jnp.tensordot(p["W0"], u, axes=([0], [0])) + p["b0"].reshape(lift)
    return jnp.tensordot(p["W1"], activation(z), axes=([0], [0]))


def diffusion_coefficients(config: NeuralConfig, p: Params) -> Array:
    """The per-channel ``c_i``, shape ``(n,)``: fixed groups or ``sigmoid(c_hat)``."""
    if config.learn_diffusion:
        return jax.nn.sigmoid(jnp.asarray(p["c_hat"]))
    return jnp.asarray(fixed_diffusion(config.channels))


def init_weights(config: NeuralConfig, key: Array) -> dict[str, np.ndarray]:
    """Initial weights: Glorot-uniform ``W0``, zero ``b0`` and zero ``W1`` (so ``f = 0`` and
    training starts from pure diffusion); ``c_hat`` starts at the fixed groups' logits."""
    n, h = config.channels, config.hidden
    limit = np.sqrt(6.0 / (n + h))
    w0 = jax.random.uniform(key, (n, h), jnp.float32, -limit, limit)
    weights = {
        "W0": np.asarray(w0),
        "b0": np.zeros(h, np.float32),
        "W1": np.zeros((h, n), np.float32),
    }
    if config.learn_diffusion:
        c = fixed_diffusion(n).astype(np.float64)
        weights["c_hat"] = np.log(c / (1.0 - np.minimum(c, 1.0 - 1e-3))).astype(np.float32)
    return weights


def neural_model(
    config: NeuralConfig,
    weights: Mapping[str, Any],
    *,
    name: str = "neural-rd",
    description: str = "",
    r: float = 1.0,
    d: float = 1.0,
) -> Model:
    """A neural RD :class:`Model` with channels ``x0 .. x{n-1}``.

    The model's listed parameters are the rates ``r`` and ``d`` (scalars or fields, so the model
    fits everywhere parameters are resolved: run files, searches, the web app). The weights are
    runtime parameters too: a parameter dict that holds ``W0``, ``b0``, ``W1`` (``c_hat``)
    overrides the model's own, which is how training and gradient code pass them (one compiled
    program for any weights, gradients flow to them); without them the model's trained weights
    are used.

    Args:
        config: channel and hidden sizes, diffusion mode.
        weights: ``W0`` ``(n, h)``, ``b0`` ``(h,)``, ``W1`` ``(h, n)`` (and ``c_hat`` ``(n,)``
            when diffusion is learned).
        r, d: default reaction and diffusion rates of eq. 1 (training uses ``r = d = 1``);
            either may be overridden by a field at run time.

    Raises:
        MorphogenError: a weight is missing or has the wrong shape.
    """
    checked = check_weights(config, weights)
    n = config.channels
    species = tuple(f"x{i}" for i in range(n))

    def with_weights(p: Params) -> dict:
        return {k: (p[k] if k in p else v) for k, v in checked.items()}

    def reaction(u: Array, p: Params, c: Mapping) -> Array:
        return reaction_network(u, with_weights(p)) * p["r"]

    def diffusion(p: Params, c: Mapping) -> tuple:
        coeff = diffusion_coefficients(config, with_weights(p)) * (p["d"] * KERNEL_SCALE)
        return tuple(coeff[i] for i in range(n))

    return Model(
        name=name,
        species=species,
        params={"r": float(r), "d": float(d)},
        reaction=reaction,
        diffusion=diffusion,
        ground=lambda p: (0.0,) * n,
        excited=lambda p: (1.0,) * n,
        display="x0",
        description=description
        or f"neural reaction-diffusion, {n} channels, {config.hidden} hidden units",
        reference="Mordvintsev, Randazzo & Niklasson, eq. 1",
        dt=1.0,
        t_end=2000.0,
        init="blobs",
        init_options={"spacing": SEED_SPACING, "sigma": SEED_SIGMA},
        colours=rgb_channels,
    )


def rgb_channels(state: np.ndarray) -> np.ndarray:
    """The picture of a state: channels ``x0, x1, x2`` as red, green, blue, ``x[:3] + 0.5``
    (the convention of the texture loss, :func:`morphogen.learn.textures.state_to_rgb`);
    ``(n, *spatial)`` -> ``(*spatial, 3)`` on grids of any dimension and on meshes."""
    return np.moveaxis(np.asarray(state)[:3], 0, -1) + 0.5


def check_weights(config: NeuralConfig, weights: Mapping[str, Any]) -> dict[str, np.ndarray]:
    """Validate weight names, types and shapes against ``config``; returns float32 host
    copies. Weights must be real numbers (integer or floating point): strings, booleans,
    complex numbers and objects are refused rather than cast."""
    n, h = config.channels, config.hidden
    shapes = {"W0": (n, h), "b0": (h,), "W1": (h, n)}
    if config.learn_diffusion:
        shapes["c_hat"] = (n,)
    out = {}
    for key, shape in shapes.items():
        if key not in weights:
            raise MorphogenError(f"neural model weights lack {key!r} (expected shape {shape})")
        arr = np.asarray(weights[key])
        if arr.dtype.kind not in "fiu":
            raise MorphogenError(
                f"neural model weight {key!r} holds {arr.dtype} values; weights are real "
                "numbers (float32)"
            )
        arr = np.asarray(arr, np.float32)
        if arr.shape != shape:
            raise MorphogenError(
                f"neural model weight {key!r} has shape {arr.shape}, expected {shape} for "
                f"{n} channels and {h} hidden units"
            )
        if not np.all(np.isfinite(arr)):
            raise MorphogenError(f"neural model weight {key!r} contains NaN or Inf")
        out[key] = arr
    return out


def save_neural_model(
    path: str | Path,
    config: NeuralConfig,
    weights: Mapping[str, Any],
    metadata: Mapping[str, Any] | None = None,
) -> Path:
    """Write weights and configuration to one ``.npz`` file (atomically).

    The file holds the weight arrays and a ``config`` entry: a JSON string with the format
    name, version, :class:`NeuralConfig` fields and free-form ``metadata`` (e.g. the training
    target and iterations). It loads without unpickling.
    """
    checked = check_weights(config, weights)
    info = {
        "format": FORMAT,
        "version": FORMAT_VERSION,
        "config": asdict(config),
        "metadata": dict(metadata or {}),
    }
    arrays = {**checked, "config": np.array(json.dumps(info, default=str))}
    return write_npz(path, arrays)


def read_npz(path: str | Path, what: str) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` file, through the one checked reader
    (:func:`morphogen.util.npz.read_npz`): no pickles, every header checked before its data is
    read (an entry announcing more than it holds, or more than memory allows, is refused);
    any damage is one line.

    Raises:
        MorphogenError: the file is missing, not a regular file, not a zip archive (truncated,
            corrupt), or holds something that is not a plain array.
    """
    from morphogen.util.guard import LIMITS
    from morphogen.util.npz import read_npz as read_checked

    if not Path(path).exists():
        raise MorphogenError(f"{what} {path} does not exist")
    limit = int(LIMITS.memory_bytes)
    return read_checked(path, what, kinds="biufcSU", max_elements=limit // 4, max_bytes=limit)


def read_neural_file(path: str | Path) -> tuple[NeuralConfig, dict[str, np.ndarray], dict]:
    """Read a file written by :func:`save_neural_model`: ``(config, weights, metadata)``.

    The file is checked against one schema (:func:`morphogen.models.neural_schema.check_info`
    for the ``config`` entry, :func:`check_weights` for the arrays): a ``config`` JSON object
    with ``format``, an integer ``version`` this morphogen reads, the :class:`NeuralConfig`
    fields and a ``metadata`` object; the arrays ``W0``, ``b0``, ``W1`` (and ``c_hat``) of
    real numbers, and nothing else.

    Raises:
        MorphogenError: the file is missing, not a neural model, damaged, or of a newer format.
    """
    from morphogen.models.neural_schema import check_info

    path = Path(path)
    arrays = read_npz(path, "neural model file")
    if "config" not in arrays:
        raise MorphogenError(f"{path} is not a morphogen neural model (no 'config' entry)")
    entry = arrays.pop("config")
    if entry.ndim != 0 or entry.dtype.kind != "U":
        raise MorphogenError(f"{path}: the 'config' entry must be one JSON text")
    try:
        info = json.loads(str(entry))
    except (ValueError, RecursionError):
        raise MorphogenError(f"{path}: the 'config' entry is not valid JSON") from None
    shape, metadata = check_info(info, str(path), FORMAT, FORMAT_VERSION)
    config = NeuralConfig(**shape)
    expected = {"W0", "b0", "W1"} | ({"c_hat"} if config.learn_diffusion else set())
    extra = sorted(set(arrays) - expected)
    if extra:
        raise MorphogenError(
            f"{path}: unexpected entry {extra[0]!r}; a neural model file holds config and the "
            f"weights {', '.join(sorted(expected))}"
        )
    try:
        weights = check_weights(config, arrays)
    except MorphogenError as exc:
        raise MorphogenError(f"{path}: {exc}") from None
    return config, weights, metadata


def load_neural_model(path: str | Path) -> Model:
    """The :class:`Model` stored in a neural model file (see :func:`save_neural_model`)."""
    config, weights, metadata = read_neural_file(path)
    target = metadata.get("target")
    description = f"neural RD trained on {Path(target).name}" if target else ""
    return neural_model(config, weights, name=Path(path).stem, description=description)

