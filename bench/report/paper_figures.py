"""The paper comparison's figures from its records: per setting, the best observed P against the flights counted
and the cumulative unsafe flights (median and spread over the seeds, one line per method), and the figure-8 of a0
against the median ksbo recommendation of the vehicle setting. Drawn on request, not by ``ksbo-bench report``
(a PNG's bytes differ between matplotlib versions; the pages' check would fail on them).

    python -m ksbo_bench.report.paper_figures [--out docs/figures]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ksbo_bench import sweep as sweeps
from ksbo_bench.kinds.paper_methods import ALL_NAMES
from ksbo_bench.store import Store

FIG = sweeps.ROOT / "docs" / "figures"


def runs(sweep: str = "paper-comparison") -> dict[str, dict[str, list[dict]]]:
    """{setting: {method: [run as the old JSON had it: the key's values and the result's, ``flights`` every
    flight's P in order (the counted prior first)]}}."""
    out: dict[str, dict[str, list[dict]]] = {}
    for r in Store(sweeps.load(sweep).store):
        res = r["result"]
        flights = (res["prior_y"] if res.get("prior_counted") else []) + res["y"]
        out.setdefault(r["key"]["setting"], {}).setdefault(r["key"]["method"], []).append(
            {**r["key"], **res, "flights": flights})
    return out


def curves(rs: list[dict], key: str = "flights") -> tuple[np.ndarray, np.ndarray]:
    n = min(len(r[key]) for r in rs)
    Y = np.array([np.maximum.accumulate(np.asarray(r[key][:n])) for r in rs])
    U = np.array([np.cumsum(np.asarray(r[key][:n]) < 0) for r in rs])
    return Y, U


def convergence(setting: str, by_method: dict[str, list[dict]], fig_dir: Path) -> Path:
    from ksbo_mav.plotting import pyplot

    plt = pyplot()
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for m in ALL_NAMES:
        if m not in by_method:
            continue
        Y, U = curves(by_method[m])
        x = np.arange(1, Y.shape[1] + 1)
        line, = a1.plot(x, np.median(Y, 0), label=m)
        a1.fill_between(x, np.percentile(Y, 25, 0), np.percentile(Y, 75, 0), color=line.get_color(), alpha=0.15)
        a2.plot(x, np.median(U, 0), color=line.get_color(), label=m)
        a2.fill_between(x, U.min(0), U.max(0), color=line.get_color(), alpha=0.1)
    a1.set(xlabel="flights (counted)", ylabel="best observed P (median, IQR)", ylim=(-0.2, 1.0),
           title=f"{setting}: convergence")
    a2.set(xlabel="flights (counted)", ylabel="cumulative unsafe flights (median, min–max)",
           title=f"{setting}: unsafe evaluations")
    a1.axhline(0.966, ls=":", c="k", lw=0.8)
    a1.legend(fontsize=8)
    fig.tight_layout()
    p = fig_dir / f"campaign_{setting}.png"
    fig.savefig(p, dpi=110)
    plt.close(fig)
    return p


def trajectory(by_method: dict[str, list[dict]], fig_dir: Path) -> Path:
    """a0 against the median-E ksbo run of the vehicle setting, on the first fixed initial condition."""
    from ksbo_mav.plotting import plot_trajectories
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.simulated.planar_objective import SimObjective
    from ksbo_task.starts import fixed_initial_states

    rs = sorted(by_method["ksbo"], key=lambda r: r["E"])
    r = rs[len(rs) // 2]
    prof = load_profile("sim-planar")
    obj = SimObjective(prof, seed=0)
    init = fixed_initial_states(figure8=obj.episode.figure8)[0]
    f0, f1 = obj.fly(prof.default, init=init), obj.fly(np.asarray(r["x"]), init=init)
    p = fig_dir / "campaign_trajectory.png"
    plot_trajectories([f0.trajectory, f1.trajectory],
                      [f"initial a0 (P={f0.P:.3f})", f"ksbo seed {r['seed']} (P={f1.P:.3f})"], p,
                      title="Figure-8: initial vs tuned gains (vehicle-safe setting)")
    return p


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=FIG, help="folder of the PNGs (default docs/figures)")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    data = runs()
    drawn = [convergence(s, by, a.out) for s, by in sorted(data.items())]
    if "ksbo" in data.get("vehicle", {}):
        drawn.append(trajectory(data["vehicle"], a.out))
    print("\n".join(f"wrote {p}" for p in drawn))


if __name__ == "__main__":
    main()
