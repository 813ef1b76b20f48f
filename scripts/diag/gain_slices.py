"""Diagnostic: the planar plants' score along one gain at a time, from a0.

Each slice moves one gain of a0 (unit cube of the sim-planar profile) over a grid and flies every point from the
8 fixed initial conditions under the in-process monitor: E[P] and how many of the 8 starts abort or crash. It
shows why every method stalls near 0.4 on pitch inertia ×0.5, the 40 ms delay and noise ×3: their
score is a plateau along the pitch D gain with a cliff to 0.9 at 0.05–0.1 of its range (iyy×0.5), and next to
the cliff the gains fail.

    python scripts/diag/gain_slices.py --plants "nominal,iyy x0.5" --dims 6,8 [--plot docs/figures/x.png]
"""

from __future__ import annotations

import argparse

import numpy as np


def slices(plant: str, dims: list[int], grid: np.ndarray) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """{dim: ((g,) E[P], (g,) failing starts of 8)} along each gain of ``dims`` over ``grid`` (unit cube)."""
    from ksbo_mav.simulated.planar_objective import SimObjective

    obj = SimObjective(plant=plant, monitor=True, seed=0)
    a0 = obj.profile.to_unit(obj.profile.default)
    out = {}
    for dim in dims:
        U = np.repeat(a0[None], grid.size, axis=0)
        U[:, dim] = grid
        ep, counts = obj.expected_outcomes(np.array([obj.profile.from_unit(u) for u in U]))
        out[dim] = (ep, counts[:, 1] + counts[:, 2])
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plants", default="nominal,iyy x0.5,delay 40ms,noise x3")
    ap.add_argument("--dims", default="6,8", help="gain indices (0-8; 6 = ATT_PIT_P, 8 = ATT_PIT_D)")
    ap.add_argument("--points", type=int, default=17, help="grid points over [0, --upto]")
    ap.add_argument("--upto", type=float, default=0.4)
    ap.add_argument("--plot", help="PNG with one panel per gain")
    a = ap.parse_args()
    from ksbo_mav.profiles import load_profile

    names = [g.name for g in load_profile("sim-planar").gains]
    dims = [int(d) for d in a.dims.split(",")]
    grid = np.linspace(0.0, a.upto, a.points)
    print("| plant | gain | " + " | ".join(f"{v:.3f}" for v in grid) + " |")
    print("|---|---|" + "---|" * grid.size)
    results = {}
    for plant in [p.strip() for p in a.plants.split(",")]:
        results[plant] = slices(plant, dims, grid)
        for dim, (ep, fail) in results[plant].items():
            cells = [f"{e:.2f}" + (f" ({f})" if f else "") for e, f in zip(ep, fail)]
            print(f"| {plant} | {names[dim]} | " + " | ".join(cells) + " |")
    if a.plot:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, len(dims), figsize=(5 * len(dims), 3.6), sharey=True)
        for ax, dim in zip(np.atleast_1d(axes), dims):
            for plant, res in results.items():
                ep, fail = res[dim]
                line, = ax.plot(grid, ep, lw=1.2, label=plant)
                ax.plot(grid[fail > 0], ep[fail > 0], "x", color=line.get_color())
            a0 = load_profile("sim-planar").to_unit(load_profile("sim-planar").default)[dim]
            ax.axvline(a0, color="k", ls=":", lw=0.8)
            ax.set(xlabel=f"{names[dim]} (unit cube; a0 dotted)", title=f"one gain from a0: {names[dim]}")
        np.atleast_1d(axes)[0].set_ylabel("E[P], 8 fixed starts (x: some abort/crash)")
        np.atleast_1d(axes)[-1].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(a.plot, dpi=110)
        print(f"figure: {a.plot}")


if __name__ == "__main__":
    main()
