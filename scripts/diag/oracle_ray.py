"""Diagnostic: what lies between a run's recommendation and the nominal oracle gains (E[P] 0.965)?

For each nominal-plant record of the plant sweeps' stores (``--sweeps``; one method, one mode), the straight segment
from the recommendation to the oracle in the optimiser's unit cube is flown at 51 points on the plant's 8 fixed
initial conditions, strict (the plant's own score, no monitor). Printed per seed: the best E[P] on the segment
before its first drop (a point more than 0.1 below the recommendation: some start fails there), how far from the
recommendation it lies and where the drop is. ``--plot`` draws the segments.

    python scripts/diag/oracle_ray.py --method ksbo --mode monitor --plot docs/figures/plants_oracle_ray.png
"""

from __future__ import annotations

import argparse

import numpy as np

from ksbo_bench import sweep as sweeps
from ksbo_bench.report.plants import ORACLE, flat
from ksbo_bench.store import Store

DROP = 0.1


def segments(recs: list[dict], points: int = 51) -> list[dict]:
    """Per record: the segment's distances (points,), E[P] (points,), and the best value before the first drop."""
    from ksbo_mav.simulated.planar_objective import SimObjective

    obj = SimObjective(plant="nominal", monitor=False)
    uo = obj.profile.to_unit(ORACLE)
    ts = np.linspace(0.0, 1.0, points)
    out = []
    for r in recs:
        u = obj.profile.to_unit(np.asarray(r["x"], dtype=float))
        P, _ = obj.expected_outcomes(np.array([obj.profile.from_unit(u + (uo - u) * t) for t in ts]))
        dist = ts * float(np.linalg.norm(uo - u))
        bad = np.nonzero(P < P[0] - DROP)[0]
        cliff = int(bad[0]) if bad.size else points
        i = int(np.argmax(P[:cliff]))
        out.append({"seed": r["seed"], "dist": dist, "P": P, "best": float(P[i]), "at": float(dist[i]),
                    "drop_at": float(dist[cliff]) if cliff < points else None})
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--method", default="ksbo")
    ap.add_argument("--mode", default="monitor", choices=("monitor", "strict"))
    ap.add_argument("--tag", default="")
    ap.add_argument("--sweeps", default="plants-monitor,plants-strict,plants-history",
                    help="the plant sweeps whose records to read (comma-separated)")
    ap.add_argument("--plot", default=None, help="PNG path for a figure of the segments")
    a = ap.parse_args(argv)
    recs = [flat(r) for n in a.sweeps.split(",") for r in Store(sweeps.load(n).store)]
    recs = [r for r in recs if r["plant"] == "nominal" and r["method"] == a.method and r["mode"] == a.mode
            and r.get("tag", "") == a.tag and not r.get("n_prior")]
    if not recs:
        raise SystemExit(f"no nominal records of {a.method} ({a.mode}, tag {a.tag!r}, from a0) in {a.records}")
    segs = segments(recs)
    for s in segs:
        drop = "none" if s["drop_at"] is None else f"{s['drop_at']:.2f}"
        print(f"seed {s['seed']}: recommendation {s['P'][0]:.3f}; best before the first drop {s['best']:.3f} at "
              f"{s['at']:.2f} from it; first drop at {drop}; oracle at {s['dist'][-1]:.2f}")
    clear = sum(s["drop_at"] is None for s in segs)
    print(f"median: recommendation {np.median([s['P'][0] for s in segs]):.3f}, best before the first drop "
          f"{np.median([s['best'] for s in segs]):.3f}; segments without a drop {clear}/{len(segs)}")
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        for s in segs:
            ax.plot(s["dist"], s["P"], lw=1, label=f"seed {s['seed']}")
        ax.axhline(0.95, color="k", ls="--", lw=0.8)
        ax.text(0.01, 0.955, "goal 0.95", fontsize=8)
        ax.set(xlabel="distance from the recommendation (unit cube)", ylabel="E[P], 8 fixed starts (strict)",
               title=f"nominal: {a.method} ({a.mode}) recommendations → oracle gains", ylim=(-1.05, 1.0))
        ax.legend(fontsize=7, ncol=2)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
        print(f"figure: {a.plot}")


if __name__ == "__main__":
    main()
