"""What :class:`ksbo_mav.opt.safe_bo.SafeBO` learns about its scales (issue 13): the safety GP's per-dimension
lengthscales (and optionally its noise) by marginal likelihood, and the acquisition GP built from them.

* :func:`relearn` — ML-II refit of the scale model's lengthscales on the completed trials, times the failure
  shrink factor, applied to the safety GP (and the trust region's shape).
* :func:`acquisition_model` — the main GP with each base lengthscale raised to ``ard_acquisition`` × the learnt
  safety lengthscale of its dimension (``AdaptiveConfig.ard_acquisition``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ksbo_mav.opt.failure_model import learn_scales
from ksbo_mav.opt.model import SafetyModel

if TYPE_CHECKING:
    from ksbo_mav.opt.safe_bo import SafeBO


def refits(bo: "SafeBO", learn: bool, n: int) -> bool:
    """Whether :func:`relearn` with ``learn`` on ``n`` completed trials refits its target (so an earlier fit of
    the target in the same refit is wasted once its signal and noise scales are fixed)."""
    fixed = not bo.adaptive.learn_safety_scale and bo.scale_factor < 1.0  # a shrunk fixed scale
    has_scale = bo.ml_scale is not None or (learn and n >= 2) or fixed
    return has_scale and (learn or bo.scale_factor < 1.0)


def relearn(bo: "SafeBO", target: SafetyModel, Xc: np.ndarray, yc: np.ndarray, learn: bool) -> None:
    """Refit ``target``'s lengthscales on the completed trials Xc (n, d), yc (n,) when ``learn`` (ML-II, warm
    started), then apply the learnt scale (or, never learnt, the configured one) × ``bo.scale_factor`` to it (also
    without a new fit once the factor shrank; nothing when :func:`refits` says no)."""
    if not refits(bo, learn, yc.size):
        return
    a = bo.adaptive
    if learn and yc.size >= 2:
        start = np.broadcast_to(np.asarray(target.spec.lengthscale if bo.ml_scale is None else bo.ml_scale,
                                           dtype=float), (bo.model.dim,))
        # Warm start: once a few fits exist, the previous optimum is the only start (no random restart).
        restarts = 1 if len(bo.scale_history) < 4 * a.scale_refit_every else 0
        if bo.noise_floor is None:
            bo.noise_floor = float(target.noise_std)
        noise_max = a.safety_noise_max * target.signal_std if a.safety_noise_max else None
        bo.ml_scale, target.noise_std = learn_scales(
            Xc, yc - bo.p_min, target.signal_std, bo.noise_floor, start, a.safety_scale_prior,
            a.safety_scale_bounds, bo.rng, a.scale_extent_factor, restarts, noise_max)
    base = bo.ml_scale
    if base is None:  # no ML-II fit (a fixed safety scale): shrink the configured lengthscale
        if bo.fixed_scale is None:
            bo.fixed_scale = np.broadcast_to(np.asarray(target.spec.lengthscale, float), (bo.model.dim,)).copy()
        base = bo.fixed_scale
    ls = np.maximum(np.maximum(base, a.safety_scale_floor) * bo.scale_factor, a.safety_scale_bounds[0])
    target.spec = target.spec.with_(lengthscale=tuple(float(v) for v in ls))
    target.fit(Xc, yc)
    bo.scale_history.append([float(v) for v in ls])


def acquisition_model(bo: "SafeBO") -> SafetyModel | None:
    """The UCB's GP (``ard_acquisition`` > 0, once a safety scale was learnt; else None): the main GP with each
    base lengthscale raised to ``ard_acquisition`` × the learnt safety lengthscale of its dimension, so the UCB
    stops paying for uncertainty along dimensions the data show to be flat. Safety (the LCB) stays with the main
    and safety GPs."""
    factor = bo.adaptive.ard_acquisition
    if not factor > 0 or bo.ml_scale is None:
        return None
    base = np.broadcast_to(np.asarray(bo.model.spec.lengthscale, dtype=float), (bo.model.dim,))
    ls = np.maximum(base, factor * bo.ml_scale)
    acq = bo.model.variant(lengthscale=tuple(float(v) for v in ls), optimize=False)
    return acq.fit(bo.X[bo.gp_mask], bo.y[bo.gp_mask])
