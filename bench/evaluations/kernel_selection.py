"""Evaluation ``kernel-selection``: Nyström kernel selection (C_ree, ksbo_mav.select) on functions of known
interaction order and on 36-point simulator priors (sim-planar, one random-velocity episode per point; ``design``
box: LHS over the box, local: ±0.1 around a0). Defaults unless the key says otherwise: SE base kernels with
lengthscale 0.2 (unit cube), normalised single-order kernels, y standardised, mu = 0.1, c = k = round(0.8 l) =
29, T = 1000, top 3. ``measure``:

- ``synthetic`` (``function``, ``columns``: 36 exact or 29 Nyström, ``seeds``): the top 3 per LHS seed and how
  often the top 1 is the true order;
- ``prior-cree`` (``design``): the C_ree table of prior seed 0 (mean, std, top-3 frequency, exact);
- ``stability`` (``design``, ``columns``, ``seeds``): the top 3 per prior seed and how often each order is in it;
  how many seeds reproduce the paper's {2, 3, 4};
- ``sensitivity`` (``design``, ``mu``, ``lengthscale``, ``seeds``): the same counts at another mu or lengthscale;
- ``dimensions`` (``design``, ``method``: forest or permutation, ``seeds``): how often each gain is kept for
  order 2;
- ``heldout`` (``design``, ``seeds``): test RMSE / std of GPs with single orders and combinations trained on a
  prior and tested on 200 fresh LHS points of the same region: which orders actually predict the simulator.
"""

from __future__ import annotations

from collections import Counter
from typing import Any

import numpy as np

from ksbo_bench.cell_errors import SweepError

ORDERS = tuple(range(1, 10))
SYNTH = {
    "additive (order 1)": (1, lambda X: np.sin(3 * X[:, 0]) + X[:, 1] ** 2 + np.cos(2 * X[:, 2]) + X[:, 3]
                           - X[:, 4] ** 3),
    "sum of 2-D terms (order 2)": (2, lambda X: np.sin(np.pi * X[:, 0]) * np.sin(np.pi * X[:, 1])
                                   + 4 * (X[:, 2] - 0.5) * (X[:, 3] - 0.5)
                                   + np.exp(-((X[:, 4] - 0.5) ** 2 + (X[:, 5] - 0.5) ** 2) / 0.2)),
    "9-D bump (order 9)": (9, lambda X: np.exp(-((X - 0.5) ** 2).sum(1) / 0.5)),
}
MEASURES = ("synthetic", "prior-cree", "stability", "sensitivity", "dimensions", "heldout")


def check(key: dict[str, Any]) -> None:
    if key.get("measure") not in MEASURES:
        raise SweepError(f"kernel-selection: measure must be one of {', '.join(MEASURES)}")
    if key["measure"] == "synthetic" and key.get("function") not in SYNTH:
        raise SweepError(f"kernel-selection: function must be one of {'; '.join(SYNTH)}")


def _top(orders) -> str:
    return "".join(str(r) for r in orders)


def sim_prior(design: str, seed: int, n: int = 36) -> tuple[np.ndarray, np.ndarray]:
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.select import lhs_design
    from ksbo_mav.simulated.planar_objective import SimObjective

    prof = load_profile("sim-planar")
    U = lhs_design(n, prof.dim, design=design, center=prof.to_unit(prof.default), radius=0.1, seed=seed)
    return U, SimObjective(prof, seed=seed).batch(prof.from_unit(U))


def _seeds(key: dict[str, Any], default: int) -> range:
    return range(int(key.get("seeds", default)))


def run(key: dict[str, Any]) -> dict[str, Any]:
    from ksbo_mav.select import lhs_design, select_dimensions_for_orders, select_orders

    m, design = key["measure"], key.get("design", "box")
    if m == "synthetic":
        true, f = SYNTH[key["function"]]
        tops = []
        for s in _seeds(key, 8):
            X = lhs_design(36, 9, seed=s)
            tops.append(_top(select_orders(X, f(X), trials=300, columns=int(key.get("columns", 36)), seed=s).orders))
        return {"tops": tops, "hits": sum(t[0] == str(true) for t in tops)}
    if m == "prior-cree":
        U, P = sim_prior(design, 0)
        sel = select_orders(U, P, seed=0)
        return {"unsafe": int(np.sum(P < 0)), "P_median": float(np.median(P)), "orders": list(sel.orders),
                **{k: {str(r): float(getattr(sel, k)[r]) for r in ORDERS} for k in ("mean", "std", "top_frequency",
                                                                                      "exact")}}
    priors = [sim_prior(design, s) for s in _seeds(key, 10)]
    if m in ("stability", "sensitivity"):
        kw = ({"columns": int(key["columns"])} if "columns" in key else {})
        if m == "sensitivity":
            kw = {"mu": float(key["mu"]), "lengthscales": float(key["lengthscale"])}
        tops = [_top(select_orders(U, P, seed=0, **kw).orders) for U, P in priors]
        counts = Counter(int(c) for t in tops for c in t)
        return {"tops": tops, "counts": [counts[r] for r in ORDERS], "paper": sum(set(t) == set("234") for t in tops)}
    if m == "dimensions":
        cnt, sizes = Counter(), []
        for i, (U, P) in enumerate(priors):
            sel = select_dimensions_for_orders(U, P, [2], method=key.get("method", "forest"), seed=i)[2]
            cnt.update(sel.dims)
            sizes.append(len(sel.dims))
        return {"counts": [cnt[i] for i in range(9)], "mean_kept": float(np.mean(sizes))}
    return _heldout(design, priors)


def _heldout(design: str, priors: list) -> dict[str, Any]:
    from ksbo_mav.gp import AdditiveKernel, GaussianProcess
    from ksbo_mav.profiles import load_profile
    from ksbo_mav.select import lhs_design, select_orders
    from ksbo_mav.simulated.planar_objective import SimObjective

    prof = load_profile("sim-planar")
    kernels = {**{f"{r}": (r,) for r in ORDERS}, "1+9": (1, 9), "2+3+4": (2, 3, 4)}
    errs: dict[str, list[float]] = {k: [] for k in kernels}
    chosen = []
    for s, (U, P) in enumerate(priors):
        Ut = lhs_design(200, 9, design=design, center=prof.to_unit(prof.default), radius=0.1, seed=1000 + s)
        Pt = SimObjective(prof, seed=1000 + s).batch(prof.from_unit(Ut))
        for name, orders in kernels.items():
            gp = GaussianProcess(AdditiveKernel(9, orders, 0.2), noise=1e-2).fit(U, P)
            errs[name].append(float(np.sqrt(np.mean((gp.predict(Ut) - Pt) ** 2)) / P.std()))
        chosen.append(_top(select_orders(U, P, seed=0).orders))
    return {"rmse": {k: float(np.mean(v)) for k, v in errs.items()}, "chosen": chosen}


def report(recs: list[dict[str, Any]]) -> str:
    from ksbo_bench.evaluations.kernel_selection_report import report as tables

    return tables(recs)
