"""Safe LineBO (Kirschner et al., ICML 2019; kirschnj/LineBO ``subdomainbo/safeopt.py``), re-implemented.

One global GP (SE-ARD, same prior scales as the other safe methods). Each line passes through the current
recommendation x_b along a random direction (or cyclic coordinates); the 1-D problem is solved on a
``line_points`` grid (opt.acquisition.lines): the safe interval is the contiguous run of certified-safe grid
points containing x_b; the query is the UCB maximiser on it unless the interval's end points (expanders) have a
wider confidence interval than 2·β·σ at that maximiser. A line ends after ``line_budget`` queries or when the
best UCB on it exceeds LCB(x_b) by less than 1 % of |μ(x_b)|. Unlike the original, x_b is not re-evaluated at the
start of every line (that only serves its reporting and would spend budget).
"""

from __future__ import annotations

import numpy as np

from ksbo_mav.opt.acquisition.lines import line_grid, line_query, safe_interval
from ksbo_mav.opt.methods.build import bo_config, build_safe_bo, model_spec
from ksbo_mav.opt.models.safety_model import SafetyModel
from ksbo_mav.opt.options import Options
from ksbo_mav.opt.problem import Problem, build_result
from ksbo_mav.opt.result import OptimizeResult


def run_linebo(problem: Problem, opts: Options, seed: int | None) -> OptimizeResult:
    """Spend the remaining budget with safe LineBO (x0 already evaluated)."""
    d = problem.dim
    rng = np.random.default_rng(seed)
    model = SafetyModel(model_spec(opts, (d,)), d, problem.p_min, seed=seed)
    bo = build_safe_bo(model, bo_config(opts), np.ones(d, dtype=bool), rng, x0=problem.x0)
    bo.fit(*problem.data())
    n_lines = 0
    while problem.remaining > 0:
        i_best, mu_b, lcb_b = bo.recommend()
        xb = bo.obs.X[i_best].copy()
        if opts.directions == "coordinate":
            direction = np.zeros(d)
            direction[n_lines % d] = 1.0
        else:
            direction = rng.standard_normal(d)
            direction /= np.linalg.norm(direction)
        n_lines += 1
        s, P = line_grid(xb, direction, opts.line_points)
        i0 = int(np.argmin(np.abs(s)))
        for _ in range(opts.line_budget):
            if problem.remaining <= 0:
                break
            mu, sd, lcb, ucb = bo.bounds(P)
            ok = bo.feasible(P, lcb)
            lo, hi = safe_interval(ok, i0)
            if not ok[i0]:
                # x_b itself is no longer certified: re-evaluate the best-LCB observation (fallback).
                bo.fallbacks += 1
                j = int(np.argmax(bo.bounds(bo.obs.X)[2]))
                x = bo.obs.X[j].copy()
            else:
                if np.max(ucb[lo : hi + 1]) - lcb_b < 0.01 * abs(mu_b):
                    break
                x = P[line_query(ucb, sd, lo, hi, i0)]
            y = problem.evaluate(x)
            bo.observe(x, y)
    i, mu, lcb = bo.recommend()
    return build_result(
        problem, "linebo", i, mu=mu, lcb=lcb, orders=(d,), fallbacks=bo.fallbacks,
        info={"options": opts, "lines": n_lines, "signal_std": model.signal_std},
    )
