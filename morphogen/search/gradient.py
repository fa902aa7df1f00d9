"""Gradient fitting: a model's parameters fitted to a target image by gradient descent through
the simulator (seed 002's differentiable programming, applied to classic models).

The simulator is differentiable (:func:`morphogen.learn.rollout.rollout` over
:func:`morphogen.solvers.step.make_step`), so the rotation-invariant texture loss of
:mod:`morphogen.learn.loss` between the final pattern and a target image has a gradient with
respect to every parameter. This module offers it through the evolutionary search's interface:

- :class:`GradientEvaluator` is an ``evaluate(genomes (P, G), key) -> (fitness (P,), metrics)``
  built from the same :class:`~morphogen.search.evaluate.Problem`; ``fitness = -loss`` (higher
  is better) and ``metrics["gradient"]`` is ``d fitness / d genome``, shape ``(P, G)``;
- :class:`GradientAscent` is a :class:`~morphogen.search.strategy.Strategy` whose ``tell`` also
  takes that gradient: each of the ``P`` genomes is an independent start point (multi-start)
  moved by Adam in units of its genes' ranges and kept inside the bounds.

Both fitted and target patterns are compared as images of the display species, standardised
to zero mean and unit variance (:func:`field_image`), so only the pattern's geometry matters,
not the colour map the target image was drawn with.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from morphogen.errors import MorphogenError
from morphogen.learn.extractors import make_extractor
from morphogen.learn.loss import TextureLoss, texture_loss
from morphogen.learn.rollout import rollout
from morphogen.search.evaluate import Evaluator, Problem
from morphogen.search.genes import Gene
from morphogen.search.strategy import Array, State, Strategy
from morphogen.solvers.step import make_step

IMAGE_CONTRAST = 0.2
"""Standard deviation of a standardised pattern image around grey 0.5."""


def field_image(field: Array) -> Array:
    """A pattern as a standardised grey RGB image: ``(..., H, W)`` -> ``(..., H, W, 3)``,
    ``0.5 + IMAGE_CONTRAST * (f - mean f) / std f``."""
    mean = jnp.mean(field, axis=(-2, -1), keepdims=True)
    std = jnp.sqrt(jnp.mean((field - mean) ** 2, axis=(-2, -1), keepdims=True) + 1e-12)
    grey = 0.5 + IMAGE_CONTRAST * (field - mean) / (std + 1e-6)
    return jnp.repeat(grey[..., None], 3, axis=-1)


def target_field_image(path: str) -> np.ndarray:
    """A target image file as a standardised grey RGB image ``(S, S, 3)`` (luminance)."""
    from morphogen.learn.textures import load_texture

    rgb = load_texture(path)
    lum = rgb @ np.array([0.299, 0.587, 0.114], np.float32)
    return np.asarray(field_image(jnp.asarray(lum)))


def require_target(problem: Problem) -> None:
    """Refuse a problem without a target image: gradient fitting has nothing else to fit."""
    if problem.fitness != "target" or not problem.target:
        raise MorphogenError(
            "gradient fitting needs a target image: use --fitness target --target IMAGE"
        )


class GradientEvaluator:
    """``evaluate(genomes (P, G), key) -> (fitness (P,), metrics)`` with gradients.

    Uses the problem's model, grid, fixed parameters, initial condition, ``dt``, ``steps``,
    scheme and clamp (like :class:`~morphogen.search.evaluate.Evaluator`, from which it takes
    them); the fitness is ``-L`` with ``L`` the rotation-invariant texture loss of the final
    display species against ``problem.target``.

    ``metrics``: ``gradient`` ``(P, G)`` (zero where the loss is not finite), ``loss`` ``(P,)``,
    ``valid`` ``(P,)`` and ``fields`` (final display species, ``(P, H, W)``).

    Args:
        problem: a problem with ``fitness="target"`` and a 2D grid.
        features: texture descriptors (``random`` or ``spectrum``; ``vgg`` if available).
        n_rot: target orientations of the loss.
        chunk: steps per rematerialised chunk of the differentiable rollout.
    """

    def __init__(self, problem: Problem, *, features: str = "random", n_rot: int = 8,
                 chunk: int = 50):
        require_target(problem)
        if len(problem.size) != 2:
            raise MorphogenError("gradient fitting compares images: use a 2D grid (--size HxW)")
        self.base = Evaluator(replace(problem, fitness="dirichlet", target=None))
        # dt, steps and init as the run policy resolved them for the base evaluator
        self.problem = replace(self.base.problem, fitness=problem.fitness, target=problem.target)
        self.loss: TextureLoss = texture_loss(target_field_image(problem.target),
                                              make_extractor(features), n_rot)
        self._value_and_grad = self._compile(chunk)

    @property
    def genes(self) -> tuple[Gene, ...]:
        return self.problem.genes

    def __call__(self, genomes: Any, key: Any) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        genomes = np.asarray(genomes, np.float32)
        if genomes.ndim != 2 or genomes.shape[1] != len(self.genes):
            raise MorphogenError(
                f"genomes must have shape (P, {len(self.genes)}), got {genomes.shape}"
            )
        u0 = jnp.asarray(self.base.initial_states(genomes))
        params = {k: v for k, v in self.base.population_params(genomes).items()
                  if k not in {g.name for g in self.genes}}
        loss, grad, fields = self._value_and_grad(jnp.asarray(genomes), params, u0)
        loss = np.asarray(loss, np.float64)
        grad = np.asarray(grad, np.float64)
        fields = np.asarray(fields, np.float32)
        valid = np.isfinite(loss) & self.base.stable(genomes)
        valid &= np.all(np.isfinite(fields.reshape(len(genomes), -1)), axis=1)
        fitness = np.where(valid, -loss, np.nan).astype(np.float32)
        grad = np.where(valid[:, None] & np.isfinite(grad), -grad, 0.0).astype(np.float32)
        return fitness, {"gradient": grad, "loss": loss.astype(np.float32), "valid": valid,
                         "fields": fields}

    def _compile(self, chunk: int) -> Callable:
        base = self.base
        step = make_step(base.model, base.domain, scheme=base.scheme,
                         clamp=self.problem.clamp_bounds(base.model))
        names = [g.name for g in self.genes]
        display = self.base.display
        steps, dt = self.problem.steps, self.problem.dt

        def one_loss(genome, params, u0, loss):
            p = {**params, **{n: genome[i] for i, n in enumerate(names)}}
            u = rollout(step, u0, p, max_steps=steps, dt=dt, chunk=chunk)
            field = u[display]
            return loss(field_image(field)[None])[0], field

        def total(genomes, params, u0, loss):
            losses, fields = jax.vmap(one_loss, in_axes=(0, 0, 0, None))(genomes, params, u0,
                                                                          loss)
            return jnp.sum(losses), (losses, fields)

        grad_fn = jax.grad(total, has_aux=True)

        @jax.jit
        def run(genomes, params, u0, loss):
            grad, (losses, fields) = grad_fn(genomes, params, u0, loss)
            return losses, grad, fields

        return lambda genomes, params, u0: run(genomes, params, u0, self.loss)


class GradientInner(NamedTuple):
    """State of :class:`GradientAscent`: normalised genomes ``z`` ``(P, G)`` in ``[0, 1]``,
    Adam moments ``m``, ``v`` ``(P, G)``, step count ``t``, and the last gradient told,
    ``grad`` ``(P, G)`` in genome units. The moments are fields of their own (not an optax state
    pytree) so that a saved search state keeps its layout."""

    z: Array
    m: Array
    v: Array
    t: Array
    grad: Array


@dataclass(frozen=True)
class GradientAscent(Strategy):
    """Adam ascent on the fitness, one independent trajectory per population member.

    The step is :func:`optax.adam`'s (``eps = 1e-8`` added to the root of the second moment,
    ``eps_root = 0``), which is Kingma and Ba's update.

    Genes are normalised, ``z = (x - low) / (high - low)``, so ``learning_rate`` is a step in
    units of each gene's range; steps are clipped to the unit cube. ``ask`` returns the current
    points (no randomness after ``init``); ``tell`` needs ``gradient=d fitness / d genome``.

    Args:
        population_size: number of start points ``P``.
        learning_rate: Adam step size (fraction of the gene ranges).
        start: ``uniform`` (random start points in the bounds) or ``centre`` (the first at the
            centre of the box, the rest spread around it by the genes' ``sigma``).
        beta1, beta2: Adam's moment decay rates.
    """

    needs_gradient: ClassVar[bool] = True

    learning_rate: float = 0.02
    start: str = "uniform"
    beta1: float = 0.9
    beta2: float = 0.999

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.learning_rate > 0:
            raise MorphogenError(f"learning rate must be positive, got {self.learning_rate}")
        if self.start not in ("uniform", "centre"):
            raise MorphogenError(f"start must be uniform or centre, not {self.start!r}")

    def tell(self, genomes: Array, fitness: Array, state: State,
             gradient: Array | None = None) -> tuple[State, dict]:
        """As :meth:`Strategy.tell`, with ``gradient`` ``(P, G)``: ``d fitness / d genome``
        (``metrics["gradient"]`` of a :class:`GradientEvaluator`)."""
        if gradient is None:
            raise MorphogenError(
                "the gradient strategy needs the fitness gradient: evaluate with a "
                "GradientEvaluator and pass gradient=metrics['gradient']"
            )
        gradient = jnp.asarray(gradient, jnp.float32)
        if gradient.shape != state.inner.z.shape:
            raise MorphogenError(
                f"gradient has shape {gradient.shape}, expected {state.inner.z.shape}"
            )
        state = state._replace(inner=state.inner._replace(grad=gradient))
        return super().tell(genomes, fitness, state)

    def _init(self, key: Array, low: Array, high: Array, sigma: Array) -> GradientInner:
        shape = (self.population_size, low.shape[0])
        if self.start == "uniform":
            z = jax.random.uniform(key, shape)
        else:
            spread = (sigma / (high - low)) * jax.random.normal(key, shape)
            z = jnp.clip(0.5 + spread.at[0].set(0.0), 0.0, 1.0)
        zeros = jnp.zeros(shape, jnp.float32)
        return GradientInner(z=z, m=zeros, v=zeros, t=jnp.asarray(0, jnp.int32), grad=zeros)

    def _ask(self, key: Array, state: State) -> tuple[Array, GradientInner]:
        inner = state.inner
        return state.low + inner.z * (state.high - state.low), inner

    def _tell(self, genomes: Array, fitness: Array, state: State) -> GradientInner:
        inner = state.inner
        g = inner.grad * (state.high - state.low)  # d fitness / d z
        g = jnp.where(jnp.isfinite(fitness)[:, None], g, 0.0)
        adam = optax.adam(self.learning_rate, b1=self.beta1, b2=self.beta2, eps=1e-8)
        moments = optax.ScaleByAdamState(count=inner.t, mu=inner.m, nu=inner.v)
        step, (moments, _) = adam.update(g, (moments, optax.EmptyState()))
        # optax descends: its step for the fitness gradient points down, so it is subtracted.
        z = jnp.clip(inner.z - step, 0.0, 1.0)
        return GradientInner(z=z, m=moments.mu, v=moments.nu, t=moments.count, grad=inner.grad)


class FitResult(NamedTuple):
    """Outcome of :func:`fit`: the best genome and fitness, the final state, and per
    iteration the population's genomes ``(I, P, G)`` and fitness ``(I, P)``."""

    best_genome: np.ndarray
    best_fitness: float
    state: State
    genomes: np.ndarray
    fitness: np.ndarray


def fit(
    evaluate: GradientEvaluator,
    strategy: GradientAscent,
    genes: Sequence[Gene],
    *,
    iterations: int,
    seed: int = 0,
    callback: Callable[[int, np.ndarray, np.ndarray], None] | None = None,
) -> FitResult:
    """Run ``iterations`` ask/evaluate/tell rounds; ``callback(i, genomes, fitness)`` after each."""
    key = jax.random.PRNGKey(seed)
    state = strategy.init(key, list(genes))
    history_g, history_f = [], []
    for i in range(iterations):
        genomes, state = strategy.ask(jax.random.fold_in(key, i), state)
        genomes = np.asarray(genomes)
        fitness, metrics = evaluate(genomes, key)
        state, _ = strategy.tell(genomes, fitness, state, gradient=metrics["gradient"])
        history_g.append(genomes)
        history_f.append(fitness)
        if callback is not None:
            callback(i, genomes, fitness)
    return FitResult(
        best_genome=np.asarray(state.best_genome),
        best_fitness=float(state.best_fitness),
        state=state,
        genomes=np.stack(history_g) if history_g else np.zeros((0, 0, len(genes))),
        fitness=np.stack(history_f) if history_f else np.zeros((0, 0)),
    )
