"""The stopping rule: end the search once one more evaluation cannot be expected to pay for itself.

After every evaluation the optimiser's next proposal x is judged by what evaluating it can still gain. The model
gives two estimates, and the rule takes the smaller:

* the proposal's expected improvement over the incumbent,
  ``EI(x) = E[max(f(x) − μ*, 0)] = (μ − μ*) Φ(z) + σ φ(z)``, ``z = (μ − μ*) / σ``, with μ, σ the main GP's
  posterior mean and latent std at x and μ* the largest posterior mean among the points evaluated so far that
  completed safely (prior points are not candidates: they were never flown);
* what the last evaluation gained: how far μ* rose since the previous check (the incumbent's progress).

EI alone never says stop while the search explores: a proposal outside the certified set (the backup's
exploration) sits where the GP knows little (σ 0.8 of a signal std of 1 on a copter campaign), so its EI stayed
at 0.19–0.26 in P while the flights there gained 0.001 (benchmarks/notes/short-campaign.md). The progress of the
incumbent is the model's judgement of what flights are paying now; the first check has only EI. The search stops
when the gain stays below ``ratio`` × the objective's re-flight noise for ``patience`` evaluations in a row, once
``min_evals`` evaluations (the start included) are done: a gain smaller than the scatter of one re-flight of the
same gains is one that a flight could not even show. A fallback proposal (no new point certified, a flown one
re-flown) never counts towards stopping, nor does the check right after a growing search box moved
(opt.acquisition.growing_box): it moved because the best flights reached its edge, the evidence that the optimum
lies outward, and what the incumbent gained inside the old box says nothing about the room just opened (on
ArduCopter SITL in wind the default campaigns stopped at the first box's corner, 80 % of the oracle's cut, the
trial after their box grew; benchmarks/notes/smooth-gains.md). The caller's budget stays the ceiling.

The noise is ``noise`` when the caller measured it (e.g. from repeated flights of the same gains), else the model's
own noise std (the scatter it assumes for a single evaluation).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError
from ksbo_mav.opt.acquisition.rules import Posterior
from ksbo_mav.opt.observations import Observations


@dataclass(frozen=True)
class StopCheck:
    """One check: after ``after`` evaluations the next proposal (``kind``) could gain ``gain`` against the
    threshold ``threshold`` (``ratio`` × ``noise``), all in the objective's units; ``box_grew``: the search box
    moved with the last evaluation."""

    after: int
    kind: str
    gain: float
    noise: float
    threshold: float
    box_grew: bool = False

    @property
    def below(self) -> bool:
        """The gain is below the threshold, and the proposal is a new point in a box that did not just move: a
        fallback (nothing new certified yet; the re-flight is what lets the safe set grow) and the check after the
        box grew never count towards stopping."""
        return self.gain < self.threshold and self.kind != "fallback" and not self.box_grew


def incumbent_mean(post: Posterior, obs: Observations) -> float | None:
    """μ*: the largest posterior mean among the evaluated (not prior) points that completed safely; None if none."""
    flown = (np.arange(obs.n) >= obs.n_prior) & obs.safe_complete()
    return float(np.max(post.bounds(obs.X[flown])[0])) if flown.any() else None


def expected_gain(post: Posterior, obs: Observations, x: np.ndarray) -> float:
    """Expected improvement of evaluating ``x`` (d,) over μ* (:func:`incumbent_mean`; inf when there is no
    incumbent: nothing to compare with, so nothing says stop)."""
    best = incumbent_mean(post, obs)
    if best is None:
        return math.inf
    mu, sd = (float(v[0]) for v in post.bounds(np.asarray(x, dtype=float)[None, :])[:2])
    if sd <= 0.0:
        return max(mu - best, 0.0)
    z = (mu - best) / sd
    cdf = 0.5 * (1.0 + math.erf(z / math.sqrt(2.0)))
    pdf = math.exp(-0.5 * z * z) / math.sqrt(2.0 * math.pi)
    return (mu - best) * cdf + sd * pdf


@dataclass
class StoppingRule:
    """Stop once the next proposal's gain is below ``ratio`` × noise for ``patience`` evaluations in a row, after at
    least ``min_evals`` evaluations; ``noise`` None: the model's noise std. ``checks``: every check made."""

    ratio: float = 1.0
    noise: float | None = None
    patience: int = 1
    min_evals: int = 4
    checks: list[StopCheck] = field(default_factory=list)
    stopped: bool = False
    incumbent: float | None = None  # μ* at the previous check

    def __post_init__(self) -> None:
        self.min_evals, self.patience = int(self.min_evals), int(self.patience)  # a table's 5.0 counts as 5

    def should_stop(self, post: Any, obs: Observations, x: np.ndarray, kind: str, n_evals: int,
                    model_noise: float, box_grew: bool = False) -> bool:
        """Check the proposal ``x`` (d,) of kind ``kind`` after ``n_evals`` evaluations; ``model_noise``: the
        model's noise std (used when no measured noise was given); ``box_grew``: the search box moved with the
        last evaluation. True: stop the search here."""
        noise = float(self.noise if self.noise is not None else model_noise)
        best = incumbent_mean(post, obs)
        gain = float(expected_gain(post, obs, x))
        if self.incumbent is not None and best is not None:
            gain = min(gain, max(best - self.incumbent, 0.0))
        self.incumbent = best
        check = StopCheck(n_evals, kind, gain, noise, self.ratio * noise, box_grew)
        self.checks.append(check)
        run = 0
        for c in reversed(self.checks):
            if not c.below:
                break
            run += 1
        self.stopped = n_evals >= self.min_evals and run >= self.patience
        return self.stopped

    def summary(self, budget: int) -> dict[str, Any]:
        """JSON-ready: the rule's settings, every check, whether it stopped and the evaluations it left unspent."""
        last = self.checks[-1] if self.checks else None
        return {"ratio": self.ratio, "patience": self.patience, "min_evals": self.min_evals,
                "measured_noise": self.noise is not None, "stopped": self.stopped,
                "after": last.after if last is not None else None, "budget": budget,
                "saved": budget - last.after if self.stopped and last is not None else 0,
                "checks": [{k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                            for k, v in asdict(c).items()} for c in self.checks]}


def rule_from(table: dict[str, Any]) -> StoppingRule:
    """The rule of a settings table {min_evals, patience, ratio, noise} (keys left out keep their defaults);
    InputError, one line, naming a bad key or value."""
    bad = sorted(set(table) - {"min_evals", "patience", "ratio", "noise"})
    if bad:
        raise InputError(f"early_stop: unknown key(s) {', '.join(bad)} (known: min_evals, patience, ratio, noise)")
    for k in ("min_evals", "patience"):
        v = table.get(k, 1)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not float(v).is_integer() or v < 1:
            raise InputError(f"early_stop: {k} must be an integer >= 1, got {v!r}")
    for k in ("ratio", "noise"):
        v = table.get(k, 1.0)
        if (v is not None or k == "ratio") and (isinstance(v, bool) or not isinstance(v, (int, float))
                                                or not math.isfinite(v) or v <= 0):
            raise InputError(f"early_stop: {k} must be a number > 0{' or null' if k == 'noise' else ''}, got {v!r}")
    return StoppingRule(**table)
