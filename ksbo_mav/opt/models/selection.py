"""ksbo's kernel selection inside the optimiser: Algorithm 1 first, then re-selection by evidence.

* :func:`select_kernel` — the paper's selection on the data available before BO: additive orders ranked by mean
  C_ree (Algorithm 1, repeated), optionally dimensions per kept order; returns a typed :class:`KernelSelection`.
* :func:`reselect_by_evidence` — on the completed trials the run gathered, rank the candidate orders by the log
  marginal likelihood of the single-order GP (same lengthscale and scales as the running model) and keep the
  ``top`` best. Run every ``reselect_every`` iterations; the result records whether the orders changed.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ksbo_mav.opt.method_config import SelectionConfig
from ksbo_mav.opt.models.safety_model import SafetyModel


@dataclass(frozen=True)
class KernelSelection:
    """Which kernel ksbo uses and why.

    Attributes:
        orders: additive orders, best first.
        dims: kept dimensions (sorted) or None = all.
        selected: False when the orders are fixed or defaults (``reason`` says why).
        method: "fixed", "default", "cree" (Algorithm 1) or "evidence" (marginal likelihood).
        scores: per candidate order, mean C_ree (lower is better) or log marginal likelihood (higher is better).
        top_frequency: per order, fraction of Algorithm-1 trials in which it ranked in the top (C_ree only).
        dims_per_order: kept dimensions of each order (dimension selection only).
        at_iteration: BO iteration of a re-selection (0 for the first selection).
        changed: a re-selection changed the orders.
    """

    orders: tuple[int, ...]
    dims: tuple[int, ...] | None = None
    selected: bool = False
    method: str = "fixed"
    reason: str = ""
    scores: dict[int, float] = field(default_factory=dict)
    top_frequency: dict[int, float] = field(default_factory=dict)
    dims_per_order: dict[int, list[int]] = field(default_factory=dict)
    at_iteration: int = 0
    changed: bool = False

    @property
    def cree(self) -> dict[int, float]:
        """Mean C_ree per order (empty unless ``method == "cree"``)."""
        return self.scores if self.method == "cree" else {}

    def as_dict(self) -> dict[str, Any]:
        """Plain dict for JSON records (``cree`` included for Algorithm-1 selections)."""
        d = asdict(self)
        d["orders"], d["cree"] = list(self.orders), self.cree
        return d


def select_kernel(X: np.ndarray, y: np.ndarray, opts: SelectionConfig, lengthscale: float,
                  seed: int | None) -> KernelSelection:
    """Kernel selection on X (n, d) unit cube, y (n,): fixed ``opts.orders``, defaults below ``min_select``
    observations, else Algorithm 1 over orders 1..``max_order`` (C_ree with the GP's base ``lengthscale``)."""
    d = X.shape[1]
    if opts.orders is not None:
        return KernelSelection(tuple(int(r) for r in opts.orders), method="fixed", reason="orders given")
    if len(y) < opts.min_select:
        return KernelSelection(tuple(opts.default_orders), method="default",
                               reason=f"{len(y)} observations < min_select={opts.min_select}")
    from ksbo_mav.select import select_dimensions, select_orders

    top_order = d if opts.max_order is None else max(1, min(d, int(opts.max_order)))
    sel = select_orders(X, y, orders=range(1, top_order + 1), trials=opts.trials, top=min(opts.top, top_order),
                        seed=seed, lengthscales=lengthscale)
    orders = tuple(int(r) for r in sel.orders)[: opts.top]
    dims, per_order = None, {}
    if opts.dims != "all":
        for r in orders:
            per_order[int(r)] = [int(i) for i in select_dimensions(X, y, r, method=opts.dims, seed=seed).dims]
        kept = sorted({i for v in per_order.values() for i in v})
        if len(kept) >= max(orders):  # every kept order needs at least `order` dimensions
            dims = tuple(kept)
    return KernelSelection(orders, dims, True, "cree", scores={int(r): float(v) for r, v in sel.mean.items()},
                           top_frequency={int(r): float(v) for r, v in sel.top_frequency.items()},
                           dims_per_order=per_order)


def evidence(model: SafetyModel, X: np.ndarray, y: np.ndarray, orders: tuple[int, ...]) -> dict[int, float]:
    """Log marginal likelihood of each single order r (the running model's spec, signal and noise) on X, y."""
    out = {}
    for r in orders:
        m = model.variant(orders=(int(r),), order_weights=None)
        m.fit(X, y)
        out[int(r)] = float(m.gp.log_marginal_likelihood_value_)
    return out


def reselect_by_evidence(model: SafetyModel, X: np.ndarray, y: np.ndarray, opts: SelectionConfig,
                         iteration: int) -> KernelSelection:
    """The ``top`` orders among 1..``max_order`` by evidence on the completed data X (n, d), y (n,)."""
    d = model.dim
    top_order = d if opts.max_order is None else max(1, min(d, int(opts.max_order)))
    lml = evidence(model, X, y, tuple(range(1, top_order + 1)))
    orders = tuple(sorted(lml, key=lml.get, reverse=True)[: opts.top])
    changed = set(orders) != set(int(r) for r in model.spec.orders)
    return KernelSelection(orders, model.spec.active_dims, True, "evidence", scores=lml, at_iteration=iteration,
                           changed=changed)

