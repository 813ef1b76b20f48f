"""The surrogate of the safe optimiser: the main GP (additive kernel of the selected orders), the optional local
SE-ARD safety GP that must certify every query as well, and the acquisition GP of the learned safety scale.

Kernel selection decides the main GP's orders (opt.models.selection); :meth:`Surrogate.switch_orders` swaps them when
the orders are re-selected during the run.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.models.safety_model import SafetyModel
from ksbo_mav.opt.models.scale import SafetyScale
from ksbo_mav.opt.observations import Observations


@dataclass
class Surrogate:
    """``model`` (main GP), ``safety_model`` (None: the main GP certifies alone), the learned ``scale`` and the
    acquisition GP it builds (``acq_model``, None: the UCB comes from the main GP)."""

    model: SafetyModel
    safety_model: SafetyModel | None = None
    scale: SafetyScale = field(default_factory=SafetyScale)
    acq_model: SafetyModel | None = field(default=None, init=False)

    @property
    def dim(self) -> int:
        return self.model.dim

    @property
    def scale_target(self) -> SafetyModel | None:
        """The SE-ARD GP whose lengthscales are the safety scale (the safety GP, or an SE-ARD main model)."""
        if self.safety_model is not None:
            return self.safety_model
        return self.model if tuple(self.model.spec.orders) == (self.model.dim,) else None

    def safety_lengthscales(self) -> np.ndarray:
        """(d,) lengthscales of the scale target (or the main GP): the failure model's and trust region's shape."""
        m = self.scale_target or self.model
        return np.broadcast_to(np.asarray(m.spec.lengthscale, dtype=float), (self.dim,)).copy()

    def fit(self, obs: Observations, learn: bool, rng: np.random.Generator) -> None:
        """Refit every GP on the GP data of ``obs``; with ``learn`` relearn the safety scale (opt.models.scale)."""
        Xc, yc = obs.gp_data()
        target = self.scale_target
        # relearn refits the scale model with its new lengthscales; a fit before that only fixes its signal and
        # noise scales (first call), so later calls skip it (an O(n^3) fit per refit).
        skip = target is not None and np.isfinite(target.signal_std) and self.scale.refits(learn, yc.size)
        for m in (self.model, self.safety_model):
            if m is not None and not (skip and m is target):
                m.fit(Xc, yc)
        if target is not None:
            self.scale.relearn(target, Xc, yc, learn, obs.p_min, rng)
        self.refresh_acquisition(obs)

    def add(self, x: np.ndarray, y: float) -> None:
        """Rank-one update of every GP with one trial x (d,), y."""
        for m in (self.model, self.safety_model, self.acq_model):
            if m is not None:
                m.add(x, y)

    def refresh_acquisition(self, obs: Observations) -> None:
        """Rebuild the acquisition GP from the GP data and the learnt scale (:meth:`SafetyScale.acquisition`)."""
        self.acq_model = self.scale.acquisition(self.model, *obs.gp_data())

    def switch_orders(self, orders: tuple[int, ...], obs: Observations) -> None:
        """Rebuild the main GP with new additive orders (scales kept) and refit it on the GP data."""
        self.model = self.model.variant(orders=tuple(orders))
        self.model.fit(*obs.gp_data())
        self.refresh_acquisition(obs)
