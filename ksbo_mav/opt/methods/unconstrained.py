"""Unconstrained baselines: GP-UCB, expected improvement, uniform random search.

The GP baselines are what a user would pick without safety: SE-ARD GP with standardised outputs and ML-II
hyperparameters refitted every ``unconstrained_refit`` iterations, acquisition maximised over global Sobol
points plus Gaussian clouds around the best observations, refined locally. Nothing stops them from querying
unsafe gains; that is the point of the comparison.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import norm

from ksbo_mav.gp import AdditiveKernel, GaussianProcess
from ksbo_mav.opt.acquisition.candidates import local_gaussian, refine, sobol
from ksbo_mav.opt.options import Options
from ksbo_mav.opt.problem import Problem, build_result
from ksbo_mav.opt.result import OptimizeResult


def _gp(d: int, opts: Options, seed: int | None, optimize: bool) -> GaussianProcess:
    kernel = AdditiveKernel(dim=d, orders=(d,), lengthscales=np.full(d, max(opts.lengthscale, 0.2)))
    return GaussianProcess(kernel=kernel, noise=1e-4, normalize_y=True, optimize=optimize, n_restarts=1, seed=seed)


def run_unconstrained(problem: Problem, method: str, opts: Options, seed: int | None) -> OptimizeResult:
    """``method`` = "ucb" or "ei": spend the remaining budget of ``problem`` (x0 already evaluated)."""
    d = problem.dim
    rng = np.random.default_rng(seed)
    it = 0
    gp = _gp(d, opts, seed, optimize=True)
    while problem.remaining > 0:
        X, y = problem.data()
        k = max(opts.unconstrained_refit, 1)
        # Refit with ML-II every k iterations; in between only the data changes (hyperparameters kept).
        if it % k == 0 or it == 0:
            gp = _gp(d, opts, seed, optimize=len(y) >= 3)
            gp.fit(X, y)
        else:
            gp.add_observation(X[-1], y[-1])
        it += 1
        best = float(np.max(y))

        def evaluate(Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            mu, sd = gp.predict(Z, return_std=True)
            mu, sd = np.asarray(mu).reshape(-1), np.asarray(sd).reshape(-1)
            if method == "ucb":
                score = mu + opts.beta * sd
            else:
                z = (mu - best - opts.xi) / np.maximum(sd, 1e-12)
                score = (mu - best - opts.xi) * norm.cdf(z) + sd * norm.pdf(z)
            return score, np.ones(len(Z), dtype=bool)

        top = X[np.argsort(-y)[: min(8, len(y))]]
        C = np.vstack([sobol(opts.n_global * 4, d, rng),
                       local_gaussian(top, opts.n_local // 2, opts.local_scales, rng)])
        score, _ = evaluate(C)
        starts = C[np.argsort(-score)[:8]]
        Z, s = refine(evaluate, starts, rng, rounds=4, samples=32, scale=0.05)
        x = Z[int(np.argmax(s))]
        problem.evaluate(x)
    X, y = problem.data()
    gp = _gp(d, opts, seed, optimize=False) if len(y) < 3 else gp
    gp.fit(X, y)
    mu, sd = gp.predict(X, return_std=True)
    i = int(np.argmax(np.asarray(mu).reshape(-1)))
    return build_result(problem, method, i, mu=float(np.asarray(mu).reshape(-1)[i]), orders=(d,),
                        info={"options": opts})


def run_random(problem: Problem, opts: Options, seed: int | None) -> OptimizeResult:
    """Uniform random search; recommends the best *observed* point (as random search does)."""
    rng = np.random.default_rng(seed)
    while problem.remaining > 0:
        problem.evaluate(rng.random(problem.dim))
    X, y = problem.data()
    return build_result(problem, "random", int(np.argmax(y)), info={"options": opts})
