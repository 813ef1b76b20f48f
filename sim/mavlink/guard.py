"""The onboard guard, simulated: what ``ksbo_guard.lua`` does on ArduPilot, done by the simulator itself, so the
demo and the fast tests run the tuner's guard protocol against a vehicle without Lua.

The vehicle looks like ArduPilot with scripting on: parameters ``SCR_ENABLE`` (1), ``MAV_GCS_SYSID`` (255; the
personality's name for it: ``SYSID_MYGCS`` on the pre-4.7 ArduPilot generation) and the
script's ``KSG_STATE``/``KSG_TRIP`` (always listed here; ArduPilot adds them when the script starts), a ``scripts/``
directory served over MAVLink FTP (:mod:`ksbo_sim.mavlink.ftp`), and MAV_CMD_SCRIPTING (42701, p1 = 3) restarting
the scripts: the guard then runs when ``scripts/ksbo_guard.lua`` is there, configured from the script's own
configuration block (the same lines the Lua reads), and stops when it is gone. While it runs it does what the Lua
does, every 100 ms of simulated time: watch an armed trial (``KSG_STATE`` 1) for the tuner's heartbeat (from the
system id in ``MAV_GCS_SYSID``, on the simulated clock), the box, the tilt, the mode (GUIDED, or one of the custom
modes whose bits the tuner set in ``KSG_MODES`` before it armed) and the arming, and on a breach put the baseline
gains back, hold (the simulator's BRAKE and LOITER are one hold mode) and say so; ``KSG_ALIVE`` and ``KSG_CFG`` go
out twice a second. The protocol words are documented in
``ksbo_mav.mav.guard_script``.

A script rendered with a figure-8 (``F8_DURATION_MS`` > 0) flies it on board as the Lua does: on ``KSG_F8`` = 1
during an armed trial it answers ``KSG_T0`` and sets the reference (:class:`ksbo_task.figure8_ne.Figure8H` with
its lead-in) as the guided target every control period, the simulator's loop rate, then holds the end point; a
tracking error past ``TRACK_MAX`` trips it.
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from ksbo_sim.mavlink.personality import Mode
from ksbo_sim.vehicle import ParamSpec
from ksbo_task.figure8_ne import Figure8H

SCRIPT_PATH = "scripts/ksbo_guard.lua"
CMD_SCRIPTING, SCRIPTING_RESTART = 42701, 3
IDLE, ARMED, TRIPPED, REFUSED = 0, 1, 2, 3
LINK, BOX, TILT, PILOT, DISARMED, TRACK = 1, 2, 3, 4, 5, 7
TICK_US, ALIVE_US = 100_000, 500_000
SEV_CRITICAL, SEV_WARNING, SEV_INFO = 2, 4, 6

PARAMS = [
    ParamSpec("SCR_ENABLE", 1, 0, 1, "INT32", "Lua scripting (the simulated guard runs when 1)"),
    ParamSpec("KSG_STATE", 0.0, 0.0, 3.0, description="onboard guard: 0 idle, 1 trial armed, 2 tripped, 3 refused"),
    ParamSpec("KSG_TRIP", 0.0, 0.0, 7.0, description="onboard guard: why it tripped"),
    ParamSpec("KSG_F8", 0.0, 0.0, 1.0, description="onboard guard: 1 flies the figure-8 on board"),
    ParamSpec("KSG_T0", -1.0, -1.0, 16777215.0, description="onboard guard: vehicle ms (mod 2^24) of its t = 0"),
    ParamSpec("KSG_MODES", 0.0, 0.0, 16777215.0, description="onboard guard: the tuner's own modes besides GUIDED "
                                                             "(bit per custom mode) for the next armed flight"),
]


def params(gcs_sysid_param: str = "MAV_GCS_SYSID") -> list[ParamSpec]:
    """The guard's parameters with the ground station's system id under the personality's name."""
    return [PARAMS[0], ParamSpec(gcs_sysid_param, 255, 1, 255, "INT32", "system id whose heartbeat is the GCS link"),
            *PARAMS[1:]]


#: Never persisted: a restarted vehicle's guard starts idle, as the Lua does.
VOLATILE = ("KSG_STATE", "KSG_TRIP", "KSG_F8", "KSG_T0", "KSG_MODES")


def parse_config(text: str) -> dict[str, Any] | None:
    """The configuration block of a rendered ``ksbo_guard.lua``: {"CONFIG_ID": 7, "GAINS": [(name, value)], ...};
    None when the block is missing or lists no gains."""
    m = re.search(r"-- KSBO_CONFIG_BEGIN\n(.*?)-- KSBO_CONFIG_END", text, re.S)
    if m is None:
        return None
    out: dict[str, Any] = {}
    for line in m.group(1).splitlines():
        names, sep, values = line.removeprefix("local ").partition(" = ")
        if not sep:
            continue
        if names.strip() == "GAINS":
            out["GAINS"] = [(n, float(v)) for n, v in re.findall(r'\{"(\w+)",\s*([-+0-9.eE]+)\}', values)]
            continue
        for name, value in zip(names.split(","), values.split(",")):
            out[name.strip()] = float(value)
    return out if out.get("GAINS") else None


class SimGuard:
    """The guard of one :class:`ksbo_sim.mavlink.server.Server` (which calls :meth:`step` every control period)."""

    def __init__(self, server: Any) -> None:
        self.s = server
        self.cfg: dict[str, Any] | None = None
        self.state = IDLE
        self.gcs_seen_us: int | None = None
        self._next_tick = 0
        self._next_alive = 0
        self.f8: Figure8H | None = None
        self.f8_start_us: int | None = None
        self.f8_done = False
        self.own_modes = 0  # KSG_MODES as read when the flight armed

    # --- the scripting service ---------------------------------------------------------------------------
    def restart(self) -> None:
        """MAV_CMD_SCRIPTING restart: (re)start the guard from the uploaded script, or stop it."""
        self.s.telemetry.statustext(SEV_CRITICAL, "Scripting: restarted")
        data = self.s.ftp.files.get(SCRIPT_PATH)
        self.cfg = parse_config(data.decode("utf-8", "replace")) if data and self.s.params["SCR_ENABLE"] else None
        self._set_state_param(IDLE)
        self.f8 = None
        if self.cfg is not None and self.cfg.get("F8_DURATION_MS", 0) > 0:
            c = self.cfg
            self.f8 = Figure8H(amp_north=c["F8_AMP_N"], amp_east=c["F8_AMP_E"], period=c["F8_PERIOD"],
                               altitude=c["F8_UP"], lead_in=c["F8_LEAD"])
        if self.cfg is not None:
            self.s.telemetry.statustext(SEV_INFO, f"KSG: guard running, config {int(self.cfg['CONFIG_ID'])}, "
                                                  f"{len(self.cfg['GAINS'])} gains")
            self._alive()  # at once: in lockstep no time passes until the tuner steps it

    def state_written(self) -> None:
        """A PARAM_SET of KSG_STATE: answered right after its echo (the server steps the guard after every
        parameter message) rather than at the next tick, because in lockstep no tick comes while the tuner waits
        for the answer; on ArduPilot the script answers within its 100 ms tick."""
        if self.cfg is not None and int(self.s.params["KSG_STATE"]) != self.state:
            self._next_tick = 0

    def heartbeat(self, msg: Any) -> None:
        if msg.get_srcSystem() == int(self.s.params[self.s.personality.gcs_sysid_param]):
            self.gcs_seen_us = self.s.now_us

    # --- the script's loop -------------------------------------------------------------------------------
    def step(self, now_us: int) -> None:
        if self.cfg is not None and self.state == ARMED and self.f8 is not None:
            self._fly_figure8(now_us)  # every control period (and right after a KSG_F8 write's echo)
        if self.cfg is None or now_us < self._next_tick:
            return
        self._next_tick = now_us + TICK_US
        wanted = int(self.s.params["KSG_STATE"])
        if self.state == ARMED:
            if wanted == IDLE:
                self._set(IDLE)
            else:
                self._watch(now_us)
        elif wanted == ARMED:
            why = self._refusal(now_us)
            if why:
                self._set(REFUSED)
                self.s.telemetry.statustext(SEV_WARNING, "KSG: trial not armed: " + why)
            else:
                modes = int(self.s.params["KSG_MODES"])
                self._set(ARMED, 0)
                self.own_modes = modes
                self.s.telemetry.statustext(SEV_INFO, f"KSG: trial armed, modes {modes}" if modes else
                                            "KSG: trial armed")
        elif wanted == IDLE and self.state != IDLE:
            self._set(IDLE)
        if now_us >= self._next_alive:
            self._alive()

    def _alive(self) -> None:
        ms = self.s.now_us // 1000
        self.s.mav.named_value_float_send(ms & 0xFFFFFFFF, b"KSG_ALIVE", float(self.state))
        self.s.mav.named_value_float_send(ms & 0xFFFFFFFF, b"KSG_CFG", float(self.cfg["CONFIG_ID"]))
        self._next_alive = self.s.now_us + ALIVE_US

    def _set_state_param(self, state: int) -> None:
        self.state = state
        self.s.params.force("KSG_STATE", state)
        if state != ARMED:  # a trip or the tuner's end of the trial ends the figure-8
            self.f8_start_us = None
            self.s.params.force("KSG_F8", 0.0)
            self.s.params.force("KSG_T0", -1.0)
            self.s.params.force("KSG_MODES", 0.0)  # the next flight is GUIDED only unless written again
            self.own_modes = 0

    def _fly_figure8(self, now_us: int) -> None:
        f, fl = self.f8, self.s.flight
        nan = np.full(3, np.nan)
        wanted = int(self.s.params["KSG_F8"])
        if self.f8_start_us is None:
            if wanted == 1:
                self.f8_start_us, self.f8_done = now_us, False
                self.s.params.force("KSG_T0", float((now_us // 1000) & 0xFFFFFF))
                self.s.telemetry.statustext(SEV_INFO, "KSG: figure-8 started")
            return
        if wanted != 1:  # the tuner stopped it: hold where the vehicle is
            self.f8_start_us = None
            self.s.params.force("KSG_T0", -1.0)
            fl.set_target(np.array(fl.est_pos, float), nan, nan, now_us)
            return
        if self.f8_done:
            return
        t_ms = (now_us - self.f8_start_us) / 1000.0
        pos, vel, acc = f.state(min(t_ms, self.cfg["F8_DURATION_MS"]) / 1000.0)
        if t_ms >= self.cfg["F8_DURATION_MS"]:
            fl.set_target(pos, nan, nan, now_us)
            self.f8_done = True
            self.s.telemetry.statustext(SEV_INFO, "KSG: figure-8 done")
            return
        fl.set_target(pos, vel, acc, now_us)
        err = float(np.linalg.norm(np.asarray(fl.est_pos, float) - pos))
        if self.cfg.get("TRACK_MAX", 0) > 0 and err > self.cfg["TRACK_MAX"]:
            self._trip(TRACK, f"tracking error {err:.1f}>{self.cfg['TRACK_MAX']:.1f} m", True)

    def _set(self, state: int, reason: int | None = None) -> None:
        self._set_state_param(state)
        if reason is not None:
            self.s.params.force("KSG_TRIP", reason)
        self._alive()

    def _silent_ms(self, now_us: int) -> float:
        return math.inf if self.gcs_seen_us is None else (now_us - self.gcs_seen_us) / 1000.0

    def _refusal(self, now_us: int) -> str | None:
        f = self.s.flight
        if not f.armed:
            return "vehicle disarmed"
        if f.mode is not Mode.GUIDED:
            return "not in GUIDED"
        if self._silent_ms(now_us) > self.cfg["LINK_TIMEOUT_MS"]:
            return f"no heartbeat from {self.s.personality.gcs_sysid_param}"
        return None

    def _watch(self, now_us: int) -> None:
        f, c = self.s.flight, self.cfg
        if not f.armed:
            return self._trip(DISARMED, "disarmed", False)
        if not self._tuners_mode(f.mode):
            return self._trip(PILOT, "pilot mode change", False)
        silent = self._silent_ms(now_us)
        if silent > c["LINK_TIMEOUT_MS"]:
            return self._trip(LINK, f"link lost {silent / 1000:.1f} s", True)
        north, east, up = float(f.est_pos[0]), float(f.est_pos[1]), -float(f.est_pos[2])
        if c.get("BRAKE_ACCEL", 0) > 0:
            k = 1.0 / (2.0 * c["BRAKE_ACCEL"])
            v = f.est_vel
            north, east, up = north + v[0] * abs(v[0]) * k, east + v[1] * abs(v[1]) * k, up - v[2] * abs(v[2]) * k
        if abs(north) > c["X_MAX"]:
            return self._trip(BOX, f"|north| {abs(north):.1f}>{c['X_MAX']:.1f} m", True)
        if abs(east) > c["Y_MAX"]:
            return self._trip(BOX, f"|east| {abs(east):.1f}>{c['Y_MAX']:.1f} m", True)
        if not c["Z_MIN"] <= up <= c["Z_MAX"]:
            return self._trip(BOX, f"up {up:.1f} m out of {c['Z_MIN']:.0f}..{c['Z_MAX']:.0f}", True)
        tilt = math.degrees(max(abs(float(f.truth.rpy[0])), abs(float(f.truth.rpy[1]))))
        if tilt > c["TILT_MAX_DEG"]:
            return self._trip(TILT, f"tilt {tilt:.0f}>{c['TILT_MAX_DEG']:.0f} deg", True)
        return None

    def _tuners_mode(self, mode: Mode) -> bool:
        """GUIDED, or a mode the tuner declared its own for this flight (the custom mode this simulator reports
        for it: its hold mode is LOITER)."""
        if mode is Mode.GUIDED:
            return True
        try:
            custom = self.s.personality.custom_mode(mode)
        except KeyError:
            return False
        return 0 <= custom < 24 and bool(self.own_modes >> custom & 1)

    def _trip(self, reason: int, text: str, take_control: bool) -> None:
        failed = sum(1 for name, value in self.cfg["GAINS"]
                     if name not in self.s.params.values or self.s.params.set_local(name, value) is not None)
        gains = "gains back" if not failed else f"{failed} gains NOT back"
        action = ""
        if take_control:
            self.s.flight.set_mode(Mode.HOLD)  # BRAKE, then LOITER: one hold mode in this simulator
            action = "; BRAKE"
        self._set(TRIPPED, reason)
        self.s.telemetry.statustext(SEV_CRITICAL if not failed else 1, f"KSG: {text}; {gains}{action}")
