"""``morphogen analyse``: the Turing analysis of a model (:func:`morphogen.runs.analysis.analyse`)
as ``analysis.json`` and a dispersion-relation picture."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "analyse",
        help="Turing analysis: fixed points, dispersion relation, unstable band, wavelength",
        description="Linear stability of a model's homogeneous states (Murray, Mathematical "
        "Biology II, ch. 2). Every homogeneous fixed point is found (multi-start Newton, plain "
        "and in log-concentrations, deduplicated), with its Jacobian eigenvalues, its class "
        "(turing, stable, unstable_k0, marginal), the unstable band and the fastest-growing "
        "wavelength on the chosen grid (its stencil's discrete Laplacian) and in continuous "
        "space. MODEL is a library name, a model file (.toml), an Antimony/SBML network "
        "(.ant/.xml), or a run file (.json: a `morphogen networks` run's best/best_1.json or "
        "any run.json; its grid is the default). Writes analysis.json and dispersion.png "
        "into DIR.",
    )
    p.add_argument("model", metavar="MODEL",
                   help="library name, .toml/.ant/.xml model file, or run .json")
    p.add_argument("-p", "--param", action="append", metavar="NAME=VALUE",
                   help="set a parameter (repeatable); numbers only")
    p.add_argument("--preset", help="start from one of the model's presets")
    p.add_argument("--size", metavar="N|NxM", help="grid cells per side (default 128, or the "
                   "run file's grid)")
    p.add_argument("--dx", type=float, metavar="H",
                   help="cell spacing (default 1, or the run file's)")
    p.add_argument("--stencil", choices=("5", "7", "9", "spectral"),
                   help="Laplacian whose symbol gives the grid's modes (default: the grid's)")
    p.add_argument("--boundary", choices=("periodic", "neumann"), default="periodic",
                   help="periodic (Fourier modes) or neumann (no-flux: cosine modes)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write")
    p.set_defaults(func=run)


def _model_and_grid(text: str) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """The model, the run file's parameters (if any) and grid settings (size, dx)."""
    if text.lower().endswith(".json"):
        from morphogen.models.registry import load_model
        from morphogen.models.text.equations import parse_model
        from morphogen.runs.config import load_run_file

        config = load_run_file(text)
        if config.model_source is not None:
            model = parse_model(config.model_source, path=config.model)
        else:
            model = load_model(config.model)
        grid = {"size": list(config.size), "dx": float(config.dx)}
        return model, dict(config.params or {}), grid
    from morphogen.models.registry import load_model

    return load_model(text), {}, {}


def _size(text: str | None, default: Any) -> tuple[int, ...]:
    from morphogen.cli.options import size
    from morphogen.errors import MorphogenError

    if text is None:
        return tuple(default) if default is not None else (128, 128)
    if text.strip().isdigit():
        n = int(text)
        if n < 3:
            raise MorphogenError(f"--size {text!r}: give at least 3 cells")
        return (n, n)
    return tuple(size(text))


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from morphogen.cli.options import assignments
    from morphogen.errors import MorphogenError
    from morphogen.render.dispersion import dispersion_png
    from morphogen.runs.analysis import analyse
    from morphogen.util.io import check_run_dir, staged_dir

    check_run_dir(args.out)
    model, run_params, grid = _model_and_grid(args.model)
    given = assignments(args.param)
    for name, value in given.items():
        if isinstance(value, str) or np.ndim(value):
            raise MorphogenError(f"-p {name}={value}: the analysis takes numbers only (a "
                                 "homogeneous state has spatially constant parameters)")
    params = model.parameters({**run_params, **given}, preset=args.preset)
    dx = grid.get("dx", 1.0) if args.dx is None else args.dx
    if not (np.isfinite(dx) and dx > 0):
        raise MorphogenError(f"--dx {args.dx}: give a positive number")
    shape = _size(args.size, grid.get("size"))
    stencil = None if args.stencil is None else (
        args.stencil if args.stencil == "spectral" else int(args.stencil))
    result = analyse(model, params, size=shape, dx=dx, stencil=stencil, boundary=args.boundary)
    with staged_dir(args.out) as stage:
        (stage / "analysis.json").write_text(result.to_json(curves=True))
        _picture(result, stage / "dispersion.png", dispersion_png)
    for line in summary(result):
        print(line)
    print(f"wrote {args.out}/analysis.json and dispersion.png")
    return 0


def _picture(result: Any, path: Path, draw: Any) -> None:
    import numpy as np

    labels, fastest, bands = [], [], []
    for f in result.fixed_points:
        state = ", ".join(f"{x:.4g}" for x in f.state)
        labels.append(f"u* = ({state}): {f.cls}")
        g = f.grid_fastest
        grows = f.grid_band is not None and f.cls == "turing"
        fastest.append((2 * np.pi / g.wavelength, g.growth, g.wavelength) if grows else None)
        bands.append(tuple(float(np.sqrt(k)) for k in f.band.kappa2)
                     if f.band is not None and f.cls == "turing" else None)
    c = result.curves
    shape = "x".join(str(n) for n in result.grid["shape"])
    draw(path, c["q"], c["sigma"], c["grid_q"], c["grid_sigma"], labels, fastest, bands,
         title=f"{result.model}: dispersion relation on {shape}, dx = {result.grid['dx']:g}")


def summary(result: Any) -> list[str]:
    """A few lines: one per fixed point with its class, band and fastest wavelength."""
    lines = [f"{result.model}: {len(result.fixed_points)} homogeneous fixed point(s) on a "
             f"{'x'.join(map(str, result.grid['shape']))} grid, dx = {result.grid['dx']:g}"]
    for f in result.fixed_points:
        state = ", ".join(f"{n}={x:.5g}" for n, x in zip(result.species, f.state, strict=True))
        line = f"  {state}: {f.cls}, sigma(0) = {f.growth0:.3g}"
        if f.cls == "unstable_k0":
            line += " (oscillatory: Hopf side)" if f.oscillatory else " (saddle)"
        if f.grid_band is not None and f.cls == "turing":
            g, b = f.grid_fastest, f.grid_band
            line += (f"; unstable wavelengths {b.wavelength[0]:.4g}-{b.wavelength[1]:.4g} "
                     f"({b.modes} grid modes), fastest {g.wavelength:.4g} "
                     f"({g.wavelength_cells:.4g} cells, mode {tuple(g.mode)}, growth "
                     f"{g.growth:.3g}); continuous {f.fastest.wavelength:.4g}")
        lines.append(line)
    return lines
