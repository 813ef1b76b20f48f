#!/usr/bin/env python
"""Optimiser overhead of the safe BO campaign: seconds per ksbo proposal at 200 observations (9-D,
orders 2, 3, 4, the campaign's options, one thread) and the rank-one model update. Reported by
``bench_campaign_report.py``; run alone it prints the numbers.

    python scripts/bench_campaign_overhead.py
"""

from __future__ import annotations

import sys
import time

import numpy as np

from _bench_campaign_common import METHOD_OPTIONS


def overhead(n_obs: int = 200, repeats: int = 5) -> dict[str, float]:
    """Seconds per ksbo proposal with ``n_obs`` observations (9-D, orders 2, 3, 4, campaign options, 1 thread)."""
    from threadpoolctl import threadpool_limits

    from ksbo_mav.opt.options import options_for
    from ksbo_mav.opt.problem import Problem
    from ksbo_mav.opt.methods.build import safe_bo_for

    with threadpool_limits(1):
        rng = np.random.default_rng(0)
        X = np.clip(0.3 + 0.2 * rng.random((n_obs, 9)), 0, 1)
        y = np.sin(3 * X).sum(1) / 3
        opts = options_for("ksbo", METHOD_OPTIONS["ksbo"]).update({"expansion_iters": 0})
        prob = Problem(fun=lambda x: 0.0, lower=np.zeros(9), upper=np.ones(9), x0=X[0], budget=1)
        bo = safe_bo_for(prob, opts, (2, 3, 4), None, 0, rng)
        bo.fit(X, y)
        t = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            p = bo.propose()
            t.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        bo.observe(p.x, 0.5)
        return {"ksbo": float(np.median(t)), "ksbo_update": time.perf_counter() - t0}


if __name__ == "__main__":
    ov = overhead()
    print(f"ksbo proposal at 200 observations: {ov['ksbo']:.3f} s; model update {ov['ksbo_update'] * 1e3:.1f} ms")
    sys.exit(0)
