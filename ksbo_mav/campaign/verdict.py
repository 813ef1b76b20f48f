"""The verdict of the validation flights: per manoeuvre, did a gain set fly it better than the baseline, no
measurably differently, or worse?

The rule. Each manoeuvre has one figure that decides (:data:`DECIDING`, lower is better: a hold's RMS drift, a
mission's cross-track RMS, the steps' settling time); the other figures are shown beside it. The baseline's
completed flights ``a`` and the candidate's ``b`` were flown alternately (A B A B ...), so a slow drift of the
vehicle or the wind moves both alike. The repeats' spread is the larger of the two ranges, ``max(max a - min a,
max b - min b)``, but never less than :data:`RESOLUTION` of the baseline's mean (a deterministic simulator
repeats a manoeuvre to the millimetre: a 0.1 % difference there is not a change a pilot can feel). With
``d = mean b - mean a``: ``d > spread`` is "worse", ``d < -spread`` is "better", anything between is "no
measurable change". A candidate the monitor aborted on a manoeuvre the baseline completed every time is "worse"
there (and the reverse "better"); fewer than two completed flights of either is "not measured".
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Sequence

import numpy as np

from ksbo_mav.mav.validation.manoeuvre_spec import HEADLINE

#: The figure that decides each manoeuvre's verdict (lower is better; the manoeuvre's headline figure): a hold's
#: RMS drift, a mission's cross-track RMS, the steps' mean settling time. The others are shown, not judged.
DECIDING = HEADLINE
#: The figure that decides instead when the headline one is missing from a flight (steps that did not settle
#: within the dwell have no settling time; their overshoot still compares).
FALLBACK = {"steps": "overshoot_pct_mean"}
#: The smallest difference called measurable, as a fraction of the baseline's mean.
RESOLUTION = 0.02
#: Completed flights of each gain set a verdict needs.
MIN_FLIGHTS = 2

BETTER, SAME, WORSE, UNMEASURED = "better", "no measurable change", "worse", "not measured"


@dataclass(frozen=True)
class Judgement:
    """One manoeuvre's verdict. ``base``/``cand``: the deciding figure of each completed flight; ``spread``: the
    repeats' spread (with the resolution floor); ``diff``: mean cand - mean base (None when not measured)."""

    verdict: str
    base: tuple[float, ...]
    cand: tuple[float, ...]
    spread: float | None
    diff: float | None
    base_aborted: int = 0
    cand_aborted: int = 0
    metric: str = ""  # the figure judged

    def line(self, manoeuvre: str) -> str:
        """"hold: worse (hold_rms_m 0.21 -> 0.35, spread 0.03)"."""
        if not self.base or not self.cand:
            figures = ""
        else:
            figures = (f" ({self.metric} {np.mean(self.base):.3g} -> {np.mean(self.cand):.3g}"
                       + (f", spread {self.spread:.2g}" if self.spread is not None else "") + ")")
        aborts = "".join(f", {n} {who} flight(s) aborted" for n, who in ((self.base_aborted, "baseline"),
                                                                          (self.cand_aborted, "candidate")) if n)
        return f"{manoeuvre}: {self.verdict}{figures}{aborts}"


def judge(base: Sequence[float], cand: Sequence[float], base_aborted: int = 0, cand_aborted: int = 0) -> Judgement:
    """The verdict on one manoeuvre from the deciding figure of the completed flights of the baseline (``base``)
    and of the candidate (``cand``), and how many flights of each the monitor aborted (module docstring)."""
    a = tuple(float(x) for x in base if x is not None and np.isfinite(x))
    b = tuple(float(x) for x in cand if x is not None and np.isfinite(x))
    if cand_aborted and not base_aborted and len(a) >= 1:
        return Judgement(WORSE, a, b, None, None, base_aborted, cand_aborted)
    if base_aborted and not cand_aborted and len(b) >= 1:
        return Judgement(BETTER, a, b, None, None, base_aborted, cand_aborted)
    if len(a) < MIN_FLIGHTS or len(b) < MIN_FLIGHTS:
        return Judgement(UNMEASURED, a, b, None, None, base_aborted, cand_aborted)
    spread = max(max(a) - min(a), max(b) - min(b), RESOLUTION * abs(float(np.mean(a))))
    diff = float(np.mean(b) - np.mean(a))
    verdict = WORSE if diff > spread else BETTER if diff < -spread else SAME
    return Judgement(verdict, a, b, spread, diff, base_aborted, cand_aborted)


def worst(verdicts: Sequence[str]) -> str:
    """The overall word for a gain set: "worse" if any manoeuvre is worse, else "better" if any is better, else
    "no measurable change" (or "not measured" when none was)."""
    if WORSE in verdicts:
        return WORSE
    if BETTER in verdicts:
        return BETTER
    return SAME if SAME in verdicts else UNMEASURED


@dataclass(frozen=True)
class PairVerdict:
    """A gain set against the baseline on every manoeuvre flown (``pair``: "recommendation" or "trial N")."""

    pair: str
    x: tuple[float, ...] | None
    judged: dict[str, Judgement]

    @property
    def overall(self) -> str:
        return worst([j.verdict for j in self.judged.values()])

    @property
    def worse_on(self) -> list[str]:
        return [m for m, j in self.judged.items() if j.verdict == WORSE]

    def lines(self) -> list[str]:
        return [j.line(m) for m, j in self.judged.items()]

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly: the pair, its overall word, and per manoeuvre the verdict, the figure judged, the
        figures of both sides, the spread and the difference of the means."""
        return {"pair": self.pair, "overall": self.overall, "x": None if self.x is None else list(self.x),
                "manoeuvres": {m: {"verdict": j.verdict, "metric": j.metric, "baseline": list(j.base),
                                   "candidate": list(j.cand), "spread": j.spread, "diff": j.diff,
                                   "baseline_aborted": j.base_aborted, "candidate_aborted": j.cand_aborted}
                               for m, j in self.judged.items()}}


def judge_pairs(entries: Sequence[Any]) -> list[PairVerdict]:
    """Every comparison in a validation journal's ``entries``
    (:class:`~ksbo_mav.campaign.validation_log.ValidationEntry`), in the order flown, each manoeuvre judged by
    :func:`judge` on its :data:`DECIDING` figure."""
    out = []
    for pair in dict.fromkeys(e.pair for e in entries):
        mine = [e for e in entries if e.pair == pair and e.counted]
        judged = {}
        for m in dict.fromkeys(e.manoeuvre for e in mine):
            sets = [[e for e in mine if e.manoeuvre == m and (e.gains == "baseline") == base] for base in (True, False)]
            ok = [e for s in sets for e in s if e.outcome == "ok"]
            metric = DECIDING.get(m, "")
            if m in FALLBACK and any(metric not in e.metrics for e in ok):
                metric = FALLBACK[m]
            figures = [[e.metrics.get(metric) for e in s if e.outcome == "ok"] for s in sets]
            j = judge(figures[0], figures[1], *(sum(e.outcome != "ok" for e in s) for s in sets))
            judged[m] = replace(j, metric=metric)
        x = next((e.x for e in mine if e.gains != "baseline"), None)
        out.append(PairVerdict(pair, x, judged))
    return out


def best_not_worse(verdicts: Sequence[PairVerdict]) -> PairVerdict | None:
    """The first comparison (the recommendation, then the further candidates in the campaign's order) that is
    worse on no manoeuvre and was measured on at least one; None when every one flown is worse somewhere."""
    for v in verdicts:
        if not v.worse_on and any(j.verdict != UNMEASURED for j in v.judged.values()):
            return v
    return None


def refusal(verdicts: Sequence[PairVerdict]) -> str | None:
    """One line when the recommendation flew worse than the baseline on a manoeuvre beyond the repeats' spread
    (naming the best candidate worse nowhere, if one was flown); None otherwise."""
    rec = next((p for p in verdicts if p.pair == "recommendation"), None)
    if rec is None or not rec.worse_on:
        return None
    why = "; ".join(line for line in rec.lines() if line.split(":")[1].strip().startswith(WORSE))
    best = best_not_worse(verdicts)
    alt = (f"; best candidate worse nowhere: {best.pair}" if best is not None
           else "; no candidate flown is worse nowhere")
    return f"the recommendation flew worse than the baseline in the validation flights ({why}){alt}"
