"""Safe BO over flown trials: the optimiser asks, the trial loop flies; a resumed campaign answers the journalled
trials from the journal (:class:`~ksbo_mav.campaign.replay.JournalReplay`) and flies only new ones.

The first search runs from the baseline over the campaign's box (:func:`search`). A further stage runs the
optimiser again over a (possibly wider) box, started from known-good gains that it re-flies first, with what the
campaign already knows as its prior (:func:`search_box`): a widened search box (:mod:`ksbo_mav.campaign.widen`)
and a warm start from a finished campaign (:mod:`ksbo_mav.campaign.warm_start`). Both build their optimiser call
in one place (:func:`_optimize`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ksbo_mav.campaign.config import CampaignConfig, optimizer_options, prior_kind, stop_options
from ksbo_mav.campaign.journal import JournalEntry
from ksbo_mav.campaign.replay import JournalReplay
from ksbo_mav.campaign.search_end import search_end
from ksbo_mav.campaign.trials import TrialLoop
from ksbo_mav.errors import UnsafeStartError, VehicleError
from ksbo_mav.mav.approach import moving_starts

#: A point of the campaign's data joins a stage along some gains (``dims``) as prior when its other gains lie within
#: this fraction of the box's width of the start's.
NEAR = 0.1


def _optimize(trials: TrialLoop, cfg: Any, done: list[JournalEntry], start: np.ndarray, bounds: np.ndarray,
              prior: Any, budget: int, log: Callable[[str], None], dims: list[int] | None = None, **extra: Any
              ) -> tuple[Any, list[JournalEntry]]:
    """The optimiser over ``bounds`` (d, 2) from ``start`` (d,) for ``budget`` trials with ``prior`` (X, y) or
    None, the journalled trials ``done`` replayed first; ``dims``: along these gains only (see :func:`search_box`);
    ``extra``: optimiser options over the campaign's. Returns (result, journalled trials a diverged replay could
    not use); :class:`UnsafeStartError` when ``start`` flew unsafe."""
    from types import SimpleNamespace

    from ksbo_mav import optimize

    m, profile = trials.objective.mission, trials.objective.profile  # a stress start exists only with moving starts
    replay = JournalReplay(done, trials.evaluate, log, (lambda x: trials.evaluate(x, stress=True))
                           if moving_starts(m.kind, m.start_speed) else None)
    options = {**optimizer_options(prior_kind(cfg, profile), cfg.options, cfg.method, profile), **extra}
    fun: Any = replay
    if dims is not None:
        fun = _Embedded(replay, start, dims)
        prior = _along(prior, start, bounds, dims)
        start, bounds = start[dims], bounds[dims]
    result = optimize(fun, start, bounds, prior=prior, budget=budget, method=cfg.method, seed=cfg.seed,
                      p_min=0.0, check_x0=True, **options)
    if dims is not None:
        result = SimpleNamespace(x=fun.embed(np.asarray(result.x)), fun=result.fun, orders=None)
    return result, replay.unused


def search(trials: TrialLoop, cfg: CampaignConfig, x0: np.ndarray, bounds: np.ndarray, prior: Any,
           resume: bool, log: Callable[[str], None]) -> tuple[Any, list[JournalEntry]]:
    """Run the optimiser over ``bounds`` (d, 2) from ``x0`` (d,) with the ``prior`` (X, y) or None, with the
    stopping rule where the settings turn it on (said on the console when it stops the search). Returns its
    result and the journalled trials a diverged replay could not use."""
    done = trials.journal.of("opt")
    if resume and len(done) > 1:
        log(f"resume: replaying {len(done)} journalled trial(s) through the optimiser (nothing re-flown)")
    try:
        result, unused = _optimize(trials, cfg, done, x0, bounds, prior, cfg.budget, log,
                                   **stop_options(cfg, trials.objective.profile))
    except UnsafeStartError:
        raise VehicleError(f"the baseline gains flew unsafe (P = {done[0].P:.3f} < 0): safe BO needs a safe "
                           "start; fix the gains or the mission/safety settings first (baseline restored)"
                           ) from None
    end = search_end((getattr(result, "info", None) or {}).get("stop"), trials.journal.of("opt")[0], cfg.confirm)
    if end is not None and end["stopped"]:
        log(end["text"])
    return result, unused


def search_box(trials: TrialLoop, cfg: Any, start: np.ndarray, bounds: np.ndarray,
               prior: tuple[np.ndarray, np.ndarray], done: list[JournalEntry], budget: int,
               log: Callable[[str], None], dims: list[int] | None = None, **extra: Any
               ) -> tuple[Any, list[JournalEntry]]:
    """A further stage: the optimiser over ``bounds`` (d, 2) from ``start`` (d,), flown first, for ``budget``
    trials with ``prior`` (X, y); ``done``: this stage's journalled trials (a resume). ``dims``: search along these
    gains only, the others held at ``start`` (the prior: the points near ``start`` in the others). Returns (result,
    journalled trials a diverged replay could not use), or (None, []) when ``start`` no longer flies safe.
    ``extra``: optimiser options over the campaign's."""
    start = np.clip(np.asarray(start, dtype=float), bounds[:, 0], bounds[:, 1])
    try:
        return _optimize(trials, cfg, done, start, bounds, prior, budget, log, dims, **extra)
    except UnsafeStartError:
        log("the start gains of this stage flew unsafe now: stage ended, the earlier recommendation stands")
        return None, []


class _Embedded:
    """``fun`` of a search along ``dims`` only: the other gains stay at ``start``'s values."""

    def __init__(self, fun: Any, start: np.ndarray, dims: list[int]) -> None:
        self.fun, self.start, self.dims = fun, start, dims
        if hasattr(fun, "stress"):
            self.stress = lambda z: fun.stress(self.embed(z))

    def embed(self, z: np.ndarray) -> np.ndarray:
        x = self.start.copy()
        x[self.dims] = z
        return x

    def __call__(self, z: np.ndarray) -> Any:
        return self.fun(self.embed(z))


def _along(prior: tuple[np.ndarray, np.ndarray], start: np.ndarray, bounds: np.ndarray, dims: list[int]
           ) -> tuple[np.ndarray, np.ndarray]:
    """The prior points near ``start`` in every gain but ``dims``, as points of the search along ``dims``."""
    X, y = prior
    other = [i for i in range(len(start)) if i not in dims]
    width = bounds[:, 1] - bounds[:, 0]
    near = np.all(np.abs(X[:, other] - start[other]) <= NEAR * width[other], axis=1)
    inside = np.all((X[:, dims] >= bounds[dims, 0]) & (X[:, dims] <= bounds[dims, 1]), axis=1)
    keep = near & inside
    return X[keep][:, dims], y[keep]
