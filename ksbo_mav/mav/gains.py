"""Gain service: the tuned parameters of one vehicle, trial writes inside the trust region, verified restores.

Writes go only to the profile's gains, inside the profile box *and* the trust region around the baseline, each
verified by its echo; a restore is confirmed by a fresh read of every parameter.
"""

from __future__ import annotations

import numpy as np

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.mav.params import ParamClient
from ksbo_mav.mav.stacks import GainMap
from ksbo_mav.profiles import Profile


def trust_region(profile: Profile, baseline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where trial gains may go: the profile box, at most ``max_step_fraction`` of each gain's range from the
    baseline and, with ``max_ratio`` r, inside [baseline / r, baseline * r] for positive baselines."""
    b = profile.bounds
    tr = profile.trust_region
    frac = float(tr.max_step_fraction)
    w = b[:, 1] - b[:, 0]
    lo, hi = np.maximum(b[:, 0], baseline - frac * w), np.minimum(b[:, 1], baseline + frac * w)
    if tr.max_ratio is not None:
        r = float(tr.max_ratio)
        pos = baseline > 0
        lo = np.where(pos, np.maximum(lo, baseline / r), lo)
        hi = np.where(pos, np.minimum(hi, baseline * r), hi)
    return lo, hi


def opt_bounds(profile: Profile, baseline: np.ndarray) -> np.ndarray:
    """(d, 2) the optimiser's first search box: :func:`trust_region` around ``baseline`` as [lo, hi] rows."""
    lo, hi = trust_region(profile, baseline)
    return np.column_stack([lo, hi])


def trial_limits(profile: Profile, baseline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where a trial's gains may go: the profile's box when its search box grows (``[trust_region] grow``), else
    the first box (:func:`trust_region`)."""
    if profile.trust_region.grow:
        b = profile.bounds
        return b[:, 0].copy(), b[:, 1].copy()
    return trust_region(profile, baseline)


class GainService:
    """The profile's gains on one vehicle: gain vectors (d,) in the profile's order and units are checked and
    written; ``{autopilot parameter name: value}`` dicts (a baseline, accepted gains) are written and verified.
    ``gain_map`` translates between the two."""

    def __init__(self, params: ParamClient, profile: Profile, gain_map: GainMap) -> None:
        self.params, self.profile, self.gain_map = params, profile, gain_map

    def check_trial(self, x: np.ndarray, baseline: np.ndarray) -> np.ndarray:
        """Absolute box of the profile and, unless the search box grows, the trust region around the baseline
        (:func:`trial_limits`); InputError otherwise."""
        b = self.profile.bounds
        width = b[:, 1] - b[:, 0]
        x = np.asarray(x, dtype=float)
        if x.shape == (self.profile.dim,) and np.all(np.isfinite(x)):
            # An optimiser's lower + u (upper - lower) can overshoot a bound by an ulp: that is the bound.
            tol = 1e-9 * width
            x = np.where((x > b[:, 1]) & (x <= b[:, 1] + tol), b[:, 1], x)
            x = np.where((x < b[:, 0]) & (x >= b[:, 0] - tol), b[:, 0], x)
        x = self.profile.check_gains(x)
        lo, hi = trial_limits(self.profile, baseline)
        tol = 1e-9 * width
        far = (x < lo - tol) | (x > hi + tol)
        if np.any(far):
            i = int(np.flatnonzero(far)[0])
            raise InputError(f"gain {self.profile.names[i]} = {x[i]:g} is outside the trust region "
                             f"[{lo[i]:g}, {hi[i]:g}] around the baseline {baseline[i]:g}")
        return np.clip(x, lo, hi)

    def write(self, x: np.ndarray) -> None:
        """Set-and-verify the parameters of the gain vector ``x`` (d,) (callers check bounds first)."""
        for name, value in self.gain_map.to_params(x).items():
            self.params.set_verified(name, value)

    def write_params(self, params: dict[str, float], retries: int = 3) -> None:
        """Set-and-verify ``{autopilot parameter name: value}``; InputError for a parameter that is not tuned."""
        for name, value in params.items():
            if name not in self.gain_map.param_names:
                raise InputError(f"{name} is not one of the tuned parameters; refusing to write it")
            self.params.set_verified(name, value, retries=retries)

    def restore(self, params: dict[str, float], attempts: int = 3, retries: int = 8) -> None:
        """Write ``{autopilot parameter name: value}`` (a baseline) and confirm it with a fresh read of every
        parameter; VehicleError if impossible.

        More retries than a trial write: a restore is the one write that must get through a lossy link."""
        last: Exception | None = None
        for _ in range(attempts):
            try:
                self.write_params(params, retries=retries)
                wrong = [n for n, v in params.items()
                         if not np.isclose(self.params.read(n, retries=retries), v, rtol=1e-6, atol=1e-7)]
                if not wrong:
                    return
                last = VehicleError(f"read-back differs for {', '.join(wrong)}")
            except VehicleError as exc:
                last = exc
        raise VehicleError(f"baseline NOT restored: {last}")
