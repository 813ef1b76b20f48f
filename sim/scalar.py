"""One episode at a time, compiled with numba: the fast path for single flights and the independent
reference the vectorised :func:`ksbo_sim.episode.simulate` is tested against.

It integrates every 1 ms sub-step explicitly (no closed-form sums) and runs the PID with scalar math, so
agreement with the batched code checks both the closed-form integration and the batching.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from ksbo_sim.episode import EpisodeConfig, Rollout


@njit(cache=True)
def _episode(gains, init, refs, consts, limits, dt, n_sub):  # pragma: no cover - compiled
    N = refs.shape[0] - 1
    states = np.empty((N + 1, 6))
    inputs = np.empty((N, 2))
    L, reason = _episode_into(gains, init, refs, consts, limits, dt, n_sub, states, inputs)
    return states, inputs, L, reason


@njit(cache=True)
def _episode_into(gains, init, refs, consts, limits, dt, n_sub, states, inputs):  # pragma: no cover - compiled
    """Fly one episode writing into ``states`` (N+1, 6) and ``inputs`` (N, 2); NaN after an early stop."""
    (m, iyy, d, g, kf, pscale, pconst, pwm_min, pwm_max, tmax, ilx, ilz, ilth) = consts
    (x_max, z_min, z_max, tilt_max) = limits
    Px, Ix, Dx, Pz, Iz, Dz, Pt, It, Dt = gains
    N = refs.shape[0] - 1
    s = init.copy()
    states[0] = s
    ix = 0.0
    iz = 0.0
    ith = 0.0
    prev = 0.0
    h = dt / n_sub
    for k in range(N):
        x, vx, z, vz, th, om = s[0], s[1], s[2], s[3], s[4], s[5]
        ex = refs[k, 0] - x
        ez = refs[k, 2] - z
        ix = min(max(ix + ex * dt, -ilx), ilx)
        iz = min(max(iz + ez * dt, -ilz), ilz)
        fx = Px * ex + Ix * ix + Dx * (refs[k, 1] - vx)
        fz = Pz * ez + Iz * iz + Dz * (refs[k, 3] - vz) + m * g
        thrust = max(0.0, fx * math.sin(th) + fz * math.cos(th))
        pwm_t = (math.sqrt(thrust / (4.0 * kf)) - pconst) / pscale
        e_th = 2.0 * math.sin(th - math.atan2(fx, fz)) if fz > 0.0 else 0.0
        ith = min(max(ith - e_th * dt, -ilth), ilth)
        tau = -Pt * e_th - Dt * (th - prev) / dt + It * ith
        tau = min(max(tau, -tmax), tmax)
        prev = th
        p1 = min(max(pwm_t - 0.5 * tau, pwm_min), pwm_max)
        p2 = min(max(pwm_t + 0.5 * tau, pwm_min), pwm_max)
        r1 = pscale * p1 + pconst
        r2 = pscale * p2 + pconst
        t1 = 2.0 * kf * r1 * r1
        t2 = 2.0 * kf * r2 * r2
        inputs[k, 0] = t1
        inputs[k, 1] = t2
        total = (t1 + t2) / m
        alpha = (t2 - t1) * d / iyy
        for _ in range(n_sub):
            vx += h * math.sin(th) * total
            vz += h * (math.cos(th) * total - g)
            om += h * alpha
            x += h * vx
            z += h * vz
            th += h * om
        s[0], s[1], s[2], s[3], s[4], s[5] = x, vx, z, vz, th, om
        states[k + 1] = s
        reason = 0
        if not abs(th) <= tilt_max:
            reason = 4
        if not z <= z_max:
            reason = 3
        if not z >= z_min:
            reason = 2
        if not abs(x) <= x_max:
            reason = 1
        if reason:
            states[k + 2 :] = np.nan
            inputs[k + 1 :] = np.nan
            return k + 1, reason
    return N, 0


@njit(cache=True, parallel=True)
def _episodes(gains, init, refs, consts, limits, dt, n_sub):  # pragma: no cover - compiled
    B, N = gains.shape[0], refs.shape[0] - 1
    states = np.empty((B, N + 1, 6))
    inputs = np.empty((B, N, 2))
    L = np.empty(B, dtype=np.int64)
    reason = np.empty(B, dtype=np.int8)
    for i in prange(B):
        L[i], reason[i] = _episode_into(gains[i], init[i], refs, consts, limits, dt, n_sub, states[i], inputs[i])
    return states, inputs, L, reason


def _args(config: EpisodeConfig) -> tuple:
    c, b = config.constants, config.bounds
    consts = (c.mass, c.iyy, c.moment_arm, c.g, c.kf, c.pwm2rpm_scale, c.pwm2rpm_const, c.pwm_min, c.pwm_max,
              c.max_torque_pwm, c.pos_integral_limit_x, c.pos_integral_limit_z, c.pitch_integral_limit)
    limits = (b.x_max, b.z_min, b.z_max, math.radians(b.tilt_max_deg))
    return consts, limits


def simulate_one(gains: np.ndarray, init: np.ndarray, config: EpisodeConfig | None = None) -> Rollout:
    """Fly one episode; returns a :class:`Rollout` with batch size 1 (same layout as ``simulate``)."""
    config = config or EpisodeConfig()
    consts, limits = _args(config)
    refs = config.reference()
    states, inputs, L, reason = _episode(np.asarray(gains, dtype=float).reshape(9),
                                         np.asarray(init, dtype=float).reshape(6), refs, consts, limits,
                                         config.dt, config.n_sub)
    return Rollout(t=np.arange(refs.shape[0]) * config.dt, states=states[None], refs=refs, inputs=inputs[None],
                   L=np.array([L]), reason=np.array([reason], dtype=np.int8))


def simulate_parallel(gains: np.ndarray, init: np.ndarray, config: EpisodeConfig | None = None) -> Rollout:
    """Many episodes, each on the compiled scalar path, spread over all cores (numba ``prange``).

    Same layout as :func:`ksbo_sim.episode.simulate`; the fast backend for large batches. Chattering gains are
    chaotic, so rows can differ from the numpy path beyond round-off (see tests/test_sim_task.py).
    """
    config = config or EpisodeConfig()
    gains = np.atleast_2d(np.asarray(gains, dtype=float))
    init = np.atleast_2d(np.asarray(init, dtype=float))
    B = max(gains.shape[0], init.shape[0])
    gains = np.ascontiguousarray(np.broadcast_to(gains, (B, 9)))
    init = np.ascontiguousarray(np.broadcast_to(init, (B, 6)))
    consts, limits = _args(config)
    refs = config.reference()
    states, inputs, L, reason = _episodes(gains, init, refs, consts, limits, config.dt, config.n_sub)
    return Rollout(t=np.arange(refs.shape[0]) * config.dt, states=states, refs=refs, inputs=inputs, L=L,
                   reason=reason)
