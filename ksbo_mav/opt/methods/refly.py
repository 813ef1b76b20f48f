"""The re-fly phase: the last evaluations re-fly the best candidates, and the recommendation is the candidate that
held up, not the luckiest single flight.

* :meth:`ReflyPhase.pick_candidates` — the ``top`` best distinct completed safe points by the recommendation's
  criterion, plus the best single flight (the smoothing pulls a lone point at the edge of the data towards p_min).
* With a stress screen (``stress``, where the objective has ``fun.stress``): each candidate first flies once from
  the objective's hardest start, and only those that pass are re-flown and can be recommended. Bistable gains
  complete from most starts and fail from a few; on the planar task the failing starts are the ones against the
  path, and one flight from there flags most of them and no robust gains.
* :meth:`ReflyPhase.final_choice` — the candidate with the best mean over all its flights; once any trial failed,
  the best expected score under the failure model among the candidates, the model's choice and the best point
  clear of failures (opt.methods.recommend).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ksbo_mav.opt.acquisition.certificate import Certificate
from ksbo_mav.opt.methods.phases import PHASE_SHARE
from ksbo_mav.opt.methods.recommend import best_expected, clear_choice
from ksbo_mav.opt.observations import Observations

#: The smoothed criterion at the data, computed when needed: () -> (n,) values.
Criterion = Callable[[], np.ndarray]


@dataclass
class ReflyPhase:
    """The last ``last`` evaluations (at most a tenth of ``budget``) re-fly the ``top`` best candidates.

    State: ``chosen`` (k,) data indices of the candidates, fixed when the phase starts; ``stress_passed``: the
    stress screen's verdict per screened candidate."""

    last: int = 0
    top: int = 3
    stress: bool = False
    budget: int = 0
    chosen: np.ndarray | None = field(default=None, init=False)
    stress_passed: dict[int, bool] = field(default_factory=dict, init=False)

    def count(self) -> int:
        """Evaluations of the phase."""
        return min(self.last, self.budget // PHASE_SHARE) if self.budget > 0 else self.last

    def pick_candidates(self, crit: np.ndarray, obs: Observations, cert: Certificate) -> np.ndarray:
        """(k,) data indices of the ``top`` best distinct completed safe points by ``crit`` (n,), the best single
        flight among them."""
        ok = obs.safe_complete()
        if not ok.any():
            ok = obs.complete
        order = [int(i) for i in np.argsort(-np.where(ok, crit, -np.inf)) if ok[i]]
        fine = ok & cert.unlikely_to_abort(obs)
        if fine.any() and self.top > 1:
            best = int(np.argmax(np.where(fine, obs.y, -np.inf)))
            order = order[: self.top - 1] + [best] + order[self.top - 1 :]
        chosen: list[int] = []
        for i in order:
            if not any(np.array_equal(obs.X[i], obs.X[j]) for j in chosen):
                chosen.append(i)
            if len(chosen) == self.top:
                break
        return np.asarray(chosen, dtype=int)

    def start(self, crit: np.ndarray, obs: Observations, cert: Certificate) -> None:
        """Fix the candidates; with the stress screen, those clear of the failures' grown balls are screened first
        (a stress flight that fails grows a ball over its neighbours, but they answer with their own flight)."""
        cands = self.pick_candidates(crit, obs, cert)
        if self.stress:
            inside = cert.exclusion.in_grown_ball(obs, obs.X[cands]) if cands.size else np.zeros(0, dtype=bool)
            cands = np.concatenate([cands[~inside], cands[inside]])
        self.chosen = cands

    def next_flight(self, k: int, crit: Criterion, obs: Observations, cert: Certificate) -> tuple[int, bool]:
        """(data index, stress?) of the k-th flight of the phase. With the screen: a stress flight of the next
        unscreened candidate for the first ``top`` flights, then the candidates that passed in turn."""
        if self.stress:
            cands = [int(c) for c in self.chosen]
            passed = [c for c in cands if self.stress_passed.get(c)]
            fresh = [c for c in cands if c not in self.stress_passed and not _failed_at(obs, c)]
            if fresh and len(self.stress_passed) < self.top:
                return fresh[0], True
            live = [c for c in passed if not _failed_at(obs, c)] or passed
            if live:
                return live[k % len(live)], False
        return self._next_refly(k, crit, obs, cert), False

    def _next_refly(self, k: int, crit: Criterion, obs: Observations, cert: Certificate) -> int:
        """The candidates in turn, skipping any that failed at exactly its gains (it has shown it is bistable) or
        lies inside a failure's grown ball; once none is left, the best point clear of failures, if any."""
        cert.update_failures(obs)
        alive = [int(c) for c in self.chosen if not _failed_at(obs, int(c))]
        if alive:
            alive = [c for c, out in zip(alive, cert.exclusion.in_grown_ball(obs, obs.X[alive])) if not out]
        if not alive:
            clear = clear_choice(crit(), obs, cert)
            if clear is None:
                alive = [int(c) for c in self.chosen]
            else:  # it joins the candidates (reported as re-flown; the final choice weighs it like them)
                alive = [clear]
                if clear not in self.chosen:
                    self.chosen = np.append(self.chosen, clear)
        return alive[k % len(alive)]

    def record_stress(self, i: int, passed: bool) -> None:
        """Candidate ``i`` (data index) flew its stress flight and completed with P ≥ p_min (``passed``) or not."""
        self.stress_passed[i] = passed

    def eligible(self, obs: Observations) -> list[int]:
        """Candidates the screen has not ruled out: every one whose stress flight passed, and those the phase had
        no flight left to screen unless a flight at exactly their gains failed; empty when none passed."""
        if self.chosen is None or not any(self.stress_passed.values()):
            return []
        return [int(c) for c in self.chosen
                if (self.stress_passed[int(c)] if int(c) in self.stress_passed else not _failed_at(obs, int(c)))]

    def final_choice(self, model_choice: int, crit: Criterion, obs: Observations, cert: Certificate) -> int:
        """Data index of the recommendation given the model's own choice ``model_choice``: among the screened
        candidates if any passed, else among the re-flown ones (with, once a trial failed, the model's choice and
        the best point clear of failures), by expected score; ``model_choice`` without a re-fly phase."""
        failed = cert.update_failures(obs)
        passed = self.eligible(obs)
        if passed:
            return best_expected(obs, cert, np.asarray(passed))
        if self.chosen is None or len(self.chosen) == 0:
            return model_choice
        pool = np.asarray(self.chosen, dtype=int)
        if failed:
            clear = clear_choice(crit(), obs, cert)
            pool = np.append(pool, [model_choice] + ([clear] if clear is not None else []))
        return best_expected(obs, cert, pool)


def _failed_at(obs: Observations, i: int) -> bool:
    """Whether a flight at exactly X[i] failed (it has shown it is bistable)."""
    return not obs.complete[obs.at(obs.X[i])].all()
