"""Additive Gaussian-process kernels of any set of interaction orders (Duvenaud et al., NeurIPS 2011).

Base kernel of dimension ``i``: ``z_i(x, x') = exp(-(x_i - x'_i)**2 / (2 l_i**2))`` (squared exponential, unit
variance). The kernel is a sum of *terms*, each an interaction order ``r`` over a set of dimensions ``A``::

    k(x, x') = sum_terms  s_t**2 * e_r(z_A(x, x')) / C(|A|, r)        (the division only when normalize=True)

where ``e_r`` is the elementary symmetric polynomial (:mod:`ksbo_mav.gp.symmetric`; never subset enumeration).
With ``normalize=True`` every term has prior variance ``s_t**2`` on the diagonal.

Dimension subsets and dropped dimensions
----------------------------------------
``active_dims`` restricts the interaction orders to a subset of dimensions: one sequence for every order, or a
mapping ``order -> dims`` (the paper rebuilds each selected order from its own important base kernels). A
dimension used by no order is *dropped*:

* ``inactive_in_order1=True`` (default): dropped dimensions still enter additively. If order 1 is among the
  orders, its term is extended to include them; otherwise an extra order-1 term over the dropped dimensions is
  appended, with variance ``inactive_variance``. The GP can then still learn (and the optimiser still move)
  those gains, without letting them interact.
* ``inactive_in_order1=False``: dropped dimensions are ignored (the GP is constant along them); the optimiser must
  hold them fixed, e.g. at the safe start gains.

Hyperparameters (``theta``, all in log space, the order used by fitting and gradients): the log lengthscales
(one if ``lengthscales`` was a scalar, i.e. shared, else one per dimension), then the log variance of each term.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from math import comb
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ksbo_mav.errors import InputError
from ksbo_mav.gp.symmetric import METHODS, Method, elementary_symmetric, esp_from_power_sums, esp_without_one
from ksbo_mav.gp.terms import Term, resolve_terms, term_variances

#: Rows of X1 per block in :meth:`AdditiveKernel.__call__` (keeps the work arrays in cache).
_BLOCK_ELEMENTS = 1 << 14


class AdditiveKernel:
    """Sum of additive-kernel orders with per-dimension SE base kernels and one variance per term.

    Args:
        dim: number of input dimensions ``D`` (inputs live in the unit cube ``[0, 1]**D``).
        orders: interaction orders to include, e.g. ``(2, 3, 4)`` or ``(1, 9)``.
        lengthscales: scalar (one shared lengthscale, fitted as one hyperparameter) or ``(D,)`` per dimension.
        order_variances: ``None`` (every term ``1 / n_terms``, so ``k(x, x) = 1`` when normalised), a sequence
            aligned with ``orders``, or a mapping ``order -> variance``.
        active_dims: ``None`` (all dimensions), a sequence of dimension indices used by every order, or a mapping
            ``order -> dims``.
        normalize: divide order ``r`` over ``|A|`` dimensions by ``C(|A|, r)``.
        inactive_in_order1: how dropped dimensions are treated (see the module docstring).
        inactive_variance: variance of the extra order-1 term over dropped dimensions (default: as a default term).
        method: ``"newton-girard"`` or ``"recursive"`` evaluation of the symmetric polynomials.
        lengthscale_bounds: ``(low, high)`` for fitting.
        variance_bounds: ``(low, high)`` for fitting.
    """

    def __init__(
        self,
        dim: int,
        orders: Sequence[int] = (1,),
        lengthscales: float | ArrayLike = 0.2,
        order_variances: ArrayLike | Mapping[int, float] | None = None,
        active_dims: Sequence[int] | Mapping[int, Sequence[int]] | None = None,
        normalize: bool = True,
        inactive_in_order1: bool = True,
        inactive_variance: float | None = None,
        method: Method = "newton-girard",
        lengthscale_bounds: tuple[float, float] = (0.01, 10.0),
        variance_bounds: tuple[float, float] = (1e-3, 1e3),
    ) -> None:
        self.dim = dim
        self.orders = orders
        self.lengthscales = lengthscales
        self.order_variances = order_variances
        self.active_dims = active_dims
        self.normalize = normalize
        self.inactive_in_order1 = inactive_in_order1
        self.inactive_variance = inactive_variance
        self.method = method
        self.lengthscale_bounds = lengthscale_bounds
        self.variance_bounds = variance_bounds
        self._resolve()

    # ------------------------------------------------------------------ structure
    def _resolve(self) -> None:
        """Validate the arguments and derive terms, lengthscale and variance arrays (cheap)."""
        if not isinstance(self.dim, (int, np.integer)) or isinstance(self.dim, bool) or self.dim < 1:
            raise InputError(f"dim must be a positive integer, got {self.dim!r}")
        D = int(self.dim)
        if self.method not in METHODS:
            raise InputError(f"unknown method {self.method!r}; expected one of {', '.join(METHODS)}")
        orders, terms, dropped, extra = resolve_terms(D, self.orders, self.active_dims, self.inactive_in_order1)
        variances = term_variances(orders, len(terms), extra, self.order_variances, self.inactive_variance)

        ls = np.asarray(self.lengthscales, dtype=float)
        if ls.ndim == 0:
            shared = True
            ls = np.full(D, float(ls))
        elif ls.shape == (D,):
            shared = False
        else:
            raise InputError(f"lengthscales must be a scalar or have shape ({D},), got {ls.shape}")
        if not np.all(np.isfinite(ls)) or np.any(ls <= 0):
            raise InputError("lengthscales must be positive and finite")

        self.terms_: tuple[Term, ...] = tuple(terms)
        self.variances_: NDArray[np.float64] = variances
        self.lengthscales_: NDArray[np.float64] = ls
        self.shared_lengthscale_: bool = shared
        self.dropped_dims_: tuple[int, ...] = dropped
        # Group terms by dimension set so each set's polynomials are computed once.
        groups: dict[tuple[int, ...], list[int]] = {}
        for t, term in enumerate(terms):
            groups.setdefault(term.dims, []).append(t)
        self._groups = groups

    def _weight(self, t: int) -> float:
        term = self.terms_[t]
        w = float(self.variances_[t])
        if self.normalize:
            w /= comb(len(term.dims), term.order)
        return w

    # ------------------------------------------------------------------ parameters
    def get_params(self) -> dict[str, Any]:
        """Constructor arguments (scikit-learn style)."""
        keys = ("dim", "orders", "lengthscales", "order_variances", "active_dims", "normalize",
                "inactive_in_order1", "inactive_variance", "method", "lengthscale_bounds", "variance_bounds")
        return {k: getattr(self, k) for k in keys}

    def clone(self, **changes: Any) -> "AdditiveKernel":
        """A new kernel with the same arguments except ``changes``."""
        return AdditiveKernel(**{**self.get_params(), **changes})

    @property
    def n_lengthscale_params(self) -> int:
        return 1 if self.shared_lengthscale_ else self.dim

    @property
    def theta(self) -> NDArray[np.float64]:
        """``(p,)`` log-hyperparameters: log lengthscale(s), then log term variances."""
        ls = self.lengthscales_[:1] if self.shared_lengthscale_ else self.lengthscales_
        return np.concatenate([np.log(ls), np.log(self.variances_)])

    @property
    def theta_bounds(self) -> NDArray[np.float64]:
        """``(p, 2)`` bounds of :attr:`theta` (log space)."""
        lb = np.log(np.asarray(self.lengthscale_bounds, dtype=float))
        vb = np.log(np.asarray(self.variance_bounds, dtype=float))
        return np.vstack([np.tile(lb, (self.n_lengthscale_params, 1)), np.tile(vb, (len(self.terms_), 1))])

    def with_theta(self, theta: ArrayLike) -> "AdditiveKernel":
        """A copy with log-hyperparameters ``theta`` (shape ``(p,)``), as in :attr:`theta`."""
        theta = np.asarray(theta, dtype=float)
        m = self.n_lengthscale_params
        if theta.shape != (m + len(self.terms_),):
            raise InputError(f"theta must have shape ({m + len(self.terms_)},), got {theta.shape}")
        ls: float | NDArray[np.float64] = float(np.exp(theta[0])) if self.shared_lengthscale_ else np.exp(theta[:m])
        var = np.exp(theta[m:])
        n_ord = len(np.atleast_1d(np.asarray(self.orders)))
        inactive = float(var[n_ord]) if len(var) > n_ord else self.inactive_variance
        return self.clone(lengthscales=ls, order_variances=var[:n_ord], inactive_variance=inactive)

    # ------------------------------------------------------------------ evaluation
    def _check_X(self, X: ArrayLike, name: str) -> NDArray[np.float64]:
        X = np.asarray(X, dtype=float)
        if X.ndim == 1 and self.dim == X.shape[0]:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != self.dim:
            raise InputError(f"{name} must have shape (n, {self.dim}), got {X.shape}")
        return X

    def __call__(self, X1: ArrayLike, X2: ArrayLike | None = None) -> NDArray[np.float64]:
        """Kernel matrix.

        Args:
            X1: ``(n1, D)`` points.
            X2: ``(n2, D)`` points (default ``X1``).

        Returns:
            ``(n1, n2)`` matrix ``k(X1[a], X2[b])``.
        """
        X1 = self._check_X(X1, "X1")
        X2 = X1 if X2 is None else self._check_X(X2, "X2")
        n1, n2 = X1.shape[0], X2.shape[0]
        out = np.zeros((n1, n2))
        block = max(1, _BLOCK_ELEMENTS // max(n2, 1))
        for a in range(0, n1, block):
            self._block(X1[a:a + block], X2, out[a:a + block])
        return out

    def _block(self, X1: NDArray[np.float64], X2: NDArray[np.float64], out: NDArray[np.float64]) -> None:
        """Add the kernel of one row block into ``out`` (``(b, n2)``), one dimension at a time."""
        shape = (X1.shape[0], X2.shape[0])
        c = 0.5 / self.lengthscales_**2
        z = np.empty(shape)
        zk = np.empty(shape)
        for dims, idx in self._groups.items():
            R = max(self.terms_[t].order for t in idx)
            acc = np.zeros((R + 1,) + shape)
            if self.method == "recursive":
                acc[0] = 1.0
            for n, i in enumerate(dims):
                np.subtract.outer(X1[:, i], X2[:, i], out=z)
                np.square(z, out=z)
                z *= -c[i]
                np.exp(z, out=z)
                if self.method == "newton-girard":
                    acc[1] += z
                    for k in range(2, R + 1):
                        np.multiply(zk if k > 2 else z, z, out=zk)
                        acc[k] += zk
                else:
                    for r in range(min(n + 1, R), 0, -1):
                        np.multiply(z, acc[r - 1], out=zk)
                        acc[r] += zk
            e = esp_from_power_sums(acc) if self.method == "newton-girard" else acc
            for t in idx:
                out += self._weight(t) * e[self.terms_[t].order]

    def diag(self, X: ArrayLike) -> NDArray[np.float64]:
        """``(n,)`` prior variances ``k(x, x)`` for ``X`` of shape ``(n, D)``."""
        X = self._check_X(X, "X")
        total = sum(self._weight(t) * comb(len(term.dims), term.order) for t, term in enumerate(self.terms_))
        return np.full(X.shape[0], float(total))

    def value_and_gradient(self, X: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Kernel matrix of ``X`` with itself and its gradient with respect to :attr:`theta`.

        Args:
            X: ``(n, D)`` points.

        Returns:
            ``K`` of shape ``(n, n)`` and ``dK`` of shape ``(p, n, n)`` with ``dK[j] = dK / d theta[j]``.
        """
        X = self._check_X(X, "X")
        n = X.shape[0]
        m = self.n_lengthscale_params
        ls = self.lengthscales_
        d2 = (X[:, None, :] - X[None, :, :]) ** 2  # (n, n, D)
        s = np.moveaxis(d2 / ls**2, -1, 0)  # (D, n, n): d log z_i / d log l_i
        zall = np.exp(-0.5 * s)
        K = np.zeros((n, n))
        dK = np.zeros((m + len(self.terms_), n, n))
        for dims, idx in self._groups.items():
            R = max(self.terms_[t].order for t in idx)
            z = zall[list(dims)]
            e = elementary_symmetric(z, R, self.method)
            for t in idx:
                Kt = self._weight(t) * e[self.terms_[t].order]
                K += Kt
                dK[m + t] = Kt  # d/d log variance
            for a, i in enumerate(dims):
                f = esp_without_one(e, z[a], R - 1)
                G = sum(self._weight(t) * f[self.terms_[t].order - 1] for t in idx)
                dKi = G * z[a] * s[i]
                dK[0 if self.shared_lengthscale_ else i] += dKi
        return K, dK

    def __repr__(self) -> str:
        terms = ", ".join(f"r{t.order}{list(t.dims) if len(t.dims) < self.dim else ''}:{v:.3g}"
                          for t, v in zip(self.terms_, self.variances_))
        ls = (f"{self.lengthscales_[0]:.3g}" if self.shared_lengthscale_
              else "[" + ", ".join(f"{v:.3g}" for v in self.lengthscales_) + "]")
        return f"AdditiveKernel(dim={self.dim}, terms=[{terms}], lengthscales={ls}, normalize={self.normalize})"
