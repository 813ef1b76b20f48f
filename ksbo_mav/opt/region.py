"""Where :class:`ksbo_mav.opt.safe_bo.SafeBO` looks: anchors, the connected search region, the candidate set."""

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


def fallback_index(bo: "SafeBO", lcb_d: np.ndarray) -> int:
    """Data index re-flown when no candidate is certified: the best-LCB completed observation (lcb_d (n,)) in the
    search subspace (x0 always is one), never one the failure model now expects to abort or crash."""
    inside = np.all(bo.X[:, ~bo.free] == bo.x0[~bo.free], axis=1) & bo.complete
    if bo.failures is not None and not bo.complete.all() and inside.any():
        # A trial that completed once may abort the next time (bistable gains on a random start); x0 stays allowed.
        ok = bo.failures.acceptable(bo.X, bo.adaptive.abort_tol, bo.adaptive.crash_tol)
        inside &= ok | np.all(bo.X == bo.x0, axis=1)
    return int(np.argmax(np.where(inside, lcb_d, -np.inf))) if inside.any() else int(np.argmax(lcb_d))
