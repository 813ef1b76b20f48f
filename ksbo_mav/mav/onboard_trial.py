"""The tuner's side of a figure-8 flown on board by the onboard guard: start it, learn its t = 0, watch it.

A ground-streamed trial sends a setpoint every mission step; what it measures depends on the link's rate, latency
and loss. On board, the guard's script sets the targets itself (:mod:`ksbo_mav.mav.guard_script`, ``KSG_F8`` /
``KSG_T0``), so the link carries only the start, the parameter writes and the telemetry to score. The tuner still
checks every sample with the same monitor, against the same reference (the mission's, evaluated at the sample's
own stamp, the script's t = 0 being known), and the tlog holds a marker from which a replay computes that
reference again (:data:`ksbo_mav.mav.trajectory.BOARD_RE`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ksbo_mav.errors import LinkLost, VehicleError
from ksbo_mav.mav.guard_script import FIGURE8_PARAM, T0_PARAM
from ksbo_mav.mav.vehicle import Vehicle

#: ``KSG_T0`` carries the vehicle time modulo this (a float holds every integer below it exactly).
T0_MODULUS = 1 << 24
#: Wall seconds to wait for the guard to report the figure-8's start after the command (a few parameter reads).
START_WAIT_S = 10.0


def full_t0(t0_mod: float, now_ms: int) -> int:
    """The vehicle time of the figure-8's start from ``KSG_T0`` (modulo 2^24 ms) and a vehicle time ``now_ms``
    at or after it (less than 4.6 h later)."""
    return int(now_ms - ((int(now_ms) - int(t0_mod)) % T0_MODULUS))


def on_board(v: Vehicle) -> bool:
    """The vehicle's guard flies the figure-8 (installed with one)."""
    guard = v.guard
    return guard is not None and guard.config is not None and guard.config.figure8 is not None


def start(v: Vehicle) -> int:
    """Ask the armed guard to fly the figure-8 and return the vehicle time (ms) of its t = 0."""
    guard = v.guard
    v.guided.hold_at(None)  # our hold targets would fight the script's: the vehicle keeps the last one meanwhile
    guard.write(FIGURE8_PARAM, 1.0)
    deadline = time.monotonic() + START_WAIT_S
    while time.monotonic() < deadline:
        t0 = guard.read(T0_PARAM)
        if t0 >= 0:
            now = max(int(v.telemetry.clock.last_ms), int(t0))
            return full_t0(t0, now)
        v.guided.check_link()
        v.link.pump(0.05)
    raise VehicleError(f"the onboard guard did not start the figure-8 within {START_WAIT_S:g} s "
                       f"({guard.last_text() or 'no KSG STATUSTEXT'})")


def watch(v: Vehicle, t_end_ms: int, on_sample: Callable[[Any], None], log: Callable[[str], None]) -> None:
    """Feed every new LOCAL_POSITION_NED to ``on_sample`` (it may raise to abort) until one stamped at or after
    ``t_end_ms`` arrived. :class:`LinkLost` when the vehicle falls silent for the link timeout (the guard on board
    acts on its own)."""
    g, tel = v.guided, v.telemetry
    fresh: list[Any] = []
    tel.on_sample.append(fresh.append)
    try:
        while tel.clock.last_ms < t_end_ms:
            if g.lockstep:  # a lockstep simulator's time advances only when stepped (half a second at a time)
                g.wait(0.5)
            else:
                v.link.pump(0.01)
            while fresh:
                on_sample(fresh.pop(0))
            g.check_link()
            stalled = time.monotonic() - tel.clock.last_wall
            if stalled > g.heartbeat_timeout:
                raise LinkLost(f"no telemetry from the vehicle for {stalled:.1f} s")
            tel.keep_rates(log)
        while fresh:
            on_sample(fresh.pop(0))
    finally:
        tel.on_sample.remove(fresh.append)
