"""The surrogate every GP-based optimiser uses: the project's GP on the *safety margin* g = y − p_min.

Why a zero-mean GP on g rather than a standardised y: far from the data the posterior then reverts to
"on the threshold, with the full prior uncertainty", so the lower bound there is ``−β·σ_prior < 0`` and unexplored
gains are never certified safe. A GP with standardised outputs reverts to the data mean instead; after a prior
whose values are all positive that mean is positive and, when the prior's spread is small, the LCB of a never-seen
region can exceed the threshold — exactly the failure safe BO must not have (part F.8 of the fact sheet: the
prior, not the acquisition, decides safety).

The signal and noise scales are fixed from the first data unless ``optimize`` asks the GP for ML-II refits.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Sequence

import numpy as np

from ksbo_mav.gp import AdditiveKernel, GaussianProcess


@dataclass(frozen=True)
class ModelSpec:
    """Hyperparameters of the safety GP (unit-cube inputs, outputs in the objective's units).

    Attributes:
        orders: additive kernel orders; ``(d,)`` with per-dimension lengthscales is the SE-ARD kernel.
        lengthscale: scalar or (d,) base-kernel lengthscales in the unit cube.
        signal_std: prior standard deviation of g; None sets it to ``signal_scale * max |g|`` of the first data.
        signal_scale: factor of that heuristic.
        noise_std: observation noise standard deviation; None means ``noise_ratio * signal_std``.
        noise_ratio: factor of that heuristic.
        active_dims: dimensions the interaction orders use; None = all.
        dropped_in_order1: dimensions outside ``active_dims`` enter through an order-1 term (the optimiser may
            move them); False: the kernel ignores them and the optimiser must hold them at the start value.
        optimize: ML-II refit of the GP's hyperparameters whenever the model is refitted.
        order_weights: relative prior variance of each order (normalised to sum 1); None = equal.
    """

    orders: tuple[int, ...]
    lengthscale: float | tuple[float, ...] = 0.2
    signal_std: float | None = None
    signal_scale: float = 2.0
    noise_std: float | None = None
    noise_ratio: float = 0.02
    active_dims: tuple[int, ...] | None = None
    optimize: bool = False
    order_weights: tuple[float, ...] | None = None
    dropped_in_order1: bool = False

    def with_(self, **changes) -> "ModelSpec":
        """Copy with some fields changed."""
        return replace(self, **changes)


@dataclass
class SafetyModel:
    """GP posterior of the objective y, modelled as ``p_min + g`` with a zero-mean prior on g."""

    spec: ModelSpec
    dim: int
    p_min: float = 0.0
    seed: int | None = None
    signal_std: float = field(default=float("nan"), init=False)
    noise_std: float = field(default=float("nan"), init=False)
    gp: GaussianProcess | None = field(default=None, init=False)
    n: int = field(default=0, init=False)

    def _scales(self, g: np.ndarray) -> None:
        if np.isfinite(self.signal_std):
            return
        s = self.spec.signal_std
        if s is None:
            s = self.spec.signal_scale * float(np.max(np.abs(g))) if g.size else 1.0
            s = s if s > 0 else 1.0
        self.signal_std = float(s)
        n = self.spec.noise_std
        self.noise_std = float(n if n is not None else self.spec.noise_ratio * self.signal_std)

    def _kernel(self) -> AdditiveKernel:
        orders = tuple(int(r) for r in self.spec.orders)
        w = np.ones(len(orders)) if self.spec.order_weights is None else np.asarray(self.spec.order_weights, float)
        w = w / w.sum()
        ls = self.spec.lengthscale
        ls = float(ls) if np.ndim(ls) == 0 else np.asarray(ls, dtype=float)
        active = None if self.spec.active_dims is None else list(self.spec.active_dims)
        return AdditiveKernel(
            dim=self.dim,
            orders=orders,
            lengthscales=ls,
            order_variances=self.signal_std**2 * w,
            active_dims=active,
            normalize=True,
            inactive_in_order1=self.spec.dropped_in_order1,
        )

    def fit(self, X: np.ndarray, y: np.ndarray) -> "SafetyModel":
        """(Re)fit on all data: X (n, d) unit cube, y (n,) objective values."""
        g = np.asarray(y, dtype=float) - self.p_min
        self._scales(g)
        gp = GaussianProcess(
            kernel=self._kernel(),
            noise=self.noise_std**2,
            normalize_y=False,
            optimize=self.spec.optimize,
            seed=self.seed,
        )
        gp.fit(np.asarray(X, dtype=float), g)
        self.gp = gp
        self.n = len(g)
        return self

    def variant(self, **changes) -> "SafetyModel":
        """An unfitted copy whose spec has this model's signal and noise scales (fixed from its first data) and
        ``changes`` (:class:`ModelSpec` fields, ``noise_std`` included) — for GPs that must be comparable with it
        (order re-selection, the smoothing and acquisition GPs)."""
        spec = self.spec.with_(**{"signal_std": self.signal_std, "noise_std": self.noise_std, **changes})
        return SafetyModel(spec, self.dim, self.p_min, self.seed)

    def add(self, x: np.ndarray, y: float) -> None:
        """Incremental update with one observation x (d,), y."""
        assert self.gp is not None, "fit first"
        self.gp.add_observation(np.asarray(x, dtype=float), float(y) - self.p_min)
        self.n += 1

    def predict(self, Xc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean of y and marginal std of the latent f at Xc (m, d); returns two (m,) arrays."""
        assert self.gp is not None, "fit first"
        mu, sd = self.gp.predict(np.atleast_2d(Xc), return_std=True)
        return np.asarray(mu, float).reshape(-1) + self.p_min, np.asarray(sd, float).reshape(-1)


def active_mask(dim: int, active_dims: Sequence[int] | None, dropped_in_order1: bool = False) -> np.ndarray:
    """(dim,) bool mask of the dimensions the optimiser may move."""
    m = np.zeros(dim, dtype=bool)
    if active_dims is None or dropped_in_order1:
        m[:] = True
    else:
        m[list(active_dims)] = True
    return m
