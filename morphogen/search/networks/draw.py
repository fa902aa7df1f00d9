"""Pictures of reaction networks in the style of Yamamoto et al. Fig. 7.

"A dot indicates a reaction, continuous lines indicate educts, continuous arrows indicate
products, dotted arrows indicate catalysis, and numbers indicate stoichiometric coefficients"
(Yamamoto et al. §4.2, Fig. 7). Here a species is a **catalyst** of a reaction when it stands on
both sides with the same coefficient (``C`` in ``2A + C → 3A + C``); a species on both sides
with different coefficients (``A`` there) gets an educt line and a product arrow, which shows
autocatalysis as a loop. Coefficients of 1 are not written, as in chemical equations.

The graph is a :mod:`networkx` bipartite digraph (species and reaction nodes); the layout is
networkx's Kamada-Kawai layout of each connected part (deterministic), drawn with matplotlib's
Agg/SVG back ends.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np

from morphogen.models.network import ReactionNetwork
from morphogen.util.extras import require

SPECIES_SIZE = 1400
REACTION_SIZE = 90
CURVE = "arc3,rad=0.15"


def reaction_graph(net: ReactionNetwork, reactions: Sequence[int] | None = None):
    """The bipartite graph of ``net`` (a ``networkx.DiGraph``).

    Nodes ``("species", name)`` and ``("reaction", id)`` (attribute ``kind``; reactions also
    ``rate`` and ``label``). Edges carry ``kind`` (``educt`` species → reaction, ``product``
    reaction → species, ``catalyst`` species → reaction) and ``coefficient``. ``reactions``
    selects reaction indices (default all); species are those the selected reactions touch,
    or all species when none is selected.
    """
    nx = require("networkx", "networks", "drawing a network")

    me, mp = np.asarray(net.educts), np.asarray(net.products)
    chosen = range(len(net.reaction_ids)) if reactions is None else reactions
    g = nx.DiGraph()
    for j in chosen:
        r = ("reaction", net.reaction_ids[j])
        g.add_node(r, kind="reaction", rate=float(net.rates[j]),
                   label=f"{net.rate_names[j]}={net.rates[j]:.2g}")
        for i, s in enumerate(net.species):
            e, p, node = int(me[i, j]), int(mp[i, j]), ("species", s)
            if e or p:
                g.add_node(node, kind="species", label=s)
            if e and e == p:
                g.add_edge(node, r, kind="catalyst", coefficient=e)
                continue
            if e:
                g.add_edge(node, r, kind="educt", coefficient=e)
            if p:
                g.add_edge(r, node, kind="product", coefficient=p)
    if not len(g):
        g.add_nodes_from((("species", s), {"kind": "species", "label": s}) for s in net.species)
    return g


def draw_network(net: ReactionNetwork, fmt: str = "png",
                 reactions: Sequence[int] | None = None, title: str | None = None) -> bytes:
    """PNG or SVG bytes of :func:`reaction_graph` (see the module docstring for the legend)."""
    nx = require("networkx", "networks", "drawing a network")
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    g = reaction_graph(net, reactions)
    pos = _layout(g)
    nodes = list(g)
    species = [v for v in nodes if g.nodes[v]["kind"] == "species"]
    rxns = [v for v in nodes if g.nodes[v]["kind"] == "reaction"]
    sizes = [SPECIES_SIZE if g.nodes[v]["kind"] == "species" else REACTION_SIZE for v in nodes]
    fig = Figure(figsize=(6.4, 6.4), dpi=120)
    ax = fig.add_subplot()
    colours = {s: f"C{i}" for i, s in enumerate(net.species)}
    discs = nx.draw_networkx_nodes(g, pos, nodelist=species, node_size=SPECIES_SIZE, ax=ax,
                                   node_color=[colours[v[1]] for v in species])
    dots = nx.draw_networkx_nodes(g, pos, nodelist=rxns, node_size=REACTION_SIZE,
                                  node_color="black", ax=ax)
    for collection in (discs, dots):
        collection.set_zorder(3)  # above the edges
    names = nx.draw_networkx_labels(g, pos, labels={v: g.nodes[v]["label"] for v in species},
                                    ax=ax, font_size=15, font_weight="bold", font_color="white")
    for text in names.values():
        text.set_zorder(4)
    offset = _outward(pos, rxns, 0.11)
    rates = nx.draw_networkx_labels(g, offset, labels={v: g.nodes[v]["label"] for v in rxns},
                                    ax=ax, font_size=8, font_color="0.2",
                                    bbox={"boxstyle": "round,pad=0.1", "fc": "white",
                                          "ec": "none", "alpha": 0.8})
    for text in rates.values():
        text.set_zorder(0.5)  # below the edges, so arrowheads stay visible
    styles = {"educt": ("solid", "-"), "product": ("solid", "-|>"), "catalyst": ("dotted", "-|>")}
    for kind, (style, arrow) in styles.items():
        edges = [(a, b) for a, b, k in g.edges(data="kind") if k == kind]
        if edges:
            nx.draw_networkx_edges(g, pos, edgelist=edges, nodelist=nodes, node_size=sizes,
                                   style=style, arrowstyle=arrow, arrowsize=16, width=1.4,
                                   connectionstyle=CURVE, ax=ax, arrows=True)
    numbers = {(a, b): str(c) for a, b, c in g.edges(data="coefficient") if c > 1}
    if numbers:
        nx.draw_networkx_edge_labels(g, pos, edge_labels=numbers, connectionstyle=CURVE, ax=ax,
                                     font_size=11, font_weight="bold", rotate=False,
                                     bbox={"boxstyle": "round,pad=0.15", "fc": "white",
                                           "ec": "none"})
    legend = [Line2D([], [], color="black", lw=1.4, label="educt"),
              Line2D([], [], color="black", lw=1.4, marker=">", label="product"),
              Line2D([], [], color="black", lw=1.4, ls=":", marker=">", label="catalyst"),
              Line2D([], [], color="black", lw=0, marker="o", ms=5, label="reaction")]
    fig.legend(handles=legend, loc="lower center", ncol=4, fontsize=9, frameon=False)
    ax.set_title(title if title is not None else net.name, fontsize=11)
    ax.margins(0.15)
    ax.set_axis_off()
    buf = io.BytesIO()
    metadata = {"Date": None} if fmt == "svg" else None
    fig.savefig(buf, format=fmt, bbox_inches="tight", metadata=metadata)
    return buf.getvalue()


def _layout(g) -> dict:
    """Kamada-Kawai positions of the undirected graph per connected part, the parts side by
    side (largest first). On the directed graph, or across parts, path lengths are undefined
    for most pairs and the layout can put two nodes on one spot."""
    nx = require("networkx", "networks", "drawing a network")

    parts = sorted(nx.weakly_connected_components(g), key=lambda c: (-len(c), sorted(map(str, c))))
    pos, x = {}, 0.0
    for part in parts:
        sub = g.subgraph(part).to_undirected()
        local = nx.kamada_kawai_layout(sub) if len(sub) > 2 else nx.circular_layout(sub)
        xy = np.array([local[v] for v in sub]) * (np.sqrt(len(sub)) / 2)
        width = np.ptp(xy[:, 0]) if len(sub) > 1 else 0.0
        shift = x - xy[:, 0].min()
        for v, p in zip(sub, xy, strict=True):
            pos[v] = np.array([p[0] + shift, p[1]])
        x += width + 0.8
    return pos


def _outward(pos: dict, nodes: list, distance: float) -> dict:
    """Label positions ``distance`` from each node, away from the drawing's centre."""
    centre = np.mean(np.array(list(pos.values())), axis=0)
    out = {}
    for v in nodes:
        d = np.asarray(pos[v]) - centre
        norm = np.linalg.norm(d)
        out[v] = tuple(pos[v] + (d / norm if norm > 1e-9 else np.array([0.0, -1.0])) * distance)
    return out
