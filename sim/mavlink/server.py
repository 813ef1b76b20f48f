"""The endpoint's main loop: the simulated clock (real time, speed-up or lockstep), message dispatch, the
endpoint's own SIM_* parameters and fault injection.

Lockstep protocol (``--lockstep``): simulated time never advances on its own.

1. Every SET_POSITION_TARGET_LOCAL_NED addressed to the vehicle (any peer) is applied at the current simulated
   time and then advances time by exactly one control period (20 ms for the planar vehicle), whether or not it
   was used (mode, armed). After that step the due telemetry streams are sent, plus one LOCAL_POSITION_NED in
   any case: the client reads it as "step done" and pairs it with the next setpoint. A setpoint stamped
   (``time_boot_ms``, 0 = unstamped) as the one that made the last step, with no step since, is a re-send (its
   answer was late or lost): answered with LOCAL_POSITION_NED again, nothing else, so a client that re-sends on
   a wall-clock timeout cannot push simulated time ahead of its stream on a slow machine.
2. COMMAND_LONG MAV_CMD_USER_2 (31011), p1 = seconds: advance that many seconds (rounded up to whole control
   periods), streaming telemetry on the simulated clock as usual, then COMMAND_ACK. Used to wait for takeoff,
   landing or a hold without streaming setpoints.
3. A HEARTBEAT goes out at least every quarter of a wall-clock second while nothing advances time (time frozen),
   and while simulated time runs slower than real time (a lossy link makes the client re-send steps), so that a
   ground station's wall-clock heartbeat timeout measures the link, not the step rate, and a client that waits for
   the vehicle's next heartbeat between two flights waits a quarter of a second, not up to one; nothing else
   changes.

Real time (default) runs one control period per ``ctrl_dt / speedup`` wall seconds.
"""

from __future__ import annotations

import math
import signal
import sys
import time

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from ksbo_sim.errors import SimInputError
from ksbo_sim.estimator import Estimator
from ksbo_sim.mavlink.commands import Commands
from ksbo_sim.mavlink.flight import SEV_INFO, SEV_NOTICE, STATUS_EMERGENCY, Flight
from ksbo_sim.mavlink.ftp import FtpServer
from ksbo_sim.mavlink.guard import params as guard_params
from ksbo_sim.mavlink.guard import VOLATILE as GUARD_VOLATILE
from ksbo_sim.mavlink.guard import SimGuard
from ksbo_sim.mavlink.link import Link
from ksbo_sim.mavlink.mission_store import MissionStore
from ksbo_sim.mavlink.params import ParamTable
from ksbo_sim.mavlink.personality import Personality
from ksbo_sim.mavlink.power import Power
from ksbo_sim.mavlink.telemetry import HEARTBEAT, LOCAL_POSITION_NED, RC_THROTTLE, Telemetry
from ksbo_sim.vehicle import ParamSpec, VehicleModel

#: Wall seconds between HEARTBEATs while the simulated clock stands still or runs slower than real time.
IDLE_HEARTBEAT_S = 0.25
#: Fault switches: volatile (never persisted), so a restarted vehicle never boots faulty.
FAULT_PARAMS = ("SIM_PKT_LOSS_IN", "SIM_PKT_LOSS_OUT", "SIM_DELAY_MS", "SIM_MUTE_S", "SIM_PILOT_MODE",
                "SIM_PSET_FAIL", "SIM_FAULT_AFTER", "SIM_CRASH_WRITES", "SIM_HB_MUTE_S")


def endpoint_specs() -> list[ParamSpec]:
    return [
        ParamSpec("SIM_PKT_LOSS_IN", 0.0, 0.0, 1.0, description="fraction of received messages dropped"),
        ParamSpec("SIM_PKT_LOSS_OUT", 0.0, 0.0, 1.0, description="fraction of sent messages dropped"),
        ParamSpec("SIM_DELAY_MS", 0.0, 0.0, 10000.0, description="latency added to sent messages [ms wall]"),
        ParamSpec("SIM_MUTE_S", 0.0, 0.0, 3600.0, description="go silent (no rx/tx) this long [s wall], one-shot"),
        ParamSpec("SIM_HB_MUTE_S", 0.0, 0.0, 3600.0,
                  description="send no HEARTBEAT (the rest still goes) this long [s wall], one-shot"),
        ParamSpec("SIM_PILOT_MODE", -1, -1, 2**31 - 1, "INT32", "custom_mode a pilot switches to, one-shot; -1 off"),
        ParamSpec("SIM_PSET_FAIL", 0.0, 0.0, 1.0,
                  description="fraction of PARAM_SETs of non-SIM_ parameters refused (old value echoed)"),
        ParamSpec("SIM_CRASH_WRITES", 0, 0, 2**31 - 1, "INT32",
                  "the vehicle crashes (disarms, EMERGENCY) at this many more vehicle-parameter writes; 0 off"),
        ParamSpec("SIM_FAULT_AFTER", 0.0, 0.0, 3600.0,
                  description="faults act this long [s sim] into the guided setpoint stream; 0 = at once"),
        ParamSpec("SIM_SP_TIMEOUT", 3.0, 0.1, 60.0, description="velocity/accel setpoint timeout -> hold [s]"),
        ParamSpec("SIM_POS_NOISE", 0.0, 0.0, 10.0, description="position sensor noise std [m]"),
        ParamSpec("SIM_VEL_NOISE", 0.0, 0.0, 10.0, description="velocity sensor noise std [m/s]"),
        ParamSpec("SIM_ACC_NOISE", 0.0, 0.0, 100.0, description="accelerometer noise std [m/s^2]"),
        ParamSpec("TKOFF_SPEED", 0.5, 0.05, 5.0, description="takeoff climb rate [m/s]"),
        ParamSpec("LAND_SPEED", 0.5, 0.05, 5.0, description="landing descent rate [m/s]"),
        ParamSpec("WP_SPEED", 5.0, 0.1, 20.0, description="AUTO: speed along the mission's legs [m/s]"),
        ParamSpec("WP_ACCEL", 2.5, 0.1, 10.0, description="AUTO: acceleration and braking along a leg [m/s^2]"),
        ParamSpec("WP_RADIUS", 1.0, 0.05, 10.0, description="AUTO: a waypoint is reached within this [m]"),
        ParamSpec("SIM_LOCKSTEP", 0, 0, 1, "INT32", "1 when the clock is in lockstep (read-only)"),
    ]


class Server:
    def __init__(self, model: VehicleModel, personality: Personality, link: Link, *, lockstep: bool = False,
                 speedup: float = 1.0, sysid: int = 1, compid: int = 1, seed: int | None = None,
                 params_path: str | None = None, product_id: int = 1,
                 overrides: dict[str, float] | None = None, power: tuple | None = None) -> None:
        self.model, self.personality, self.link = model, personality, link
        self.lockstep, self.speedup, self.sysid, self.compid = lockstep, float(speedup), sysid, compid
        self.now_us = 0
        self.stop = False
        self._stepped: tuple[int, int] | None = None  # lockstep: (stamp of the setpoint that stepped, time after)
        self.mav = mavlink.MAVLink(link, srcSystem=sysid, srcComponent=compid)
        self.estimator = Estimator(model.ctrl_dt, seed=seed)
        self.flight = Flight(model, self.estimator, self._notify)
        self.flight.takeoff_mode, self.flight.after_takeoff_mode = personality.takeoff_mode, \
            personality.after_takeoff_mode
        battery, conditions = power or (None, None)
        self.power = Power(self.flight, battery, conditions, self._notify)  # (battery, conditions) or nothing
        self.telemetry = Telemetry(self.mav, self.flight, personality, product_id, self.power)
        self.mission = MissionStore(self.mav, personality.mission_home_item, lambda: self.now_us * 1e-6)
        self.flight.mission_legs = self.mission.legs
        self.commands = Commands(self)
        self.ftp = FtpServer(lambda payload, sysid, compid: self.mav.file_transfer_protocol_send(0, sysid, compid,
                                                                                                 payload))
        self.guard = SimGuard(self)
        own = endpoint_specs() + self.power.params + guard_params(personality.gcs_sysid_param) + [RC_THROTTLE]
        self._own = {s.name for s in own}
        self.params = ParamTable(list(model.param_specs()) + own, self._param_changed, personality.encoding,
                                 readonly=("SIM_LOCKSTEP",), volatile=FAULT_PARAMS + GUARD_VOLATILE, path=params_path,
                                 echo_index=personality.echo_index)
        self.params.force("SIM_LOCKSTEP", 1 if lockstep else 0)
        for name in self._own:  # values loaded from a parameter file before the table existed
            self._param_changed(name, self.params[name])
        self.params.send = self._send_param
        self.params.statustext = self.telemetry.statustext
        self.telemetry.rc_throttle = lambda: int(self.params["SIM_RC_THR"])
        self.params.write_fault = self._write_fault
        self._fault_rng = np.random.default_rng(seed)
        for name, value in (overrides or {}).items():
            if name not in self.params.values:
                raise SimInputError(f"--set: unknown parameter {name}")
            reason = self.params.set_local(name, value, persist=False)
            if reason:
                raise SimInputError(f"--set: {reason}")
        self._apply_faults()

    # --- parameters ------------------------------------------------------------------------------------
    def _send_param(self, name: str, index: int) -> None:
        value, ptype = self.params.wire_value(name)
        self.mav.param_value_send(name.encode(), value, ptype, len(self.params.specs), index)

    def _param_changed(self, name: str, value: float) -> None:
        if name not in self._own:
            self.model.set_param(name, value)
            return
        if name == "KSG_STATE" and hasattr(self, "params"):
            self.guard.state_written()
            return
        if self.power.set_param(name, value):
            return
        f, v = self.flight, self.params.values if hasattr(self, "params") else None
        if name in ("SIM_POS_NOISE", "SIM_VEL_NOISE", "SIM_ACC_NOISE") and v is not None:
            self.estimator.configure(v["SIM_POS_NOISE"], v["SIM_VEL_NOISE"], v["SIM_ACC_NOISE"])
        elif name == "SIM_SP_TIMEOUT":
            f.sp_timeout_s = value
        elif name == "TKOFF_SPEED":
            f.takeoff_speed = value
        elif name == "LAND_SPEED":
            f.land_speed = value
        elif name in ("WP_SPEED", "WP_ACCEL", "WP_RADIUS"):
            setattr(f.nav, {"WP_SPEED": "speed", "WP_ACCEL": "accel", "WP_RADIUS": "radius"}[name], value)

    def _write_fault(self, name: str) -> str | None:
        # The fault switches themselves always get through, and so do the onboard guard's own parameters (KSG_*:
        # the script's, not the vehicle's): a fault counts the writes of the vehicle's parameters only.
        if name.startswith(("SIM_", "KSG_")):
            return None
        n = int(self.params["SIM_CRASH_WRITES"])
        if n > 0:  # counts vehicle-parameter writes down; the last one crashes an armed vehicle
            self.params.force("SIM_CRASH_WRITES", n - 1)
            if n == 1 and self.flight.armed:
                self.flight.crash(STATUS_EMERGENCY, "injected (SIM_CRASH_WRITES)")
        p = self.params["SIM_PSET_FAIL"]
        if p > 0 and self._faults_active() and self._fault_rng.random() < p:
            return f"Param write failed: {name} (SIM_PSET_FAIL)"
        return None

    def _faults_active(self) -> bool:
        after = self.params["SIM_FAULT_AFTER"]
        if after <= 0.0:
            return True
        since = self.flight.guided_since_us
        return since is not None and self.flight.armed and (self.now_us - since) * 1e-6 >= after

    def _apply_faults(self) -> None:
        """Put the SIM_* fault switches into effect (called after every message and every step)."""
        v, fl = self.params.values, self.link.faults
        active = self._faults_active()
        fl.loss_in = v["SIM_PKT_LOSS_IN"] if active else 0.0
        fl.loss_out = v["SIM_PKT_LOSS_OUT"] if active else 0.0
        fl.delay_s = v["SIM_DELAY_MS"] * 1e-3 if active else 0.0
        self.telemetry.drop_rate = max(fl.loss_in, fl.loss_out)
        if not active:
            return
        if v["SIM_PILOT_MODE"] >= 0:
            mode = self.personality.decode_mode(int(v["SIM_PILOT_MODE"]))
            self.params.force("SIM_PILOT_MODE", -1)
            if mode is not None:
                name = self.personality.mode_names.get(self.personality.custom_mode(mode), mode.value)
                self._notify(SEV_NOTICE, f"Pilot switched mode to {name}")
                self.flight.set_mode(mode)
        if v["SIM_MUTE_S"] > 0:
            fl.mute_until = time.monotonic() + v["SIM_MUTE_S"]
            self.params.force("SIM_MUTE_S", 0.0)
        if v["SIM_HB_MUTE_S"] > 0:
            fl.hb_mute_until = time.monotonic() + v["SIM_HB_MUTE_S"]
            self.params.force("SIM_HB_MUTE_S", 0.0)

    def _mission_events(self) -> None:
        """AUTO's progress as the autopilots report it: MISSION_CURRENT on a new leg, MISSION_ITEM_REACHED."""
        events, self.flight.nav.events = self.flight.nav.events, []
        for kind, seq in events:
            if kind == "current":
                self.mission.current = seq
                self.mav.mission_current_send(seq, len(self.mission.items))
            else:
                self.mav.mission_item_reached_send(seq)
                self.telemetry.statustext(SEV_INFO, f"Reached command #{seq}")

    def _notify(self, severity: int, text: str) -> None:
        if hasattr(self, "telemetry"):
            self.telemetry.statustext(severity, text)

    # --- clock -----------------------------------------------------------------------------------------
    def advance(self, n: int, reply: bool = False) -> None:
        """Run ``n`` control periods, sending telemetry due on the simulated clock after each."""
        dt_us = self.flight.dt_us
        for _ in range(n):
            self.flight.step(self.now_us)
            self.power.step(self.model.ctrl_dt)
            self.guard.step(self.now_us)
            self.now_us += dt_us
            self._mission_events()
            if self.link.has_peers:  # nobody listening: skip encoding (matters at high speed-ups)
                self.telemetry.send_due(self.now_us, (LOCAL_POSITION_NED,) if reply else ())
                self.link.flush()
            if self.params["SIM_FAULT_AFTER"] > 0:
                self._apply_faults()

    # --- messages --------------------------------------------------------------------------------------
    def dispatch(self, msg) -> None:
        if getattr(msg, "target_system", 0) not in (0, self.sysid) or \
                getattr(msg, "target_component", 0) not in (0, self.compid):
            return  # addressed to another vehicle or another component (camera, gimbal, ...)
        kind = msg.get_type()
        if kind.startswith("PARAM_"):
            self.params.handle(msg)
            self.guard.step(self.now_us)  # a KSG_STATE write is answered after its echo
        elif kind == "COMMAND_LONG":
            self.commands.handle(msg)
        elif kind == "COMMAND_INT":  # same commands; x, y arrive as integers, z as float (param5..7)
            msg.param5, msg.param6, msg.param7 = float(msg.x), float(msg.y), msg.z
            self.commands.handle(msg)
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            self._setpoint(msg)
        elif kind == "SET_MODE":
            self.commands.set_mode(msg)
        elif kind == "REQUEST_DATA_STREAM":
            self.telemetry.request_data_stream(msg.req_stream_id, msg.req_message_rate, bool(msg.start_stop))
        elif kind.startswith("MISSION_"):
            self.mission.handle(msg)
            self.link.flush()
        elif kind == "FILE_TRANSFER_PROTOCOL":
            self.ftp.handle(msg)
        elif kind == "HEARTBEAT":
            self.guard.heartbeat(msg)
        elif kind == "TIMESYNC" and msg.tc1 == 0:  # a request: answered as ArduPilot and PX4 do (a link's round trip)
            self.mav.timesync_send(self.now_us * 1000, msg.ts1)
            self.link.flush()
        self._apply_faults()

    def _setpoint(self, msg) -> None:
        if self.lockstep and msg.time_boot_ms and self._stepped == (msg.time_boot_ms, self.now_us):
            # a re-send: answer it, do not step again
            self.telemetry.send(LOCAL_POSITION_NED, self.now_us)
            self.link.flush()
            return
        if msg.coordinate_frame == 1:  # MAV_FRAME_LOCAL_NED; other frames are ignored
            m = msg.type_mask

            def group(bits: int, values: tuple[float, float, float]) -> np.ndarray:
                return np.array([np.nan if m & (bits << i) else float(values[i]) for i in range(3)])

            pos = group(1, (msg.x, msg.y, msg.z))
            vel = group(8, (msg.vx, msg.vy, msg.vz))
            acc = np.full(3, np.nan) if m & 512 else group(64, (msg.afx, msg.afy, msg.afz))
            self.flight.set_target(pos, vel, acc, self.now_us)
        if self.lockstep:
            self.advance(1, reply=True)
            self._stepped = (msg.time_boot_ms, self.now_us)

    # --- main loop -------------------------------------------------------------------------------------
    def run(self) -> None:
        """Serve until SIGINT/SIGTERM (or ``self.stop``)."""
        def _stop(signum, frame):  # noqa: ARG001 - signal handler signature
            self.stop = True

        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, _stop)
        dt_wall = self.model.ctrl_dt / self.speedup if not self.lockstep else math.inf
        next_step = time.monotonic()
        next_idle_hb = next_step
        self.telemetry.send_due(self.now_us)
        self.link.flush()
        while not self.stop:
            now = time.monotonic()
            deadline = next_idle_hb if self.lockstep else next_step
            for msg in self.link.poll(min(0.1, max(0.0, deadline - now))):
                try:
                    self.dispatch(msg)
                except Exception as exc:  # a message we mishandle must not take the vehicle down
                    print(f"warning: {msg.get_type()} not handled: {type(exc).__name__}: {exc}", file=sys.stderr)
            now = time.monotonic()
            if self.lockstep:
                if now >= next_idle_hb:
                    if now - self.telemetry.heartbeat_wall >= IDLE_HEARTBEAT_S:
                        self.telemetry.send(HEARTBEAT, self.now_us)
                        self.link.flush()
                    next_idle_hb = self.telemetry.heartbeat_wall + IDLE_HEARTBEAT_S
                continue
            if now - next_step > 0.25:  # far behind (CPU-bound at a high speed-up): drop the backlog
                next_step = now
            while now >= next_step and not self.stop:
                self.advance(1)
                next_step += dt_wall
        self.link.close()
