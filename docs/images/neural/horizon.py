"""Measure how well trained neural RD rules hold their texture over a long horizon.

    python docs/images/neural/horizon.py TEXTURE=RULE [TEXTURE=RULE ...]

``RULE`` is a model file (``.npz``) or a shipped rule (``neural:NAME``); ``TEXTURE`` names the
synthetic target it is judged against (:func:`morphogen.learn.textures.synthetic_texture`,
drawn at 64 x 64). Four fresh seeds are grown on a 48 x 48 torus and the random-feature texture
loss of the cpu preset (best of 36 orientations, so another orientation of the texture scores
like the texture) is printed after 1 000, 2 000, 5 000 and 10 000 steps, with the loss of two
reference images: the target itself turned by 45 degrees (a perfect texture in another
orientation, the floor) and the disordered ``labyrinth`` texture (what a drifting stripe rule
becomes). The output is a Markdown table row per rule.
"""

from __future__ import annotations

import sys
import time

import jax
import jax.numpy as jnp
import numpy as np
from scipy import ndimage

from morphogen.domains.grid import Grid
from morphogen.learn.rollout import rollout
from morphogen.learn.seeds import seed_batch
from morphogen.learn.session import build_loss
from morphogen.learn.textures import state_to_rgb, synthetic_texture
from morphogen.learn.train import preset
from morphogen.models.registry import load_model
from morphogen.solvers.step import make_step

CHECKPOINTS = (1000, 2000, 5000, 10000)
SIZE = 48
SEEDS = 4
CHUNK = 500


def losses(texture: str, rule: str) -> tuple[list[float], float, float]:
    """Mean loss of the grown seeds at each checkpoint, and of the two reference images."""
    target = synthetic_texture(texture, 64)
    loss = build_loss(preset("cpu"), target)
    model = load_model(rule)
    step = make_step(model, Grid((SIZE, SIZE), boundary="periodic", stencil=9))
    p = dict(model.params)
    advance = jax.jit(jax.vmap(lambda u: rollout(step, u, p, max_steps=CHUNK, chunk=CHUNK)))
    x = seed_batch(jax.random.PRNGKey(123), SEEDS, len(model.species), (SIZE, SIZE))
    out, done = [], 0
    for n in CHECKPOINTS:
        while done < n:
            x = advance(x)
            done += CHUNK
        out.append(float(jnp.mean(loss(state_to_rgb(x)))))
    turned = ndimage.rotate(np.tile(target, (2, 2, 1)), 45, reshape=False, order=1)[32:96, 32:96]
    refs = [np.clip(turned, 0, 1), synthetic_texture("labyrinth", 64)]
    ref = np.asarray(loss(jnp.asarray(np.stack(refs))))
    return out, float(ref[0]), float(ref[1])


def main(pairs: list[str]) -> None:
    head = " | ".join(f"{n} steps" for n in CHECKPOINTS)
    print(f"| texture | rule | {head} | target at 45 deg | labyrinth |")
    print("|" + "---|" * (len(CHECKPOINTS) + 4))
    for pair in pairs:
        texture, _, rule = pair.partition("=")
        start = time.perf_counter()
        values, turned, maze = losses(texture, rule)
        cells = " | ".join(f"{v:.3g}" for v in values)
        print(f"| {texture} | {rule} | {cells} | {turned:.3g} | {maze:.3g} |", flush=True)
        print(f"<!-- {time.perf_counter() - start:.0f} s -->", file=sys.stderr)


if __name__ == "__main__":
    main(sys.argv[1:])
