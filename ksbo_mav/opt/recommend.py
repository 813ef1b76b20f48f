"""The recommendation: the model's smoothed judgement, and the re-fly phase that checks its top candidates.

* :func:`model_choice` — among completed observations that were safe *and* are certified by the model, the best
  smoothed posterior mean (or LCB): not the luckiest noisy observation (part D of the fact sheet: bistable gains).
* Re-fly phase (``refly_last`` > 0, opt.runner): :func:`refly_candidates` are the ``refly_top`` best distinct
  points by that criterion; :func:`final_choice` is then the candidate with the best mean over all its flights —
  or, once any trial of the run failed, the best :func:`expected_value` under the failure model among those
  candidates and the model's own choice.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt.region import excluded, in_grown_ball
from ksbo_mav.opt.stress import eligible

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO

#: The exploitation phase takes at most 1/EXPLOIT_SHARE of the budget; the boundary-expansion and the re-fly
#: phases at most 1/PHASE_SHARE each (a 30-flight vehicle campaign keeps 21 flights for the search).
EXPLOIT_SHARE = 5
PHASE_SHARE = 10
#: The value a failed (aborted or crashed) flight counts with in :func:`expected_value`: the floor of the score.
FAILED_VALUE = -1.0
#: Pseudo-flights of the failure model's neighbourhood estimate in :func:`expected_value`.
NEIGHBOUR_WEIGHT = 2.0
#: :func:`clear_choice`: P(abort) at most this (below the prior mean 0.25: well inside completed trials).
CLEAR_TOL = 0.1


def smoothed(bo: "SafeBO") -> tuple[np.ndarray, np.ndarray]:
    """Recommendation criterion at the data: (n,) posterior mean and (n,) LCB (of the smoothing GP)."""
    mu, _, lcb, _ = bo.bounds(bo.X)
    if bo.config.recommend_noise is not None:
        smooth = bo.model.variant(noise_std=bo.config.recommend_noise * bo.model.signal_std)
        smooth.fit(bo.X[bo.gp_mask], bo.y[bo.gp_mask])
        mu_s, sd_s = smooth.predict(bo.X)
        mu, lcb = mu_s, mu_s - bo.beta * sd_s
    return mu, lcb


def unlikely_to_abort(bo: "SafeBO") -> np.ndarray:
    """(n,) bool: data points the failure model does not expect to abort (all of them while none has aborted)."""
    if bo.failures is None or bo.complete.all():
        return np.ones(bo.y.size, dtype=bool)
    return bo.failures.predict(bo.X)[0] <= bo.adaptive.abort_tol


def model_choice(bo: "SafeBO") -> tuple[int, float, float]:
    """Index into the data of the recommended point, with its posterior mean and LCB.

    Among completed observations that were safe *and* are certified safe by the model, the best posterior
    mean (or LCB): the model's smoothed judgement, not the luckiest noisy observation (part D: bistable gains).
    """
    _, _, lcb_strict, _ = bo.bounds(bo.X)
    ok = (bo.y >= bo.p_min) & (lcb_strict >= bo.p_min) & bo.complete & unlikely_to_abort(bo)
    mu, lcb = smoothed(bo)
    if not ok.any():
        ok = (bo.y >= bo.p_min) & bo.complete
    if not ok.any():
        ok = np.ones_like(ok)
    crit = lcb if bo.config.recommend == "lcb" else mu
    i = int(np.argmax(np.where(ok, crit, -np.inf)))
    return i, float(mu[i]), float(lcb[i])


def refly_count(bo: "SafeBO") -> int:
    """Evaluations of the re-fly phase (at most a tenth of the budget)."""
    n = bo.adaptive.refly_last
    return min(n, bo.budget // PHASE_SHARE) if bo.budget > 0 else n


def refly_candidates(bo: "SafeBO") -> np.ndarray:
    """(k,) data indices of the ``refly_top`` best distinct completed safe points by the recommendation's
    criterion (the smoothed posterior mean or LCB)."""
    mu, lcb = bo.smoothed()
    crit = lcb if bo.config.recommend == "lcb" else mu
    ok = bo.complete & (bo.y >= bo.p_min)
    if not ok.any():
        ok = bo.complete
    order = [int(i) for i in np.argsort(-np.where(ok, crit, -np.inf)) if ok[i]]
    # The best single flight competes too: the smoothing pulls a lone point at the edge of the data towards the
    # prior mean (p_min), so on a smooth, low-noise plant the best gains would otherwise never be re-flown.
    fine = ok & unlikely_to_abort(bo)
    if fine.any() and bo.adaptive.refly_top > 1:
        best = int(np.argmax(np.where(fine, bo.y, -np.inf)))
        order = order[: bo.adaptive.refly_top - 1] + [best] + order[bo.adaptive.refly_top - 1 :]
    chosen: list[int] = []
    for i in order:
        if not any(np.array_equal(bo.X[i], bo.X[j]) for j in chosen):
            chosen.append(i)
        if len(chosen) == bo.adaptive.refly_top:
            break
    return np.asarray(chosen, dtype=int)


def _refresh_failures(bo: "SafeBO") -> bool:
    """Whether any trial of the run failed; if so, the failure model is brought up to date (the state machine
    refits it on failures only, so completed trials since the last failure are missing from it)."""
    if bo.failures is None or bo.complete.all():
        return False
    bo.failures.fit(bo.X, ~bo.complete, bo.crashed)
    return True


def next_refly(bo: "SafeBO", k: int) -> int:
    """Data index of the k-th re-flight: the candidates (``bo.refly_set``) in turn, skipping any that failed at
    exactly its gains — it has shown it is bistable, and another flight there only risks another crash — and,
    with growing exclusion balls, any inside a failure's ball. Once none is left: the best point clear of
    failures (:func:`clear_choice`), if there is one."""
    _refresh_failures(bo)
    alive = [int(c) for c in bo.refly_set if bo.complete[np.all(bo.X == bo.X[c], axis=1)].all()]
    if alive:  # nor inside a failure's (grown) exclusion ball
        alive = [c for c, out in zip(alive, in_grown_ball(bo, bo.X[alive])) if not out]
    if not alive:
        clear = clear_choice(bo)
        if clear is None:
            alive = [int(c) for c in bo.refly_set]
        else:  # it joins the candidates (reported as re-flown; the final choice weighs it like them)
            alive = [clear]
            if clear not in bo.refly_set:
                bo.refly_set = np.append(bo.refly_set, clear)
    return alive[k % len(alive)]


def refly_choice(bo: "SafeBO", cands: np.ndarray) -> int:
    """Data index of the candidate with the best :func:`expected_value` (while no trial failed: the best mean over
    every flight at exactly that point; the first of equals)."""
    return max((int(c) for c in cands), key=lambda k: expected_value(bo, k))


def expected_value(bo: "SafeBO", i: int) -> float:
    """Expected score of the gains X[i]: ``(1 − p)·m + p·FAILED_VALUE``, with m the mean over the completed
    flights at exactly X[i] and p their chance to fail.

    p = (f + NEIGHBOUR_WEIGHT·q) / (n + NEIGHBOUR_WEIGHT): X[i]'s own f failures in n flights, shrunk towards
    the failure model's P(abort) q there (its neighbours'). The kernel model alone averages a bistable point's
    own failures with many completed neighbours: on tuning seed 108 of the planar plant (BENCHMARKS.md, issue 13)
    gains that failed 2 of 5 flights had q = 0.17. Without any failed trial in the run: the mean of all its flights.
    """
    same = np.all(bo.X == bo.X[i], axis=1)
    if bo.failures is None or bo.complete.all():
        return float(np.mean(bo.y[same]))
    done = same & bo.complete
    m = float(np.mean(bo.y[done])) if done.any() else FAILED_VALUE
    q = float(bo.failures.predict(bo.X[i][None, :])[0][0])
    p = (float(np.sum(same & ~bo.complete)) + NEIGHBOUR_WEIGHT * q) / (float(same.sum()) + NEIGHBOUR_WEIGHT)
    return (1.0 - p) * m + p * FAILED_VALUE


def clear_choice(bo: "SafeBO") -> int | None:
    """Data index of the best completed safe point (recommendation criterion) that the failure model puts clear
    of every failure (P(abort) ≤ ``CLEAR_TOL``, outside every exclusion ball), or None."""
    if bo.failures is None:
        return None
    mu, lcb = bo.smoothed()
    crit = lcb if bo.config.recommend == "lcb" else mu
    ok = bo.complete & (bo.y >= bo.p_min) & (bo.failures.predict(bo.X)[0] <= CLEAR_TOL) & ~excluded(bo, bo.X)
    return int(np.argmax(np.where(ok, crit, -np.inf))) if ok.any() else None


def final_choice(bo: "SafeBO") -> tuple[int, float, float]:
    """The recommendation: among the re-flown candidates if a re-fly phase ran (after a stress screen,
    ``refly_stress``, among those it did not rule out, if any passed: :func:`ksbo_mav.opt.stress.eligible`), else
    ``bo.recommend()``.

    Once any trial failed, the re-flown candidates, the model's choice and the best point clear of failures
    (:func:`clear_choice`) compete by :func:`expected_value`: a candidate that failed when re-flown loses to a
    slightly worse point nobody failed near.
    """
    failed = _refresh_failures(bo)
    passed = eligible(bo)
    if passed:  # refly_stress: only candidates the stress flights did not rule out (opt.stress)
        j = refly_choice(bo, np.asarray(passed))
        m, l_ = bo.smoothed()
        return j, float(m[j]), float(l_[j])
    i, mu, lcb = bo.recommend()
    cands = bo.refly_set
    if cands is None or len(cands) == 0:
        return i, mu, lcb
    pool = np.asarray(cands, dtype=int)
    if failed:
        clear = clear_choice(bo)
        pool = np.append(pool, [i] + ([clear] if clear is not None else []))
    j = refly_choice(bo, pool)
    m, l_ = bo.smoothed()
    return j, float(m[j]), float(l_[j])
