"""The learned safety scale: the safety GP's per-dimension lengthscales by marginal likelihood, shrunk where
certified trials failed, and the acquisition GP stretched along the dimensions they show to be flat.

A fixed safety lengthscale is either too cautious for a smooth gain or too bold for a cliff; learning it per
dimension lets the certified set grow fast along flat gains. Each failure at new gains that the scale certified
is evidence it claimed too much smoothness, so the scale shrinks (``failure_shrink``, ``unsafe_shrink``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ksbo_mav.opt.models.failure_model import learn_scales
from ksbo_mav.opt.models.safety_model import SafetyModel


@dataclass
class SafetyScale:
    """Learns and applies the safety GP's lengthscales.

    Attributes:
        learn: fit them by ML-II (log-normal ``prior`` (median, log-sd), ``bounds``) every ``refit_every``
            evaluations (every one for the first ``4 × refit_every``); at most ``extent_factor`` × the data's
            extent along each dimension.
        failure_shrink, unsafe_shrink: factor applied to the scale after a trial at new gains that failed /
            completed below p_min (1 = off).
        ard_acquisition: > 0: the UCB's GP takes each base lengthscale raised to this × the learnt safety
            lengthscale (:meth:`acquisition`); 0 = the main GP's UCB.
        ml, fixed: (d,) last ML-II lengthscales / the configured ones once they shrank. factor: the shrink so far.
        history: every applied (d,) scale. noise_floor: the target's noise std before the first fit.
    """

    learn: bool = False
    prior: tuple[float, float] = (0.1, 1.0)
    bounds: tuple[float, float] = (0.01, 1.0)
    refit_every: int = 5
    extent_factor: float = 2.0
    failure_shrink: float = 1.0
    unsafe_shrink: float = 1.0
    ard_acquisition: float = 0.0
    ml: np.ndarray | None = field(default=None, init=False)
    fixed: np.ndarray | None = field(default=None, init=False)
    factor: float = field(default=1.0, init=False)
    history: list[list[float]] = field(default_factory=list, init=False)
    noise_floor: float | None = field(default=None, init=False)

    def start(self, target: SafetyModel) -> None:
        """Before the first fit the learnt scale starts at its lower bound: small steps first."""
        if self.learn:
            target.spec = target.spec.with_(lengthscale=float(self.bounds[0]))

    def learn_now(self, iteration: int, n: int) -> bool:
        """Relearn after BO iteration ``iteration`` with ``n`` trials? The ML-II interval grows with the data
        (every 5 up to 100 trials, 10 at 200): a fit costs O(n^3) while one more trial moves the optimum less."""
        every = max(self.refit_every, n // 20) if self.refit_every > 0 else 0
        return self.learn and every > 0 and (iteration <= 4 * self.refit_every or iteration % every == 0)

    def shrink(self, completed: bool, unsafe: bool, novel: bool) -> bool:
        """Shrink after a trial at ``novel`` gains that failed (or completed ``unsafe``); True if it shrank."""
        f = self.failure_shrink if not completed else self.unsafe_shrink if unsafe else 1.0
        if novel and f < 1.0:
            self.factor *= f
            return True
        return False

    def refits(self, learn: bool, n: int) -> bool:
        """Whether :meth:`relearn` with ``learn`` on ``n`` completed trials refits its target (so an earlier fit of
        the target in the same refit is wasted once its signal and noise scales are fixed)."""
        shrunk_fixed = not self.learn and self.factor < 1.0
        has_scale = self.ml is not None or (learn and n >= 2) or shrunk_fixed
        return has_scale and (learn or self.factor < 1.0)

    def relearn(self, target: SafetyModel, Xc: np.ndarray, yc: np.ndarray, learn: bool, p_min: float,
                rng: np.random.Generator) -> None:
        """Refit ``target``'s lengthscales on the completed trials Xc (n, d), yc (n,) when ``learn`` (ML-II, warm
        started), then apply the learnt scale (or, never learnt, the configured one) × :attr:`factor` to it (also
        without a new fit once the factor shrank; nothing when :meth:`refits` says no)."""
        if not self.refits(learn, yc.size):
            return
        d = target.dim
        if learn and yc.size >= 2:
            start = np.broadcast_to(np.asarray(target.spec.lengthscale if self.ml is None else self.ml,
                                               dtype=float), (d,))
            # Warm start: once a few fits exist, the previous optimum is the only start (no random restart).
            restarts = 1 if len(self.history) < 4 * self.refit_every else 0
            if self.noise_floor is None:
                self.noise_floor = float(target.noise_std)
            self.ml, target.noise_std = learn_scales(Xc, yc - p_min, target.signal_std, self.noise_floor, start,
                                                     self.prior, self.bounds, rng, self.extent_factor, restarts)
        base = self.ml
        if base is None:  # no ML-II fit (a fixed safety scale): shrink the configured lengthscale
            if self.fixed is None:
                self.fixed = np.broadcast_to(np.asarray(target.spec.lengthscale, float), (d,)).copy()
            base = self.fixed
        ls = np.maximum(base * self.factor, self.bounds[0])
        target.spec = target.spec.with_(lengthscale=tuple(float(v) for v in ls))
        target.fit(Xc, yc)
        self.history.append([float(v) for v in ls])

    def acquisition(self, model: SafetyModel, Xc: np.ndarray, yc: np.ndarray) -> SafetyModel | None:
        """The UCB's GP fitted on Xc (n, d), yc (n,) (``ard_acquisition`` > 0, once a scale was learnt; else None):
        ``model`` with each base lengthscale raised to ``ard_acquisition`` × the learnt safety lengthscale, so the
        UCB stops paying for uncertainty along dimensions the data show to be flat. Safety stays with the LCB."""
        if not self.ard_acquisition > 0 or self.ml is None:
            return None
        base = np.broadcast_to(np.asarray(model.spec.lengthscale, dtype=float), (model.dim,))
        ls = np.maximum(base, self.ard_acquisition * self.ml)
        return model.variant(lengthscale=tuple(float(v) for v in ls), optimize=False).fit(Xc, yc)
