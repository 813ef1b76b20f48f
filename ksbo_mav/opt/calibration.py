"""How well the safety bound has held so far: the β each past query would have needed, and a β calibrated on it.

A query x_i was proposed with the models' (capped) means μ_m(x_i) and stds σ_m(x_i) *before* its flight; once its
value y_i is known, the smallest β under which every model's bound still held is

    b_i = max_m (μ_m(x_i) − y_i) / σ_m(x_i)          (b_i ≤ β ⇔ the LCB at β did not overstate y_i)

These one-step-ahead scores are the honest check of the bound where it matters — at the points the acquisition
picked, near the edge of the certified set, on this plant — not on the (clustered, interpolated) training data.
With ``beta_min`` set, :meth:`BetaCalibration.beta` certifies with ``margin × quantile(b)`` once ``min_points``
scores exist (β itself before) — or ``margin ×`` the largest of the last ``window`` scores if that is larger —
clipped to [``beta_min``, ``beta_cap``]: a model that keeps predicting well earns a narrower margin; a flight that
came in far below its prediction widens it for the next ``window`` queries. Why the window: in strict-mode ksbo on
the nominal planar plant, P < 0 flights came in bursts (three within four queries in 2 of 10 tuning runs); the
window cut them 21 → 18 with the floor at 4 and 15 → 12 with the floor at β 5 (``beta_min`` = β; BENCHMARKS.md,
issue 13, item S).
Off by default: with ``beta_min`` 4, ksbo re-flew a little better and flew more P < 0 trials.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.config import SafeBOConfig


@dataclass
class BetaCalibration:
    """One-step-ahead calibration scores of the safety bound and the β they support.

    Attributes:
        beta_max: the configured β (used until ``min_points`` scores exist).
        beta_min: lower clip of the calibrated β (at most ``beta_max``: ``beta_min`` = β keeps β as the floor and
            only widens it after a bad flight); None = calibration off, :meth:`beta` is ``beta_max``.
        quantile: quantile of the scores b_i the calibrated β rests on.
        margin: factor on that quantile (and on the recent maximum).
        min_points: scores needed before the quantile is used.
        window: the largest of the last this many scores is a floor (0 = none).
        beta_cap: upper clip (at least ``beta_max``); None = ``beta_max``.
    """

    # The defaults are SafeBOConfig's (one place holds each value; SafeBO passes its config's).
    beta_max: float
    beta_min: float | None = SafeBOConfig.beta_min
    quantile: float = SafeBOConfig.beta_quantile
    margin: float = SafeBOConfig.beta_margin
    min_points: int = SafeBOConfig.beta_min_points
    window: int = SafeBOConfig.beta_window
    beta_cap: float | None = SafeBOConfig.beta_cap
    scores: list[float] = field(default_factory=list)
    _pending: tuple[np.ndarray, np.ndarray, np.ndarray] | None = field(default=None, repr=False)

    def predicted(self, x: np.ndarray, mu: np.ndarray, sd: np.ndarray) -> None:
        """Remember the models' capped means and stds, (k,) each, at the query x (d,) before it is flown."""
        self._pending = (np.asarray(x, float).copy(), np.asarray(mu, float), np.asarray(sd, float))

    def observed(self, x: np.ndarray, y: float) -> None:
        """Score the pending prediction if x is its query (re-flights and fallbacks are not predictions)."""
        if self._pending is None:
            return
        px, mu, sd = self._pending
        self._pending = None
        if not np.array_equal(px, np.asarray(x, float)) or not np.isfinite(y):
            return
        ok = sd > 0
        if ok.any():
            self.scores.append(float(np.max((mu[ok] - y) / sd[ok])))

    def beta(self) -> float:
        """The β to certify with now."""
        if self.beta_min is None:
            return self.beta_max
        s = self.scores
        b = self.margin * float(np.quantile(s, self.quantile)) if len(s) >= self.min_points else self.beta_max
        if self.window > 0 and s:
            b = max(b, self.margin * max(s[-self.window:]))
        return float(np.clip(b, min(self.beta_min, self.beta_max), max(self.beta_max, self.beta_cap or 0.0)))
