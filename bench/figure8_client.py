"""A separate MAVLink client that flies the campaign's figure-8 on an ArduCopter already hovering in GUIDED: the
independent check of how the tuner's training trial streams its setpoints.

It shares nothing with the tuner's MAVLink code (pymavlink only; the pattern itself comes from
``ksbo_task.figure8_ne.Figure8H``, the one definition of the reference). It asks for LOCAL_POSITION_NED at 50 Hz
on its own link and answers each sample: at a sample stamped t it sends the pos+vel+acc setpoint of the pattern
at t (``--lead-ms`` later), stamped t, so the setpoint rate is the telemetry rate and the setpoint carries no lead
unless asked. Before the pattern it flies to the start on a position-only target and hovers there for
``--settle-s`` of vehicle time; after it, it holds the end point on a position-only target (which never times
out). The score: lap-2 3-D RMS of the measured position minus the pattern's position at each sample's own stamp,
the same lap as the tuner's (stamps in ((lo + 0.5) dt, (hi + 0.5) dt] after t0), printed as one JSON line.

    python -m ksbo_bench.figure8_client --tcp 127.0.0.1:5772 [--lead-ms 0] [--no-feed-forward] [--every N]

Nothing here watches the vehicle's safety: it is a SITL measurement tool, not a way to fly a real vehicle.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from ksbo_task.figure8_ne import Figure8H  # noqa: E402

MASK_POS_VEL_ACC = 0x0C00
MASK_POS = 0x0DF8
GUIDED = 4  # ArduCopter custom_mode


def connect(tcp: str, sysid: int) -> mavutil.mavfile:
    conn = mavutil.mavlink_connection(f"tcp:{tcp}", source_system=sysid, source_component=191, autoreconnect=False)
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
        if hb is not None and hb.autopilot != mavutil.mavlink.MAV_AUTOPILOT_INVALID:
            conn.target_system, conn.target_component = hb.get_srcSystem(), hb.get_srcComponent()
            if hb.custom_mode != GUIDED or not hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED:
                sys.exit(f"the vehicle is not armed in GUIDED (custom_mode {hb.custom_mode}): hover it first")
            return conn
    sys.exit(f"no HEARTBEAT from an autopilot on tcp:{tcp} within 30 s")


class Client:
    def __init__(self, conn: mavutil.mavfile, f8: Figure8H) -> None:
        self.conn, self.f8 = conn, f8
        self.last_hb = 0.0
        self.sent = 0

    def send(self, t_ms: int, pos: np.ndarray, vel: np.ndarray | None = None, acc: np.ndarray | None = None) -> None:
        mask = MASK_POS if vel is None else MASK_POS_VEL_ACC
        vel = np.zeros(3) if vel is None else vel
        acc = np.zeros(3) if acc is None else acc
        c = self.conn
        c.mav.set_position_target_local_ned_send(int(t_ms) & 0xFFFFFFFF, c.target_system, c.target_component,
                                                 mavutil.mavlink.MAV_FRAME_LOCAL_NED, mask, *map(float, pos),
                                                 *map(float, vel), *map(float, acc), 0.0, 0.0)
        self.sent += 1

    def sample(self, timeout: float = 2.0):
        """The next LOCAL_POSITION_NED (a GCS heartbeat goes out every second meanwhile)."""
        now = time.monotonic()
        if now - self.last_hb > 1.0:
            self.conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self.last_hb = now
        m = self.conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=timeout)
        if m is None:
            sys.exit("no LOCAL_POSITION_NED for 2 s")
        return m

    def hold(self, pos: np.ndarray, seconds: float) -> None:
        """Hold ``pos`` (position-only target, re-sent at 10 Hz) for ``seconds`` of vehicle time."""
        t_end, last = None, -1e9
        while True:
            m = self.sample()
            t_end = m.time_boot_ms + seconds * 1000 if t_end is None else t_end
            if m.time_boot_ms - last >= 100:
                self.send(m.time_boot_ms, pos)
                last = m.time_boot_ms
            if m.time_boot_ms >= t_end:
                return

    def fly(self, lead_ms: float, feed_forward: bool, every: int) -> list[tuple[int, float, float, float]]:
        """Stream the pattern answering every ``every``-th sample; returns (stamp ms, north, east, down) of every
        sample from t0 to the end."""
        f8, n_ms = self.f8, self.f8.duration * 1000.0
        t0, got, k = None, [], 0
        while True:
            m = self.sample()
            t0 = m.time_boot_ms if t0 is None else t0
            t = m.time_boot_ms - t0
            got.append((t, m.x, m.y, m.z))
            if t > n_ms:
                return [(t0, math.nan, math.nan, math.nan)] + got
            if k % every == 0:
                pos, vel, acc = f8.state(np.array((t + lead_ms) / 1000.0))
                self.send(m.time_boot_ms, pos, vel if feed_forward else None, acc if feed_forward else None)
            k += 1


def lap2(f8: Figure8H, samples: list[tuple[int, float, float, float]], dt_s: float) -> dict:
    """Lap-2 3-D RMS of the samples against the pattern at each sample's stamp (the tuner's lap: stamps in
    ((lo + 0.5) dt, (hi + 0.5) dt], lo = one lap before the end)."""
    a = np.array(samples[1:], float)
    t = a[:, 0] / 1000.0
    hi = f8.duration
    sel = (t > f8.duration - f8.period + 0.5 * dt_s) & (t <= hi + 0.5 * dt_s)
    err = a[sel, 1:] - f8.position(np.minimum(t[sel], hi))
    d = np.linalg.norm(err, axis=1)
    gaps = np.diff(t[sel])
    return {"rms_lap2_m": float(np.sqrt(np.mean(d * d))), "max_err_m": float(d.max()),
            "rms_h_m": float(np.sqrt(np.mean(np.sum(err[:, :2] ** 2, axis=1)))),
            "rms_v_m": float(np.sqrt(np.mean(err[:, 2] ** 2))), "samples": int(sel.sum()),
            "rate_hz": float(sel.sum() / f8.period), "max_gap_s": float(gaps.max()) if gaps.size else math.nan}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tcp", required=True, help="HOST:PORT of an ArduCopter SITL's spare TCP port (5762+10N)")
    ap.add_argument("--lead-ms", type=float, default=0.0, help="setpoint content this far ahead of the sample "
                    "it answers (default 0)")
    ap.add_argument("--no-feed-forward", action="store_true", help="position-only setpoints (no vel/acc)")
    ap.add_argument("--every", type=int, default=1, help="answer every N-th sample (1: 50 Hz, 5: 10 Hz)")
    ap.add_argument("--settle-s", type=float, default=5.0, help="hover at the start first (vehicle s)")
    ap.add_argument("--scale", type=float, default=10.0)
    ap.add_argument("--scale-east", type=float, default=2.5)
    ap.add_argument("--period", type=float, default=20.0)
    ap.add_argument("--up", type=float, default=10.0)
    ap.add_argument("--laps", type=int, default=2)
    ap.add_argument("--lead-in", type=float, default=5.0)
    ap.add_argument("--sysid", type=int, default=246)
    ap.add_argument("--samples-out", help="write the samples (t0 first) as JSON here")
    a = ap.parse_args()
    f8 = Figure8H(amp_north=a.scale, amp_east=a.scale_east, period=a.period, altitude=a.up, laps=a.laps,
                  rate_hz=50.0, lead_in=a.lead_in)
    conn = connect(a.tcp, a.sysid)
    c = Client(conn, f8)
    c.conn.mav.command_long_send(c.conn.target_system, c.conn.target_component,
                                 mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                 mavutil.mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, 20000, 0, 0, 0, 0, 0)
    c.hold(f8.start(), a.settle_s)
    wall0 = time.monotonic()
    samples = c.fly(a.lead_ms, not a.no_feed_forward, max(1, a.every))
    wall = time.monotonic() - wall0
    c.hold(f8.position(f8.duration), 2.0)
    out = {"lead_ms": a.lead_ms, "feed_forward": not a.no_feed_forward, "every": a.every,
           **lap2(f8, samples, 0.02), "setpoints_sent": c.sent, "wall_s": round(wall, 2),
           "vehicle_s": round(samples[-1][0] / 1000.0, 2)}
    if a.samples_out:
        with open(a.samples_out, "w") as fh:
            json.dump(samples, fh)
    conn.close()
    print(json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
