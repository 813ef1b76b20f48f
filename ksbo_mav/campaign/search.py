"""Safe BO over flown trials: the optimiser asks, the trial loop flies; a resumed campaign answers the journalled
trials from the journal (:class:`~ksbo_mav.campaign.replay.JournalReplay`) and flies only new ones.

The first search runs from the baseline over the campaign's first box (:func:`search`); with the profile's
``[trust_region] grow`` the box grows within the profile's box (the autopilot's documented ranges) where the best
flights reach its edge (:mod:`ksbo_mav.opt.acquisition.growing_box`), and the moves are said on the console and kept
in result.json. A warm start (:mod:`ksbo_mav.campaign.warm_start`) runs the optimiser again from known-good gains
that it re-flies first, with what an earlier campaign knew as its prior (:func:`search_box`). Both build their
optimiser call in one place (:func:`_optimize`).
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
from ksbo_mav.opt import SAFE_GP_METHODS


def _optimize(trials: TrialLoop, cfg: Any, done: list[JournalEntry], start: np.ndarray, bounds: np.ndarray,
              prior: Any, budget: int, log: Callable[[str], None], **extra: Any) -> tuple[Any, list[JournalEntry]]:
    """The optimiser over the first box ``bounds`` (d, 2), grown within the profile's box where its
    ``[trust_region] grow`` says so, from ``start`` (d,) for ``budget`` trials with ``prior`` (X, y) or None, the
    journalled trials ``done`` replayed first; ``extra``: optimiser options over the campaign's. Returns (result,
    journalled trials a diverged replay could not use); :class:`UnsafeStartError` when ``start`` flew unsafe."""
    from ksbo_mav import optimize

    m, profile = trials.objective.mission, trials.objective.profile  # a stress start exists only with moving starts
    replay = JournalReplay(done, trials.evaluate, log, (lambda x: trials.evaluate(x, stress=True))
                           if moving_starts(m.kind, m.start_speed) else None)
    options = {**optimizer_options(prior_kind(cfg, profile), cfg.options, cfg.method, profile), **extra}
    limits = None
    if profile.trust_region.grow and cfg.method in SAFE_GP_METHODS:
        limits = np.column_stack([np.minimum(profile.bounds[:, 0], bounds[:, 0]),
                                  np.maximum(profile.bounds[:, 1], bounds[:, 1])])

    result = optimize(replay, start, bounds, prior=prior, budget=budget, method=cfg.method, seed=cfg.seed,
                      p_min=0.0, check_x0=True, limits=limits, on_grow=lambda g: log(growth_message(g, profile)),
                      **options)
    for g in (getattr(result, "info", None) or {}).get("box", {}).get("growth", []):
        g["name"] = profile.names[g["dim"]]
    return result, replay.unused


def growth_message(g: dict[str, Any], profile: Any) -> str:
    """One growth of the search box (``result.json``'s ``box.growth`` row) in words, with that gain's documented end
    on that side (the ``profile``'s box)."""
    name, limit = profile.names[g["dim"]], float(profile.bounds[g["dim"], int(g["side"] == "upper")])
    end = " (its documented end)" if np.isclose(g["new"], limit) else f" (documented end {limit:.4g})"
    return f"search box grew after trial {g['trial']}: {name} {g['side']} bound {g['old']:.4g} -> {g['new']:.4g}{end}"


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
               log: Callable[[str], None], **extra: Any) -> tuple[Any, list[JournalEntry]]:
    """A further stage: the optimiser over ``bounds`` (d, 2) from ``start`` (d,), flown first, for ``budget``
    trials with ``prior`` (X, y); ``done``: this stage's journalled trials (a resume). Returns (result, journalled
    trials a diverged replay could not use), or (None, []) when ``start`` no longer flies safe. ``extra``: optimiser
    options over the campaign's."""
    start = np.clip(np.asarray(start, dtype=float), bounds[:, 0], bounds[:, 1])
    try:
        return _optimize(trials, cfg, done, start, bounds, prior, budget, log, **extra)
    except UnsafeStartError:
        log("the start gains of this stage flew unsafe now: stage ended, the earlier recommendation stands")
        return None, []
