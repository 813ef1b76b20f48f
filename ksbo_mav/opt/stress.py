"""The re-fly phase with a stress screen (``refly_stress``): each candidate flies once from the objective's
hardest start (``fun.stress``) before it is re-flown; only candidates that pass can be recommended.

Bistable gains complete from most starts and fail from a few, and on the planar task the failing starts are the
ones against the path in x (BENCHMARKS.md, issue 13, item AH): one flight from such a start at 0.9 × the start
speed cap (:func:`ksbo_sim.episode.stress_initial_state`) flags most of them and no robust gains. A stress flight
that completes counts in its candidate's mean like any re-flight: for robust gains its P is close to their mean over
random starts (within 0.001 on the nominal tuning seeds).

* :func:`screen_order` — the re-fly candidates (:func:`ksbo_mav.opt.recommend.refly_candidates`, ranked), those
  clear of the failures' grown exclusion balls first.
* :func:`next_flight` — the phase's next flight: the first ``refly_top`` flights screen the candidates in that
  order, one stress flight each; then the ones that passed are re-flown in turn from ordinary random starts.
* :func:`eligible` — the candidates the screen has not ruled out (it passed, or there was no flight left to screen
  it): the final choice is made among them as without the screen (:func:`ksbo_mav.opt.recommend.final_choice`);
  if none passed, among all as without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt.region import in_grown_ball

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO


def screen_order(bo: "SafeBO", cands: np.ndarray) -> np.ndarray:
    """(k,) the candidates (data indices, ranked) in screening order: those outside every failure's grown exclusion
    ball first, in rank order, then the rest. Fixed when the phase starts: a stress flight that fails grows a ball
    over its neighbours, but they answer for themselves with their own stress flight."""
    cands = np.asarray(cands, dtype=int)
    inside = in_grown_ball(bo, bo.X[cands]) if cands.size else np.zeros(0, dtype=bool)
    return np.concatenate([cands[~inside], cands[inside]])


def _failed_at(bo: "SafeBO", i: int) -> bool:
    """Whether a flight at exactly X[i] failed (it has shown it is bistable)."""
    return not bo.complete[np.all(bo.X == bo.X[i], axis=1)].all()


def next_flight(bo: "SafeBO", k: int) -> tuple[int, bool]:
    """(data index, stress?) of the k-th flight of the phase: a stress flight of the next unscreened candidate for
    the first ``refly_top`` flights, then ordinary re-flights of the candidates that passed, in turn (of the
    candidates as without the screen if none passed: :func:`ksbo_mav.opt.recommend.next_refly`)."""
    cands = [int(c) for c in bo.refly_set]
    passed = [c for c in cands if bo.stress_passed.get(c)]
    fresh = [c for c in cands if c not in bo.stress_passed and not _failed_at(bo, c)]
    if fresh and len(bo.stress_passed) < bo.adaptive.refly_top:
        return fresh[0], True
    live = [c for c in passed if not _failed_at(bo, c)] or passed
    if not live:
        from ksbo_mav.opt.recommend import next_refly  # (recommend imports this module)

        return next_refly(bo, k), False
    return live[k % len(live)], False


def record_stress(bo: "SafeBO", i: int, passed: bool) -> None:
    """Note that candidate ``i`` (data index) flew its stress flight (each candidate flies one) and whether it
    completed with P ≥ p_min."""
    bo.stress_passed[i] = passed


def eligible(bo: "SafeBO") -> list[int]:
    """Data indices of the candidates the screen has not ruled out (screening order): every candidate whose stress
    flights all passed, and those the phase had no flight left to screen (a 20-trial campaign re-flies 2 of its 3
    candidates) unless a flight at exactly their gains failed; empty when no stress flight passed."""
    if bo.refly_set is None or not any(bo.stress_passed.values()):
        return []
    cands = [int(c) for c in bo.refly_set]
    return [c for c in cands if (bo.stress_passed[c] if c in bo.stress_passed else not _failed_at(bo, c))]
