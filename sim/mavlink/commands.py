"""COMMAND_LONG / SET_MODE handling: every COMMAND_LONG gets a COMMAND_ACK.

Simulator-only commands (documented in ``ksbo_sim.mavlink``):

* MAV_CMD_USER_1 (31010) set state: p1..p3 NED position (NaN = keep), p4..p6 NED velocity. Armed only;
  places the vehicle in the air and zeroes its controller (how a test starts a figure-8 at the origin with a
  given initial velocity, exactly as ``ksbo_sim.simulate`` does).
* MAV_CMD_USER_2 (31011) lockstep step: advance simulated time by p1 seconds, then ACK (lockstep only).
* MAV_CMD_USER_3 (31012) reset: disarmed vehicle back on the ground at home, crash state cleared.

MAV_CMD_SCRIPTING (42701) p1 = 3 restarts the (simulated) scripts: :mod:`ksbo_sim.mavlink.guard`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ksbo_sim.mavlink.flight import SEV_WARNING
from ksbo_sim.mavlink.guard import CMD_SCRIPTING, SCRIPTING_RESTART
from ksbo_sim.mavlink.personality import Mode
from ksbo_sim.mavlink.telemetry import AUTOPILOT_VERSION, ON_REQUEST

ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = 0, 1, 2, 3, 4
CMD_RTL, CMD_LAND, CMD_TAKEOFF, CMD_DO_SET_MODE, CMD_ARM = 20, 21, 22, 176, 400
CMD_SET_INTERVAL, CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPS = 511, 512, 520
CMD_SIM_SET_STATE, CMD_SIM_STEP, CMD_SIM_RESET = 31010, 31011, 31012
FORCE_MAGIC = (21196, 2989)  # MAVLink force flag; MAVProxy's "arm throttle force" sends ArduPilot's 2989
MAX_STEP_S = 3600.0


class Commands:
    """COMMAND_LONG handling of a :class:`ksbo_sim.mavlink.server.Server` (which owns this object)."""

    def __init__(self, server: Any) -> None:
        self.s = server

    def _refuse(self, result: int, reason: str | None) -> int:
        if reason:
            self.s.telemetry.statustext(SEV_WARNING, reason)
        return result

    def handle(self, msg) -> None:
        """Execute a COMMAND_LONG and acknowledge it (the ACK goes out before any message it triggers)."""
        s, f, c = self.s, self.s.flight, msg.command
        p = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        after = None
        if c == CMD_ARM:
            if p[0] == 1:
                reason = f.arm()
            else:
                reason = f.disarm(force=int(round(p[1])) in FORCE_MAGIC)
            result = self._refuse(DENIED, reason) if reason else ACCEPTED
        elif c == CMD_TAKEOFF:
            result, reason = f.takeoff(p[6])
            self._refuse(result, reason)
        elif c == CMD_LAND:
            f.set_mode(Mode.LAND)
            result = ACCEPTED
        elif c == CMD_DO_SET_MODE:
            mode = s.personality.mode_from_command(p[1], p[2])
            if mode is None:
                result = self._refuse(DENIED, f"Mode: unknown mode {p[1]:g}/{p[2]:g}")
            elif mode is Mode.AUTO and (f.landed or not f.mission_legs()):
                result = self._refuse(DENIED, "Mode change to AUTO failed: no mission to fly" if not f.landed
                                      else "Mode change to AUTO failed: on the ground")
            elif mode is Mode.AUTO and s.now_us * 1e-6 - s.mission.stored_at < s.personality.mission_check_s:
                result = self._refuse(TEMPORARILY_REJECTED, "Mission: still checking the new mission")
            else:
                f.set_mode(mode)
                result = ACCEPTED
        elif c == CMD_SET_INTERVAL:
            ok = s.telemetry.set_interval(int(p[0]), p[1])
            result = ACCEPTED if ok else self._refuse(DENIED, f"Interval: message {p[0]:g} not streamed")
        elif c in (CMD_REQUEST_MESSAGE, CMD_REQUEST_CAPS):
            mid = AUTOPILOT_VERSION if c == CMD_REQUEST_CAPS else int(p[0])
            known = mid in ON_REQUEST or mid in s.telemetry.intervals
            result = ACCEPTED if known else self._refuse(DENIED, f"Request: message {mid} unknown")
            if known:
                after = mid
        elif c == CMD_SIM_SET_STATE:
            reason = f.teleport(np.array(p[0:3], float), np.array(p[3:6], float))
            result = self._refuse(DENIED, reason) if reason else ACCEPTED
        elif c == CMD_SIM_RESET:
            if f.armed and not f.landed:
                result = self._refuse(DENIED, "Reset: vehicle is flying")
            else:
                f.reset_home()
                result = ACCEPTED
        elif c == CMD_SIM_STEP:
            if not s.lockstep:
                result = self._refuse(DENIED, "Step: simulator is not in lockstep")
            elif not (0 < p[0] <= MAX_STEP_S):
                result = self._refuse(DENIED, f"Step: seconds must be in (0, {MAX_STEP_S:g}]")
            else:
                s.advance(max(1, math.ceil(p[0] / f.model.ctrl_dt - 1e-9)))
                result = ACCEPTED
        elif c == CMD_SCRIPTING and int(p[0]) == SCRIPTING_RESTART:
            s.guard.restart()
            result = ACCEPTED
        else:
            result = UNSUPPORTED
        s.mav.command_ack_send(c, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())
        if after is not None:
            s.telemetry.send(after, s.now_us)

    def set_mode(self, msg) -> None:
        """SET_MODE (unacknowledged): custom_mode in this personality's numbering."""
        mode = self.s.personality.decode_mode(msg.custom_mode)
        if mode is not None:
            self.s.flight.set_mode(mode)
