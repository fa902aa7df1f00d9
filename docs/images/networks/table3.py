"""Do the two evolved networks of Yamamoto et al.'s Table 3 form spots at Δt = 0.1?

    python docs/images/networks/table3.py

Table 3 lists the evolvable reactions only; the rates of the static slots (inflow of C, decay
of A, B and C; inflow of A and B is imposed at 0, §4.2) are not given. Every combination of
:data:`RHO_C`, :data:`MU_A`, :data:`MU_B`, :data:`MU_C` (the hand-made network's values, §2.1,
and ten times and a tenth of them) is evaluated with the Table-1 evaluation (32², Δt = 0.1,
10 rounds from t = 2000 every 200) from both initial conditions (``steady``: the well-mixed
state times 1 ± 10 %; ``uniform`` in ``[0, 2)``) on :data:`DRAWS` initial draws. Writes
``table3.json`` (fitness of every setting) and ``pattern_table3_top.png`` /
``pattern_table3_bottom.png`` (A/B/C at t = 3800 of the fittest setting from the steady start,
or of the hand-made statics when none has a pattern) and ``network_table3_top.png`` /
``network_table3_bottom.png`` (Fig. 7-style drawings; the two rate-0 reactions of the bottom
network change nothing and are left out, as in the exported model files).
"""

from __future__ import annotations

import itertools
import json
from pathlib import Path

import jax
import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from morphogen.search.networks.cluster import peaks  # noqa: E402
from morphogen.search.networks.draw import draw_network  # noqa: E402
from morphogen.search.networks.evolve import Evaluation, evaluate, initial_state  # noqa: E402
from morphogen.search.networks.export import genome_network  # noqa: E402
from morphogen.search.networks.genome import NetworkSpec, make_genome, stack  # noqa: E402

HERE = Path(__file__).parent
SPEC = NetworkSpec(("A", "B", "C"), 12, (0.005, 0.2, 0.0), fixed=(0, 1), fixed_rates=(0.0, 0.0))
RHO_C = (0.01, 0.1, 1.0)
MU_A = (0.001, 0.01, 0.1)
MU_B = (0.002, 0.02, 0.2)
MU_C = (0.0, 0.01)
DRAWS = 2
#                 educts (A, B, C)  products (A, B, C)  k
TABLE3 = {
    "top": [((1, 0, 1), (2, 1, 0), 6.2), ((2, 0, 0), (1, 0, 2), 6.4e-2),
            ((2, 1, 1), (0, 1, 1), 2.3e-2), ((1, 1, 1), (0, 0, 0), 1.0e-1),
            ((1, 1, 0), (0, 0, 0), 2.0e-2), ((0, 1, 2), (1, 1, 2), 1.0)],
    "bottom": [((1, 2, 1), (1, 1, 0), 5.0e-3), ((0, 0, 2), (0, 1, 1), 0.0),
               ((0, 1, 2), (1, 0, 1), 0.0), ((0, 2, 0), (1, 1, 1), 1.0),
               ((0, 1, 2), (1, 2, 1), 1.0), ((2, 1, 0), (2, 0, 1), 2.0e-1)],
}


def genome(name: str, rho_c: float, mu_a: float, mu_b: float, mu_c: float):
    rows = TABLE3[name]
    me = np.array([r[0] for r in rows]).T
    mp = np.array([r[1] for r in rows]).T
    k = [0.0, 0.0, rho_c, mu_a, mu_b, mu_c] + [r[2] for r in rows]
    return make_genome(SPEC, k, me, mp)


def pattern_figure(state: np.ndarray, title: str, path: Path) -> None:
    fig = Figure(figsize=(9.6, 3.2), dpi=120)
    for i, species in enumerate(SPEC.species):
        ax = fig.add_subplot(1, 3, i + 1)
        im = ax.imshow(state[i], cmap="viridis", interpolation="nearest")
        fig.colorbar(im, ax=ax, shrink=0.8)
        ax.set_title(species)
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path)


def scan(name: str, ev: Evaluation, settings: list) -> tuple[dict, np.ndarray, np.ndarray]:
    """Fitness of every static setting over the draws, and the first draw's final states."""
    pop = stack([genome(name, *s) for s in settings])
    fits, finals = [], None
    for draw in range(DRAWS):
        f, states = evaluate(pop, initial_state(jax.random.key(draw), SPEC, ev), SPEC, ev)
        fits.append(f)
        finals = states if finals is None else finals
    fits = np.asarray(fits)
    rows = []
    for s, f, st in zip(settings, fits.T, finals, strict=True):
        n_peaks = int(np.asarray(peaks(st[0], prominence=0.5)).sum()) if f[0] > -1 else 0
        rows.append({"static": list(s), "fitness": [round(float(x), 2) for x in f],
                     "peaks_first_draw": n_peaks})
    mean = fits.mean(0)
    best = int(np.argmax(mean))
    summary = {"valid_settings": int((fits > -1).all(0).sum()),
               "flat_settings": int((fits == 0).all(0).sum()),
               "spot_settings": int(sum(r["peaks_first_draw"] > 0 for r in rows)),
               "of": len(settings), "best": rows[best], "settings": rows}
    return summary, fits, finals


def drawing(name: str) -> None:
    """Fig. 7-style drawing of the network's evolvable reactions with a non-zero rate."""
    net = genome_network(genome(name, 0.1, 0.01, 0.02, 0.0), SPEC, name=f"table3-{name}")
    keep = [j for j, r in enumerate(net.reaction_ids) if not r.startswith(("inflow_", "decay_"))]
    assert len(keep) == sum(r[2] > 0 for r in TABLE3[name])
    png = draw_network(net, "png", reactions=keep, title=f"Table 3 ({name})")
    (HERE / f"network_table3_{name}.png").write_bytes(png)


def main() -> None:
    for name in TABLE3:
        drawing(name)
    settings = list(itertools.product(RHO_C, MU_A, MU_B, MU_C))
    out: dict = {"evaluation": {"size": 32, "dt": 0.1, "t_start": 2000.0, "interval": 200.0,
                                "rounds": 10, "init_noise": 0.1, "draws": DRAWS},
                 "static_rates": ["rho_C", "mu_A", "mu_B", "mu_C"]}
    for name in TABLE3:
        out[name] = {}
        for init in ("steady", "uniform"):
            summary, fits, finals = scan(name, Evaluation(init=init), settings)
            out[name][init] = summary
            print(name, init, {k: v for k, v in summary.items() if k != "settings"},
                  flush=True)
            if init == "steady":
                mean = fits.mean(0)
                best = int(np.argmax(mean))
                shown = best if mean[best] > 0 else settings.index((0.1, 0.01, 0.02, 0.0))
                pattern_figure(finals[shown], f"Table 3 ({name}), ρ_C, μ_A, μ_B, μ_C = "
                               f"{', '.join(f'{x:g}' for x in settings[shown])}: t = 3800, "
                               f"fitness {fits[0, shown]:.1f} of 1024",
                               HERE / f"pattern_table3_{name}.png")
    (HERE / "table3.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
