"""The ways a ``flights`` cell flies one gain set on the vehicle it holds hovering (ksbo_bench.kinds.flights):

- ``streamed``: the training trial through the tuner's own MavlinkObjective (the figure-8 streamed from the
  ground at the mission rate); ``streamed@HZ``: the same at HZ (setpoints and telemetry; the rate the link check
  left otherwise);
- ``onboard``: the same trial flown on board by the onboard guard's Lua script (ArduCopter with scripting);
- ``client``, ``client+lead10``, ``client-ff``, ``client10hz``: the figure-8 streamed by the separate client
  ``python -m ksbo_bench.figure8_client`` (pymavlink only, on the SITL's second port) answering each
  LOCAL_POSITION_NED sample with the setpoint of its stamp: no lead / 10 ms lead (the tuner's half step) /
  position only (no feed-forward) / every 5th sample (10 Hz);
- ``steps``, ``hold``, ``auto_mission``: the profile's validation manoeuvres (full sizes) through ``fly_manoeuvre``.

Every figure-8 is also scored against the pattern at each sample's own stamp (``true_rms``), next to the tuner's
own score where it has one.
"""

from __future__ import annotations

import json
import re
import socket
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_bench.kinds.independent_refly import stream_motor_outputs

CLIENTS = {"client": [], "client+lead10": ["--lead-ms", "10"], "client-ff": ["--no-feed-forward"],
           "client10hz": ["--every", "5"]}
MANOEUVRES = ("steps", "hold", "auto_mission")
TRIALS = ("streamed", "onboard")
#: A streamed trial at a given rate: ``streamed@10``.
AT_RATE = re.compile(r"^streamed@(\d+)$")


def known(way: str) -> bool:
    return way in TRIALS or way in CLIENTS or way in MANOEUVRES or bool(AT_RATE.match(way))


def true_rms(tlog: Path, mission) -> float | None:
    """Lap-2 3-D RMS of a tuner trial's received LOCAL_POSITION_NED against the pattern at each sample's stamp
    (t0 from the trial's start marker), as the separate client scores itself."""
    from ksbo_mav.mav.tlog import read_tlog
    from ksbo_mav.mav.trajectory import trajectory_from_tlog

    recs = read_tlog(tlog)
    _, info, _ = trajectory_from_tlog(recs)
    t0 = info.get("t0_ms")
    if t0 is None:
        return None
    f8 = mission.figure8h
    t, pos = [], []
    for r in recs:
        if not r.sent and r.msg.get_type() == "LOCAL_POSITION_NED":
            t.append((r.msg.time_boot_ms - t0) / 1000.0)
            pos.append((r.msg.x, r.msg.y, r.msg.z))
    t, pos = np.array(t), np.array(pos)
    dt = mission.dt
    sel = (t > f8.duration - f8.period + 0.5 * dt) & (t <= f8.duration + 0.5 * dt)
    if sel.sum() < 50:
        return None
    d = np.linalg.norm(pos[sel] - f8.position(np.minimum(t[sel], f8.duration)), axis=1)
    return float(np.sqrt(np.mean(d * d)))


def centre_sticks(instance: int) -> None:
    """ArduCopter SITL's simulated transmitter with sticks 1-4 centred (its throttle rests at 1000 us otherwise, and
    LOITER, the hold manoeuvre, follows the throttle stick): one RC packet to its RC input port 5501+10N."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(struct.pack("<16H", *([1500] * 4 + [0] * 12)), ("127.0.0.1", 5501 + 10 * instance))


def fly_client(v, port: int, extra: list[str], out: Path) -> dict[str, Any]:
    """The separate client on the SITL's spare port, the tuner's link pumped meanwhile (its heartbeat goes on)."""
    m = v.mission
    cmd = [sys.executable, "-m", "ksbo_bench.figure8_client", "--tcp", f"127.0.0.1:{port}", "--scale", str(m.scale),
           "--scale-east", str(m.scale2), "--period", str(m.period), "--up", str(m.center_up), "--laps",
           str(m.laps), "--lead-in", str(m.lead_in), "--samples-out", str(out), *extra]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while p.poll() is None:
        v.link.pump(0.02)
    so, se = p.communicate()
    if p.returncode != 0:
        return {"outcome": "client failed", "error": (se.strip().splitlines() or ["?"])[-1][:200]}
    return {"outcome": "ok", **json.loads(so.strip().splitlines()[-1])}


class Ways:
    """The ways of one cell on one hovering vehicle ``v`` (baseline parameters ``base``; trial records under
    ``work``); :meth:`fly` flies gain vector ``x`` one way and returns the flight's row."""

    def __init__(self, v, base: dict[str, float], work: Path, sitl, guard, log) -> None:
        from ksbo_mav.mav.monitor import Monitor, limits_from_profile
        from ksbo_mav.mav.validation import ManoeuvreSpec

        self.v, self.base, self.work, self.sitl, self.guard, self.log = v, base, work, sitl, guard, log
        self.rate = v.mission.rate_hz  # the rate the link check left
        stream_motor_outputs(v)
        self.objectives: dict[int, Any] = {}
        self.monitor = Monitor(limits_from_profile(v.profile), v.stack.modes["guided"], v.stack.mode_name)
        vspec = v.profile.validation_spec
        self.specs = {k: ManoeuvreSpec.from_dict(k, vspec.sizes(k)) for k in vspec.kinds}
        self.n = 0

    def _objective(self, rate: int):
        from ksbo_mav.mav.objective import MavlinkObjective

        if self.v.mission.rate_hz != rate:
            self.v.set_mission_rate(rate)
            self.v.setup_streams()
            stream_motor_outputs(self.v)
        if rate not in self.objectives:
            self.objectives[rate] = MavlinkObjective(self.v, self.base, self.work / f"trials-{rate}hz", log=self.log)
        return self.objectives[rate]

    def fly(self, way: str, name: str, x: np.ndarray) -> dict[str, Any]:
        from ksbo_mav.errors import TrialStopped
        from ksbo_mav.mav.validation import fly_manoeuvre

        self.n += 1
        m = AT_RATE.match(way)
        if way in TRIALS or m:
            obj = self._objective(int(m.group(1)) if m else self.rate)
            obj.trial_flight.on_board = way == "onboard"
            try:
                f = obj.fly(x, label=f"{name}/{way}")
            except TrialStopped as exc:  # the tuner fell behind, the link: recorded, not scored
                return {"outcome": "stopped", "message": str(exc)[:200]}
            row = {"outcome": str(f.outcome.value), "rms": f.score.get("rms_lap2_m"),
                   "rough": f.score.get("rough_dps"), "motor": f.score.get("motor_osc_us"),
                   "tilt_max": f.score.get("tilt_max_deg"),
                   "true_rms": true_rms(Path(f.meta["tlog"]), self.v.mission),
                   "lag_max_ms": f.meta["link"].get("lag_max_ms"), "late_fraction": f.meta["link"].get("late_fraction"),
                   "lost": f.meta["link"].get("lost_packets"), "samples": f.score.get("samples"),
                   "message": f.meta.get("message", ""), "wall_s": round(f.meta.get("wall_s", 0.0), 1)}
            done = [t for t in (self.guard.texts if self.guard else []) if "figure-8 done" in t]
            if way == "onboard" and done:  # "KSG: figure-8 done, N targets": the script's rate
                row["targets"] = int(done[-1].split(", ")[1].split()[0])
                self.guard.texts.clear()
            return row
        self._objective(self.rate)  # the streams at the mission's rate for the others
        if way in CLIENTS:
            self.v.write_gains(x)
            try:
                row = fly_client(self.v, self.sitl.tcp_ports[1], CLIENTS[way], self.work / f"client-{self.n}.json")
            finally:
                self.v.write_gains(self.v.gain_map.from_params(self.base))
            row["true_rms"] = row.get("rms_lap2_m")
            return row
        f = fly_manoeuvre(self.v, self.specs[way], self.monitor, gains_label=name,
                          tlog_path=self.work / f"val-{self.n}-{way}.tlog", gains=x, baseline_params=self.base,
                          log=self.log)
        return {"outcome": str(f.outcome.value), "metrics": f.metrics, "message": f.message}
