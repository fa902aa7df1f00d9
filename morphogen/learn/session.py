"""A training run on disk: the loop, periodic checkpoints, ``--resume``, samples and plots.

A run directory holds

- ``checkpoint.npz``: the full :class:`~morphogen.learn.train.TrainState` (weights, Adam state,
  pool, iteration, key), the settings, the target image and the loss history; rewritten
  atomically every ``checkpoint_every`` iterations and when the run is interrupted;
- ``model.npz``: the trained rule (:func:`morphogen.models.neural.save_neural_model`), small,
  runnable with ``morphogen simulate``;
- ``loss.png`` and ``loss.csv``: the loss curve;
- ``samples/iter_NNNNNN.png``: the target, four pool states and four fresh seeds grown with the
  current weights.

Resuming restores the state exactly, and iteration ``i`` always draws its randomness from
``fold_in(key, i)``, so an interrupted and resumed run ends with the same weights as an
uninterrupted one.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from morphogen.errors import MorphogenError
from morphogen.learn.extractors import make_extractor
from morphogen.learn.loss import TextureLoss, texture_loss
from morphogen.learn.textures import state_to_rgb, to_uint8
from morphogen.learn.train import (
    TrainConfig,
    TrainState,
    grow_samples,
    init_state,
    make_train_step,
)
from morphogen.models.neural import read_npz, save_neural_model
from morphogen.util import guard
from morphogen.util.io import ensure_writable_dir, write_atomic, write_npz
from morphogen.util.progress import ProgressBar

CHECKPOINT = "checkpoint.npz"
MODEL = "model.npz"


@dataclass
class Run:
    """A training run: settings, target, state and loss history."""

    config: TrainConfig
    target: np.ndarray
    state: TrainState
    losses: list[float]
    target_name: str = ""

    @property
    def iteration(self) -> int:
        return int(self.state.iteration)


def resolve_features(config: TrainConfig) -> str:
    """The extractor a run uses: ``auto`` becomes ``vgg`` when weights are found, else
    ``random``."""
    if config.features != "auto":
        return config.features
    from morphogen.learn.vgg import find_vgg_weights

    return "vgg" if (config.vgg_weights or find_vgg_weights()) else "random"


def build_loss(config: TrainConfig, target: np.ndarray) -> TextureLoss:
    """The run's texture loss against ``target`` (``(S, S, 3)`` in ``[0, 1]``)."""
    extractor = make_extractor(resolve_features(config), config.vgg_weights)
    return texture_loss(target, extractor, config.n_rot)


def new_run(config: TrainConfig, target: np.ndarray, target_name: str = "") -> Run:
    """A fresh run at iteration 0. ``features="auto"`` is resolved here, so the checkpoint
    records the extractor used and a resumed run keeps it."""
    config = replace(config, features=resolve_features(config))
    return Run(config, np.asarray(target, np.float32), init_state(config), [], target_name)


def save_checkpoint(directory: str | Path, run: Run) -> Path:
    """Write ``checkpoint.npz`` (atomically) and ``model.npz`` into ``directory``."""
    directory = ensure_writable_dir(directory)
    state = run.state
    arrays = {f"weights/{k}": np.asarray(v) for k, v in state.weights.items()}
    for i, leaf in enumerate(jax.tree_util.tree_leaves(state.opt_state)):
        arrays[f"opt/{i}"] = np.asarray(leaf)
    meta = {"config": run.config.to_dict(), "target_name": run.target_name}
    arrays.update(
        pool=np.asarray(state.pool),
        iteration=np.asarray(state.iteration),
        key=np.asarray(jax.random.key_data(state.key) if _typed(state.key) else state.key),
        target=run.target,
        losses=np.asarray(run.losses, np.float32),
        meta=np.array(json.dumps(meta)),
    )
    path = directory / CHECKPOINT
    write_npz(path, arrays)
    save_model(directory / MODEL, run)
    return path


def save_model(path: str | Path, run: Run) -> Path:
    """Write the run's current rule as a small neural model file."""
    metadata = {
        "target": run.target_name,
        "iterations": run.iteration,
        "features": resolve_features(run.config),
        "training": {k: v for k, v in run.config.to_dict().items() if k != "vgg_weights"},
    }
    weights = {k: np.asarray(v) for k, v in run.state.weights.items()}
    return save_neural_model(path, run.config.neural, weights, metadata)


def load_checkpoint(directory: str | Path) -> Run:
    """Read ``checkpoint.npz`` from a run directory.

    Every entry is checked before anything is built from it: the ``meta`` JSON (settings of
    the right types, within the memory guard), and each array's presence, kind and shape
    against a fresh run of those settings, so a damaged or foreign file is one line.

    Raises:
        MorphogenError: no checkpoint there, or it is damaged or of another layout.
    """
    path = Path(directory) / CHECKPOINT
    if not path.exists():  # anything else there is named by the reader (a FIFO, a folder)
        raise MorphogenError(f"no training checkpoint in {directory} (expected {path})")
    arrays = read_npz(path, "training checkpoint")
    meta = _meta(arrays, path)
    config = _settings(meta.get("config"), path)
    target_name = meta.get("target_name", "")
    if not isinstance(target_name, str):
        raise _damaged(path, "its target name is not a text")
    template = init_state(config)
    for k, leaf in template.weights.items():
        _check_entry(arrays, f"weights/{k}", leaf, path)
    leaves, treedef = jax.tree_util.tree_flatten(template.opt_state)
    for i, leaf in enumerate(leaves):
        _check_entry(arrays, f"opt/{i}", leaf, path)
    _check_entry(arrays, "pool", template.pool, path)
    _check_entry(arrays, "iteration", template.iteration, path)
    key = jax.random.key_data(template.key) if _typed(template.key) else template.key
    _check_entry(arrays, "key", key, path)
    target, losses = arrays.get("target"), arrays.get("losses")
    if target is None or target.ndim != 3 or target.shape[-1] != 3 or target.dtype.kind != "f":
        raise _damaged(path, "its target image is missing or not an (S, S, 3) float array")
    if losses is None or losses.ndim != 1 or losses.dtype.kind != "f":
        raise _damaged(path, "its loss history is missing or not a list of numbers")
    if int(arrays["iteration"]) < 0:
        raise _damaged(path, "its iteration count is negative")
    weights = {k: jnp.asarray(arrays[f"weights/{k}"]) for k in template.weights}
    opt_leaves = [
        jnp.asarray(arrays[f"opt/{i}"], dtype=jnp.asarray(leaf).dtype)
        for i, leaf in enumerate(leaves)
    ]
    state = TrainState(
        weights=weights,
        opt_state=jax.tree_util.tree_unflatten(treedef, opt_leaves),
        pool=jnp.asarray(arrays["pool"]),
        iteration=jnp.asarray(arrays["iteration"], jnp.int32),
        key=jnp.asarray(arrays["key"], template.key.dtype),
    )
    return Run(config, arrays["target"], state, [float(v) for v in losses], target_name)


def _damaged(path: Path, what: str) -> MorphogenError:
    return MorphogenError(f"training checkpoint {path} is damaged: {what}; restore it or start "
                          "a new run")


def _meta(arrays: dict[str, np.ndarray], path: Path) -> dict:
    """The checkpoint's ``meta`` entry: one JSON object."""
    entry = arrays.get("meta")
    if entry is None or entry.ndim != 0 or entry.dtype.kind != "U":
        raise _damaged(path, "it has no 'meta' text (is it a morphogen training checkpoint?)")
    try:
        meta = json.loads(str(entry))
    except (ValueError, RecursionError):
        raise _damaged(path, "its 'meta' entry is not valid JSON") from None
    if not isinstance(meta, dict):
        raise _damaged(path, "its 'meta' entry is not a JSON object")
    return meta


def _settings(data: object, path: Path) -> TrainConfig:
    """The run's :class:`TrainConfig` from ``meta["config"]``: every setting of its field's
    type (whole numbers for counts, numbers for rates, texts), within the memory guard."""
    from dataclasses import fields

    if not isinstance(data, dict):
        raise _damaged(path, "its settings are not a JSON object")
    defaults = TrainConfig()
    for f in fields(TrainConfig):
        if f.name not in data:
            continue
        value, default = data[f.name], getattr(defaults, f.name)
        if isinstance(default, bool):
            ok = isinstance(value, bool)
        elif isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = isinstance(value, int | float) and not isinstance(value, bool) \
                and math.isfinite(value)
        elif isinstance(default, tuple):
            ok = isinstance(value, list | tuple) and all(
                isinstance(v, int) and not isinstance(v, bool) for v in value)
        else:  # texts (features) and the optional VGG weight file
            ok = isinstance(value, str) or (value is None and default is None)
        if not ok:
            raise _damaged(path, f"setting {f.name} = {str(value)[:40]!r} has the wrong type")
    try:
        config = TrainConfig.from_dict(data)
    except MorphogenError as exc:
        raise _damaged(path, str(exc)) from None
    try:
        guard.check_memory(config.size * config.size, config.channels, batch=config.pool_size)
        guard.check_memory(config.hidden, 2 * config.channels)  # the weights and their moments
    except MorphogenError as exc:
        raise _damaged(path, f"its settings are out of bounds ({exc})") from None
    return config


def _check_entry(arrays: dict[str, np.ndarray], name: str, like: Any, path: Path) -> None:
    """``arrays[name]`` exists, has the shape of ``like`` and numbers of its kind."""
    arr = arrays.get(name)
    expected = np.shape(like)
    kind = np.dtype(jnp.asarray(like).dtype).kind
    if arr is None:
        raise _damaged(path, f"entry {name!r} is missing")
    if arr.shape != expected or arr.dtype.kind != kind:
        raise _damaged(path, f"entry {name!r} is {arr.dtype} {arr.shape}, expected "
                       f"{np.dtype(jnp.asarray(like).dtype)} {expected} for its settings")


def _typed(key: jax.Array) -> bool:
    return jnp.issubdtype(key.dtype, jax.dtypes.prng_key)


def train(
    run: Run,
    directory: str | Path | None,
    *,
    iterations: int | None = None,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
) -> Run:
    """Continue ``run`` until ``iterations`` (default: its settings' ``iterations``) are done.

    Writes checkpoints, samples and the loss curve into ``directory`` (nothing when ``None``).
    On ``KeyboardInterrupt`` a checkpoint of the last finished iteration is written before the
    interrupt propagates, so ``--resume`` continues from there.
    """
    config = run.config
    total = config.iterations if iterations is None else int(iterations)
    loss = build_loss(config, run.target)
    step = make_train_step(config)
    bar = ProgressBar(max(total - run.iteration, 0), enabled=progress, unit="it", desc="train")
    try:
        while run.iteration < total:
            state, metrics = step(run.state, loss)
            run.state = state
            run.losses.append(float(metrics["loss"]))
            bar.update(1)
            i = run.iteration
            if directory is not None and (i % config.checkpoint_every == 0 or i == total):
                save_checkpoint(directory, run)
                write_loss_curve(directory, run.losses)
            if directory is not None and (i % config.sample_every == 0 or i == total):
                write_samples(directory, run, loss)
            if log is not None and (i % 10 == 0 or i == total):
                log(f"iteration {i}: loss {np.mean(run.losses[-10:]):.4g}")
    except KeyboardInterrupt:
        if directory is not None:
            save_checkpoint(directory, run)
            write_loss_curve(directory, run.losses)
        raise
    finally:
        bar.close()
    return run


def write_samples(directory: str | Path, run: Run, loss: TextureLoss) -> Path:
    """``samples/iter_NNNNNN.png``: target | 4 pool states (top), target | 4 grown seeds."""
    from morphogen.render import write_png

    config = run.config
    grown = grow_samples(config, run.state.weights, 4, config.sample_steps, run.iteration)
    pool = run.state.pool[:4]
    target = to_uint8(_fit(run.target, config.size))
    rows = []
    for states in (pool, grown):
        tiles = to_uint8(np.asarray(state_to_rgb(states)))
        rows.append(np.concatenate([target, *tiles], axis=1))
    image = np.concatenate(rows, axis=0)
    path = Path(directory) / "samples" / f"iter_{run.iteration:06d}.png"
    return write_png(path, np.repeat(np.repeat(image, 2, axis=0), 2, axis=1))


def _fit(img: np.ndarray, size: int) -> np.ndarray:
    """Crop or tile an image ``(S, S, 3)`` to ``(size, size, 3)`` for display."""
    reps = -(-size // img.shape[0])
    return np.tile(img, (reps, reps, 1))[:size, :size]


def write_loss_curve(directory: str | Path, losses: list[float]) -> None:
    """``loss.csv`` (iteration, loss) and ``loss.png`` (log scale, with a running median, which
    the occasional spike of a fresh seed or a runaway state does not drag)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    directory = Path(directory)
    values = np.asarray(losses, np.float64)
    its = np.arange(1, len(values) + 1)
    text = "iteration,loss\n" + "".join(f"{i},{v:.6g}\n" for i, v in zip(its, values, strict=True))
    write_atomic(directory / "loss.csv", lambda fh: fh.write(text.encode()))
    fig, ax = plt.subplots(figsize=(6, 3.5), dpi=100)
    ax.semilogy(its, values, color="0.75", lw=0.8, label="per iteration")
    if len(values) >= 10:
        w = max(5, len(values) // 30)
        median = np.median(np.lib.stride_tricks.sliding_window_view(values, w), axis=1)
        ax.semilogy(its[w - 1 :], median, color="C0", lw=1.5, label=f"median of {w}")
    ax.set_xlabel("iteration")
    ax.set_ylabel("texture loss")
    ax.legend(loc="upper right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    write_atomic(directory / "loss.png", lambda fh: fh.write(buf.getvalue()))

