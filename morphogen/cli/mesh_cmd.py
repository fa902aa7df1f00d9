"""``morphogen mesh``: generate flower meshes, grow veins on them and describe mesh files."""

from __future__ import annotations

import argparse
from pathlib import Path

from morphogen.cli import options
from morphogen.errors import MorphogenError


def _floats(text: str) -> list[float]:
    try:
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        message = f"expected numbers separated by commas, got {text!r}"
        raise argparse.ArgumentTypeError(message) from None


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("mesh", help="generate flower meshes (PLY) and describe mesh files",
                       description="Procedural flower meshes with near-equilateral triangles, "
                       "per-vertex fields and named vertex sets (margin, base, throat, midline).")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    make = actions.add_parser("make", help="write a generated shape to a PLY file")
    make.add_argument("shape", choices=("petal", "corolla", "tube"))
    make.add_argument("--out", required=True, metavar="FILE.ply", help="output PLY file")
    make.add_argument("--edge", type=float, default=0.02, help="mean edge length (default 0.02)")
    make.add_argument("--scale", type=float, default=1.0, help="uniform scale of the result")
    make.add_argument("--petals", type=int, help="corolla: number of petals (default 5)")
    make.add_argument("--lobes", type=int, help="tube: number of lobes (default 5)")
    make.add_argument("--lobe-scales", type=_floats, metavar="A,B,...",
                      help="tube: relative lobe sizes, e.g. 0.75,0.75,1.1,1.3,1.1")
    make.add_argument("--length", type=float, help="petal or tube length")
    make.add_argument("--width", type=float, help="petal width")
    make.add_argument("--radius", type=float, help="corolla radius or tube base radius")
    make.add_argument("--eye", type=float, help="corolla: central hole, fraction of the radius")
    make.add_argument("--notch", type=float, help="depth of the notch at each tip")
    make.add_argument("--teeth", type=int, help="corolla: teeth per petal (Dianthus)")
    make.add_argument("--fringe", type=float, help="corolla: depth of the teeth")
    make.add_argument("--png", action="store_true", help="also write FILE.png, a rendered view")
    make.set_defaults(func=run_make)
    veins = actions.add_parser(
        "veins", help="grow veins on a mesh by space colonisation (Ringham et al. 3.4.1)",
        description="Writes OUT.ply with the per-vertex fields vein (1 on veins), "
        "vein_thickness and vein_distance (path length over mesh edges to the nearest vein, "
        "mesh units), and the vein graph as OUT.veins.npz. Lengths default to multiples of "
        "the mean edge e: step 2e, kill 3 step, influence 15 step.")
    veins.add_argument("file", metavar="MESH.ply")
    veins.add_argument("--out", required=True, metavar="OUT.ply", help="output PLY file")
    veins.add_argument("--seeds", required=True, metavar="SET",
                       help="where veins start: a vertex set (e.g. base) or an expression")
    veins.add_argument("--points", type=int, default=2000, help="attraction points (2000)")
    veins.add_argument("--influence", type=float, help="influence radius (mesh units)")
    veins.add_argument("--kill", type=float, help="kill distance (mesh units)")
    veins.add_argument("--step", type=float, help="growth step (mesh units)")
    veins.add_argument("--iterations", type=int, default=400, help="most growth steps (400)")
    veins.add_argument("--density", metavar="EXPR",
                       help="acceptance probability of attraction points, from fields")
    veins.add_argument("--seed", type=options.seed, default=0, help="random seed (0)")
    veins.add_argument("--cmap", default="#f4f1fb,#7b68c8",
                       help="colour map of vein_distance under the veins")
    veins.add_argument("--view", default="oblique", help="view of the --png picture")
    veins.add_argument("--png", action="store_true", help="also write OUT.png, a rendered view")
    veins.set_defaults(func=run_veins)
    info = actions.add_parser("info", help="describe a PLY mesh: size, edges, fields, sets")
    info.add_argument("file", metavar="FILE.ply")
    info.set_defaults(func=run_info)


def run_make(args: argparse.Namespace) -> int:
    from morphogen import flowers
    from morphogen.mesh_io import save_ply

    if not args.out.lower().endswith(".ply"):
        raise MorphogenError(f"--out must name a .ply file, got {args.out}")
    names = {"petal": ("length", "width", "notch"),
             "corolla": ("petals", "radius", "eye", "notch", "teeth", "fringe"),
             "tube": ("lobes", "length", "radius", "notch", "lobe_scales")}[args.shape]
    given = {k: v for k, v in vars(args).items()
             if k in {"petals", "lobes", "lobe_scales", "length", "width", "radius", "eye",
                      "notch", "teeth", "fringe"} and v is not None}
    unused = sorted(set(given) - set(names))
    if unused:
        flags = ", ".join("--" + k.replace("_", "-") for k in unused)
        raise MorphogenError(f"{flags} do(es) not apply to a {args.shape}")
    mesh = getattr(flowers, args.shape)(edge=args.edge / args.scale, **given)
    if args.scale != 1.0:
        if not args.scale > 0:
            raise MorphogenError(f"--scale must be positive, got {args.scale}")
        mesh = mesh.replace(vertices=mesh.vertices * args.scale)
    path = save_ply(args.out, mesh)
    if args.png:
        from morphogen.render.colour import colourise
        from morphogen.render.images import write_png
        from morphogen.render.mesh import render_mesh

        key = "r" if "r" in mesh.fields else "s"
        image = render_mesh(mesh.vertices, mesh.faces, colourise(mesh.fields[key], "viridis"))
        write_png(Path(args.out).with_suffix(".png"), image)
    print(f"wrote {path} ({mesh.n_vertices} vertices, {mesh.n_faces} triangles, "
          f"mean edge {mesh.edge_length:.4g}; fields: {', '.join(mesh.fields)})")
    return 0


def run_info(args: argparse.Namespace) -> int:
    from morphogen.mesh_io import load_mesh

    mesh = load_mesh(args.file)
    print(f"{args.file}: {mesh.n_vertices} vertices, {mesh.n_faces} triangles")
    print(f"mean edge {mesh.edge_length:.4g}, area {mesh.areas.sum():.4g}, "
          f"{len(mesh.boundary_vertices)} boundary vertices")
    print(f"largest stable Euler dt for D = 1: {2.0 / mesh.spectral_radius():.4g}")
    for name, values in mesh.fields.items():
        count = int((values > 0.5).sum())
        print(f"  field {name}: min {values.min():.4g}, max {values.max():.4g}, "
              f"{count} vertices > 0.5")
    return 0


def run_veins(args: argparse.Namespace) -> int:
    from morphogen.io import write_npz
    from morphogen.mesh_io import load_mesh, save_ply
    from morphogen.pipeline import grow_veins
    from morphogen.render.colour import colourise
    from morphogen.render.mesh import overlay_veins, parse_view

    out = Path(args.out)
    if out.suffix.lower() != ".ply":
        raise MorphogenError(f"--out must name a .ply file, got {args.out}")
    parse_view(args.view)
    mesh = load_mesh(args.file)
    stage = {k: getattr(args, k) for k in ("seeds", "points", "influence", "kill", "step",
                                            "iterations", "density", "seed")
             if getattr(args, k) is not None}
    graph, fields = grow_veins(stage, mesh)
    colours = overlay_veins(colourise(fields["vein_distance"], args.cmap), fields["vein"],
                            fields["vein_thickness"])
    image = None
    if args.png:
        from morphogen.render.mesh import render_mesh

        image = render_mesh(mesh.vertices, mesh.faces, colours, view=args.view)
    graph_path = out.with_suffix(".veins.npz")
    write_npz(graph_path, graph.arrays())
    path = save_ply(out, mesh.with_fields(**fields), colours=colours)
    if image is not None:
        from morphogen.render.images import write_png

        write_png(out.with_suffix(".png"), image)
    print(f"wrote {path} and {graph_path}: {len(graph.nodes)} vein nodes from "
          f"{len(graph.seeds)} seeds, Strahler order up to {int(graph.order.max())}, "
          f"{int(fields['vein'].sum())} of {mesh.n_vertices} vertices on veins, "
          f"{len(graph.remaining)} attraction points unreached")
    return 0
