"""Issue 13 diagnostic: what the flights show along the pitch D gain, plant by plant (items AL, AM).

Moves ATT_PIT_D of a0 (unit cube of the sim-planar profile) over a grid and flies each point from the 8 fixed
initial conditions under the in-process monitor. Per point: E[P], how many starts abort or crash, and the two
symptoms of the pitch rate over the scored lap (:mod:`ksbo_mav.symptoms`): ``pitch_line`` (the power fraction in
the strongest narrow line above 5 Hz, min–max over the starts) and ``pitch_chatter`` (rms of the step-to-step
change over the rms, mean). It shows where the limit cycle of a too-high D gain starts on each plant, that
sensor noise does not make a line, and where the score is best (just below the cycle's onset on most plants).

    python scripts/diag_symptom_slices.py [--plants "nominal,iyy x0.5,..."] [--plot docs/figures/x.png]
"""

from __future__ import annotations

import argparse

import numpy as np

PLANTS = "nominal,mass+30,iyy x0.5,motor lag,noise x3,gusts,delay 40ms"


def symptom_slice(plant: str, grid: np.ndarray, dim: int) -> dict[str, np.ndarray]:
    """Along gain ``dim`` over ``grid`` (g,) from a0: (g,) E[P] and failing starts, (g, 2) min/max pitch_line
    and (g,) mean pitch_chatter over the 8 fixed starts (NaN where no start reported it)."""
    from ksbo_mav.objective import SimObjective
    from ksbo_mav.scoring import score_rollout
    from ksbo_sim.episode import fixed_initial_states
    from ksbo_sim.monitor import Outcome

    obj = SimObjective(plant=plant, monitor=True, seed=0)
    a0 = obj.profile.to_unit(obj.profile.default)
    inits = fixed_initial_states(config=obj.episode)
    ep, fail, line, chatter = [], [], [], []
    for v in grid:
        u = a0.copy()
        u[dim] = v
        X = np.repeat(obj.profile.from_unit(u)[None], len(inits), axis=0)
        r = obj.rollout(X, inits)
        found = obj.symptoms(r)
        ln = [s["pitch_line"] for s in found if "pitch_line" in s]
        ch = [s["pitch_chatter"] for s in found if "pitch_chatter" in s]
        ep.append(float(np.mean(score_rollout(r, obj.score_config).P)))
        fail.append(sum(o is not Outcome.COMPLETE for o in r.outcomes))
        line.append((min(ln), max(ln)) if ln else (np.nan, np.nan))
        chatter.append(np.mean(ch) if ch else np.nan)
    return {"ep": np.array(ep), "fail": np.array(fail), "line": np.array(line), "chatter": np.array(chatter)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", default=PLANTS)
    ap.add_argument("--points", type=int, default=13, help="grid points over [0, --upto]")
    ap.add_argument("--upto", type=float, default=0.3)
    ap.add_argument("--plot", help="PNG: E[P] and pitch_line along the gain, one line per plant")
    a = ap.parse_args()
    from ksbo_mav.profiles import load_profile

    profile = load_profile("sim-planar")
    dim = profile.names.index("ATT_PIT_D")
    grid = np.linspace(0.0, a.upto, a.points)
    print("ATT_PIT_D from a0 (unit cube); cell: E[P] (failing starts) line min-max / chatter")
    print("| plant | " + " | ".join(f"{v:.3f}" for v in grid) + " |")
    print("|---|" + "---|" * grid.size)
    results = {}
    for plant in [p.strip() for p in a.plants.split(",")]:
        r = results[plant] = symptom_slice(plant, grid, dim)
        cells = [f"{e:+.2f}" + (f" ({f})" if f else "") + f" {lo:.2f}-{hi:.2f} / {c:.2f}"
                 for e, f, (lo, hi), c in zip(r["ep"], r["fail"], r["line"], r["chatter"])]
        print(f"| {plant} | " + " | ".join(cells) + " |", flush=True)
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
        for plant, r in results.items():
            line, = ax1.plot(grid, r["ep"], lw=1.2, label=plant)
            bad = r["fail"] > 0
            ax1.plot(grid[bad], r["ep"][bad], "x", color=line.get_color())
            ax2.fill_between(grid, r["line"][:, 0], r["line"][:, 1], color=line.get_color(), alpha=0.25)
            ax2.plot(grid, r["line"].mean(axis=1), lw=1.2, color=line.get_color(), label=plant)
        a0 = profile.to_unit(profile.default)[dim]
        for ax in (ax1, ax2):
            ax.axvline(a0, color="k", ls=":", lw=0.8)
            ax.set_xlabel("ATT_PIT_D (unit cube; a0 dotted)")
        ax1.set(ylabel="E[P], 8 fixed starts (x: some abort/crash)", title="score along the pitch D gain")
        ax2.axhline(0.5, color="k", ls="--", lw=0.8)
        ax2.set(ylabel="pitch_line (band: min-max over starts)", ylim=(-0.02, 1.02),
                title="the limit cycle's line (rule threshold dashed)")
        ax2.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
        print(f"figure: {a.plot}")


if __name__ == "__main__":
    main()
