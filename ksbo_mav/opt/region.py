"""Where :class:`ksbo_mav.opt.safe_bo.SafeBO` looks: anchors, the connected search region, the candidate set, the
exclusion balls around failures, the trust region's centre and the fallback."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt.candidates import local_gaussian, sobol

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO

#: Prior points this close (unit cube) to one of the optimiser's evaluations join its search region ("x0" mode).
CONNECT_RADIUS = 0.1


def anchors(bo: "SafeBO", lcb_d: np.ndarray, ucb_d: np.ndarray) -> np.ndarray:
    """(k, d) certified, completed, connected observations the candidate clouds are centred on (best by UCB,
    then random; the trust region's centre first)."""
    ok = (lcb_d >= bo.p_min) & (bo.y >= bo.p_min) & bo.complete
    ok &= connected(bo)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return bo.X[[int(np.argmax(np.where(bo.complete, lcb_d, -np.inf)))]]
    n = bo.config.n_anchors
    best = idx[np.argsort(-ucb_d[idx])][: max(n // 2, 1)]
    rest = np.setdiff1d(idx, best)
    if rest.size:
        best = np.concatenate([best, bo.rng.choice(rest, size=min(n - best.size, rest.size), replace=False)])
    A = bo.X[best]
    return A if bo.tr is None else np.vstack([bo.tr.center, A])


def connected(bo: "SafeBO") -> np.ndarray:
    """(n,) bool: observations that may anchor candidate clouds.

    All of them under ``explore_from="all"``; under ``"x0"`` the optimiser's own evaluations (the start
    first) and the prior points linked to them by a chain of steps of at most ``CONNECT_RADIUS``, so the
    search region grows from the start and takes in prior points once it reaches them. (A resumed campaign
    passes its earlier trials as prior: their chain from the start keeps them connected.)
    """
    n = bo.y.size
    if bo.config.explore_from == "all" or bo.n_prior == 0:
        return np.ones(n, dtype=bool)
    linked = np.arange(n) >= bo.n_prior
    P = bo.X[: bo.n_prior]
    while True:
        d2 = ((P[:, None, :] - bo.X[linked][None, :, :]) ** 2).sum(-1).min(axis=1)
        new = (d2 <= CONNECT_RADIUS**2) & ~linked[: bo.n_prior]
        if not new.any():
            return linked
        linked[: bo.n_prior] |= new


def candidates(bo: "SafeBO", anchors: np.ndarray) -> np.ndarray:
    """(m, d) candidate set: local clouds around ``anchors`` (k, d) plus global Sobol (moved dims only)."""
    c = bo.config
    local = local_gaussian(anchors, c.n_local, c.local_scales, bo.rng, free=bo.free)
    glob = sobol(c.n_global if c.explore_from == "all" else 0, bo.model.dim, bo.rng)
    C = np.vstack([local, glob])
    # Dimensions outside the search space stay at the start value (they are not in the kernel, so the model
    # could not tell a change there from no change).
    C[:, ~bo.free] = bo.x0[~bo.free]
    return C


def exclusion_radii(bad: np.ndarray, base: float, growth: float, cap: float) -> np.ndarray:
    """(k,) radii (unit cube) of the exclusion balls around the bad trials ``bad`` (k, d), in the order flown.

    Each ball starts at ``base``. When a later bad trial lands within twice the radius of an earlier ball, the
    bad region is evidently wider than that ball: the earlier ball grows ×``growth`` (at most ``cap``) and the new
    one starts at least as large. ``growth`` 1 keeps every ball at ``base`` (the paper method's fixed exclusion).

    Why: on the planar suite the failures after the first one landed 0.05–0.075 from an earlier failure — just
    outside the fixed 0.05 ball, where the posterior mean is high because the bistable gains fly well from other
    starts (BENCHMARKS.md, issue 13).
    """
    r = np.full(bad.shape[0], float(base))
    if growth <= 1.0:
        return r
    for i in range(1, bad.shape[0]):
        d = np.sqrt(((bad[:i] - bad[i]) ** 2).sum(-1))
        near = d < 2.0 * r[:i]
        if near.any():
            r[:i][near] = np.minimum(r[:i][near] * growth, cap)
            r[i] = max(r[i], float(r[:i][near].max()))
    return r


def excluded(bo: "SafeBO", Z: np.ndarray) -> np.ndarray:
    """(m,) bool: Z (m, d) inside the exclusion ball of a bad trial (unsafe or not completed; the radii are
    :func:`exclusion_radii`)."""
    bad = bo.X[(bo.y < bo.p_min) | ~bo.complete]
    if bo.config.exclusion_radius <= 0 or bad.shape[0] == 0:
        return np.zeros(Z.shape[0], dtype=bool)
    r = exclusion_radii(bad, bo.config.exclusion_radius, bo.adaptive.exclusion_growth, bo.adaptive.exclusion_max)
    d2 = ((Z[:, None, :] - bad[None, :, :]) ** 2).sum(-1)
    return (d2 < r[None, :] ** 2).any(axis=1)


def in_grown_ball(bo: "SafeBO", Z: np.ndarray) -> np.ndarray:
    """(m,) bool: Z (m, d) inside a failure's exclusion ball when the balls grow (``exclusion_growth`` > 1, the
    adaptive optimiser): the fallback, the re-fly phase and the trust region's centre keep out of them. All False
    with fixed balls, where only certified candidates are excluded (the paper method, bit for bit)."""
    if bo.adaptive.exclusion_growth <= 1.0:
        return np.zeros(Z.shape[0], dtype=bool)
    return excluded(bo, Z)


def incumbent(bo: "SafeBO") -> np.ndarray:
    """(d,) best completed safe trial by posterior mean (the trust region's centre; x0 before any), outside the
    failures' exclusion balls when they grow: a centre inside a ball larger than the trust region leaves no
    candidate to query, and the run falls back to re-flying one point for the rest of its budget."""
    ok = bo.complete & (bo.y >= bo.p_min)
    if ok.any() and not bo.complete.all():
        ok[ok] = ~in_grown_ball(bo, bo.X[ok])
    if not ok.any():
        return bo.x0.copy()
    mu, _ = bo.model.predict(bo.X[ok])
    return bo.X[ok][int(np.argmax(mu))].copy()


def fallback_index(bo: "SafeBO", lcb_d: np.ndarray) -> int:
    """Data index re-flown when no candidate is certified: the best-LCB completed observation (lcb_d (n,)) in the
    search subspace (x0 always is one), never one the failure model now expects to abort or crash, nor (with
    the adaptive settings) one inside the exclusion ball of a failed trial — the same gains may have completed
    once and failed the next time."""
    inside = np.all(bo.X[:, ~bo.free] == bo.x0[~bo.free], axis=1) & bo.complete
    if bo.failures is not None and not bo.complete.all() and inside.any():
        # A trial that completed once may abort the next time (bistable gains on a random start); x0 stays allowed.
        ok = bo.failures.acceptable(bo.X, bo.adaptive.abort_tol, bo.adaptive.crash_tol)
        ok &= ~in_grown_ball(bo, bo.X)
        inside &= ok | np.all(bo.X == bo.x0, axis=1)
    return int(np.argmax(np.where(inside, lcb_d, -np.inf))) if inside.any() else int(np.argmax(lcb_d))
