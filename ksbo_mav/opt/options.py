"""Method options: the settings a user or a benchmark sets (:data:`OPTIONS`, each with one default, one line of
documentation and a declared constraint), the method presets, and their validation in one place.

:class:`Options` is the composition of the typed configs of :mod:`ksbo_mav.opt.method_config`, which hold every field's
one default — the user options and the internal knobs the presets set (e.g. the candidate counts' refinement,
the trust region's growth). ``optimize(**options)`` and ``tune --option`` accept the names in :data:`OPTIONS`.
Why each preset value was chosen, with the measurements: benchmarks/notes/.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Mapping

from ksbo_mav.errors import InputError
from ksbo_mav.opt.method_config import (AdaptiveConfig, BaselineConfig, ModelConfig, SafeBOConfig, SelectionConfig,
                                 part)
from ksbo_mav.opt.constraints import BOOL, Choice, Constraint, Interval, Orders, violation

_POS = Interval(0.0, None, open_low=True)
_POS_OR_NONE = Interval(0.0, None, open_low=True, none=True)
_COUNT = Interval(0, None, integer=True)
_SHRINK = Interval(0.0, 1.0, open_low=True)

#: name -> (constraint, one line of documentation). The defaults are Options()'s, per method :func:`options_for`.
OPTIONS: dict[str, tuple[Constraint, str]] = {
    "beta": (_POS, "safety multiplier: a point is certified safe when mu - beta*sigma >= p_min"),
    "beta_ucb": (_POS_OR_NONE, "exploration multiplier of the UCB acquisition (null: beta)"),
    "rule": (Choice(("ucb", "safeopt")), "acquisition: boundary expansion then safe UCB, or SafeOpt's rule"),
    "expansion_iters": (_COUNT, "BO iterations of boundary expansion first (at most a tenth of the budget)"),
    "exploit_last": (_COUNT, "the last this many evaluations maximise the posterior mean (at most a fifth)"),
    "y_max": (Interval(none=True), "known upper bound of the objective (clips the posterior mean; null: none)"),
    "explore_from": (Choice(("x0", "all")), "candidates grow from the start (x0) or from every observation (all)"),
    "exclusion_radius": (Interval(0.0, 0.5), "no certified query within this distance (unit cube) of a bad trial"),
    "recommend_noise": (_POS_OR_NONE, "noise of the recommendation's smoothing GP, x signal std (null: none)"),
    "n_local": (Interval(1, None, integer=True), "local Gaussian candidates per iteration"),
    "n_global": (_COUNT, "global Sobol candidates per iteration (explore_from=all)"),
    "lengthscale": (_POS, "base lengthscale of the main GP (unit cube)"),
    "signal_std": (_POS_OR_NONE, "prior signal std of P (null: 2 x |P(x0) - p_min|)"),
    "noise_std": (_POS_OR_NONE, "observation noise std of P (null: 0.02 x signal std)"),
    "safety_kernel": (Choice(("se", "same")), "a local SE-ARD GP certifies every query too (se), or not (same)"),
    "safety_lengthscale": (_POS, "lengthscale of the local SE-ARD safety GP (unit cube)"),
    "orders": (Orders(), "fixed additive kernel orders; null: selected by Algorithm 1 (C_ree)"),
    "max_order": (Interval(1, None, integer=True, none=True), "highest additive order considered (null: d)"),
    "top": (Interval(1, None, integer=True), "orders kept by the kernel selection"),
    "trials": (Interval(1, None, integer=True), "repetitions of the Nystrom C_ree estimate per order"),
    "select_at": (_COUNT, "select the orders again by C_ree after this many iterations (0: never)"),
    "dims": (Choice(("all", "forest", "permutation")), "important dimensions: all, or by a random forest"),
    "dropped": (Choice(("fixed", "order1")), "unselected dimensions stay at x0 (fixed) or enter with order 1"),
    "censor_aborts": (BOOL, "aborted and crashed trials feed the failure model, never the GPs as values"),
    "learn_safety_scale": (BOOL, "learn the safety GP's per-dimension lengthscales by marginal likelihood"),
    "trust_region": (BOOL, "keep candidates in a box around the incumbent that follows the outcomes"),
    "tr_success": (Interval(1, None, integer=True), "the trust region doubles after this many new incumbents"),
    "max_aborts": (Interval(0, None, integer=True, none=True), "end the run after this many failed trials"),
    "backup_beta": (_POS_OR_NONE, "beta under which the backup may cover an uncertified trial (null: never)"),
    "refly_last": (_COUNT, "the last this many evaluations re-fly the best candidates (at most a tenth)"),
    "refly_top": (Interval(1, None, integer=True), "candidates of the re-fly phase"),
    "refly_stress": (BOOL, "screen each re-fly candidate once from the objective's hardest start"),
    "reselect_every": (_COUNT, "re-select the additive orders by evidence every this many iterations (0: never)"),
    "failure_scale_shrink": (_SHRINK, "shrink the safety scale by this after a failed trial at new gains"),
    "unsafe_scale_shrink": (_SHRINK, "shrink the safety scale by this after a P < p_min trial at new gains"),
    "unconstrained_refit": (Interval(1, None, integer=True), "ucb/ei baselines: refit the GP every this many"),
}


@dataclass(frozen=True)
class Options(BaselineConfig, SelectionConfig, ModelConfig, AdaptiveConfig, SafeBOConfig):
    """Every setting of the optimisers (unit-cube units): the composition of the typed configs, which hold each
    field's one default. ``part(opts, SafeBOConfig)`` extracts one of them."""

    def update(self, overrides: Mapping[str, Any]) -> "Options":
        """Copy with the user's ``overrides`` (names of :data:`OPTIONS`); an unknown name or a value outside its
        constraint raises :class:`InputError`, one line naming it (unknown names: with the list of options)."""
        bad = sorted(set(overrides) - set(OPTIONS))
        if bad:
            raise InputError(f"unknown option(s) {', '.join(bad)}; the options are:\n{options_listing()}")
        for name, value in overrides.items():
            problem = violation(name, value, OPTIONS[name][0])
            if problem:
                raise InputError(problem)
        return replace(self, **{k: _normalise(OPTIONS[k][0], v) for k, v in overrides.items()})


def _normalise(constraint: Constraint, v: Any) -> Any:
    """A checked value in the field's type: lists as tuples, whole numbers of an integer option as int."""
    if isinstance(v, list):
        return tuple(int(r) for r in v) if isinstance(constraint, Orders) else tuple(v)
    if isinstance(constraint, Interval) and constraint.integer and v is not None:
        return int(v)
    return v


def options_listing() -> str:
    """One line per option: name, what it accepts, what it does (the ``tune --option`` error listing)."""
    width = max(map(len, OPTIONS))
    return "\n".join(f"  {n:<{width}}  {c.describe()}: {doc}" for n, (c, doc) in OPTIONS.items())


#: The adaptive settings of method ``ksbo-adaptive`` (tuned on the nominal planar plant, tuning seeds 100+;
#: benchmarks/notes/plants.md): the learned safety scale, trust region, abort budget, re-fly phase with a stress
#: screen, order re-selection every 10 iterations, growing exclusion balls, the scale shrink after a failure and
#: the acquisition GP stretched along flat dimensions.
ADAPTIVE: dict[str, Any] = {
    "censor_aborts": True, "learn_safety_scale": True, "trust_region": True, "max_aborts": 10, "refly_last": 9,
    "refly_top": 3, "reselect_every": 10, "exclusion_growth": 2.0, "failure_scale_shrink": 0.7,
    "ard_acquisition": 2.0, "refly_stress": True,
}

#: Presets per method, applied before the user's options. ``ksbo``: orders among 1..4 (on the clustered data of a
#: safe start C_ree ranks 9 > 8 > 7 and those near-SE kernels explore slowly), β 5, evidence re-selection every 10
#: iterations, a local safety lengthscale of 0.06 shrunk ×0.7 after each failure or P < 0 flight at new gains.
METHOD_DEFAULTS: dict[str, dict[str, Any]] = {
    "ksbo": {"max_order": 4, "beta": 5.0, "reselect_every": 10, "safety_lengthscale": 0.06, "unsafe_scale_shrink": 0.7,
             "failure_scale_shrink": 0.7},
    "ksbo-adaptive": {"max_order": 4, "beta": 5.0, **ADAPTIVE},
    "standard": {},
    "safeopt": {"rule": "safeopt", "lengthscale": 0.07},
    "linebo": {"lengthscale": 0.07},
    "ucb": {"beta": 2.0},
    "ei": {},
    "random": {},
}


def options_for(method: str, overrides: Mapping[str, Any] | None = None) -> Options:
    """Options of ``method``: its preset, then the user's ``overrides`` (checked against :data:`OPTIONS`)."""
    return replace(Options(), **METHOD_DEFAULTS.get(method, {})).update(overrides or {})


def options_markdown() -> str:
    """docs/options.md: every option with its default per method, what it accepts and what it does."""
    base = Options()
    methods = ("ksbo-adaptive", "ksbo")
    rows = ["| option | default | ksbo-adaptive | ksbo | accepts | what it does |", "|---|---|---|---|---|---|"]
    for name, (c, doc) in OPTIONS.items():
        per = [getattr(options_for(m), name) for m in methods]
        cells = [_md(getattr(base, name))] + [_md(v) if v != getattr(base, name) else "" for v in per]
        rows.append(f"| `{name}` | " + " | ".join(cells) + f" | {c.describe()} | {doc} |")
    return "\n".join(rows)


def _md(v: Any) -> str:
    return {True: "true", False: "false", None: "null"}.get(v, str(v)) if isinstance(v, (bool, type(None))) \
        else (", ".join(map(str, v)) if isinstance(v, tuple) else str(v))


__all__ = ["ADAPTIVE", "METHOD_DEFAULTS", "OPTIONS", "Options", "options_for", "options_listing", "part"]
