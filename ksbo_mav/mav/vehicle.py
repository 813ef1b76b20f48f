"""The vehicle as the tuner sees it, split the way MAVSDK splits services.

:meth:`Vehicle.connect` is the preflight/identity step: heartbeat, AUTOPILOT_VERSION, stack detection, a complete
parameter download, the profile's gain map (refusing profiles meant for another stack) and the telemetry rates
(SET_MESSAGE_INTERVAL only: nothing stored on the vehicle changes). The services:

* ``params`` (:class:`~ksbo_mav.mav.params.ParamClient`) — the parameter protocol;
* ``tuning`` (:class:`~ksbo_mav.mav.gains.GainService`) — trial gain writes inside the trust region, verified
  restores;
* ``telemetry`` (:class:`~ksbo_mav.mav.telemetry.Telemetry`) — latest state, vehicle clock, rates, packet loss;
* ``guided`` (:class:`~ksbo_mav.mav.guided.Guided`) — arming, takeoff, holds, landing, setpoint streaming.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from ksbo_mav.errors import InputError, PilotTookOver, VehicleError
from ksbo_mav.mav.commands import Commander
from ksbo_mav.mav.firmware import check_firmware
from ksbo_mav.mav.gains import GainService
from ksbo_mav.mav.guided import Guided
from ksbo_mav.mav.link import Endpoint, Link
from ksbo_mav.mav.linkcheck import needed_streams
from ksbo_mav.mav.mission import Mission
from ksbo_mav.mav.params import CAPABILITY_FTP, ParamClient
from ksbo_mav.mav.pilot import taken_over
from ksbo_mav.mav.power import PowerWatch
from ksbo_mav.mav.px4_generation import px4_generation, serves_param_file
from ksbo_mav.mav.quieting import SequenceLoss, StreamQuieter, quiet_while_connecting
from ksbo_mav.mav.signing import needs_key
from ksbo_mav.mav.stacks import GainMap, Identity, Stack, default_profile, detect_stack
from ksbo_mav.mav.takeoff_landing import ensure_airborne, land
from ksbo_mav.mav.telemetry import Telemetry
from ksbo_mav.mav.wire import mavlink
from ksbo_mav.profiles import Profile, load_profile

class Vehicle:
    def __init__(self, link: Link, stack: Stack, identity: Identity, params: ParamClient, cmd: Commander,
                 profile: Profile, gain_map: GainMap, streams: StreamQuieter | None = None) -> None:
        self.link, self.stack, self.identity = link, stack, identity
        self.params, self.cmd, self.profile = params, cmd, profile
        #: Profile gain vector <-> autopilot parameters ({name: value}) of this vehicle.
        self.gain_map = gain_map
        self.mission = Mission.from_profile(profile)
        self.is_sim = "SIM_LOCKSTEP" in params.table
        self.lockstep = self.is_sim and params.table["SIM_LOCKSTEP"].value == 1
        self.heartbeat_timeout = float(profile.safety.heartbeat_timeout_s)  # the one source of this timeout
        self.tuning = GainService(params, profile, gain_map)
        self.telemetry = Telemetry(link, cmd, self.mission.rate_hz,
                                   actuators="ACTUATOR_OUTPUT_STATUS" in needed_streams(self.mission.kind))
        self.guided = Guided(link, cmd, stack, self.telemetry, self.heartbeat_timeout, self.lockstep)
        self.power = PowerWatch(link)  # battery figures and the vehicle's STATUSTEXTs
        #: The vehicle's streams asked down on a full link (put back by :meth:`close`), and the watch for a ground
        #: station that asks for them again (:func:`ksbo_mav.campaign.mission_rate.watch_streams`).
        self.streams = streams or StreamQuieter(cmd, stack.name)
        self.stream_watch: Any = None
        #: Airborne in guided by us since our last landing: a later mode change or disarm is not ours to undo.
        self.had_control = False
        #: The onboard guard (:class:`~ksbo_mav.mav.onboard_guard.OnboardGuard`) armed around every trial, if the
        #: campaign installed one.
        self.guard: Any = None
        #: The firmware and how far it has been verified here (docs/firmware.md): said at connect, in the plan and
        #: in the report.
        self.firmware_check = check_firmware(stack.name, identity.flight_sw_version, gain_map.generation,
                                             px4_generation(params.table) if stack.name == "px4" else "")
        #: Where a validation's AUTO mission keeps the user's stored mission while it replaces it (None: memory only).
        self.mission_file: Any = None

    # --- preflight -----------------------------------------------------------------------------------------
    @classmethod
    def connect(cls, endpoint: Endpoint, profile: str | None = None, *, sysid: int | None = None,
                compid: int | None = None, timeout: float = 15.0,
                log: Callable[[str], None] = lambda s: None, param_ftp: bool = True,
                param_cache: bool = True) -> "Vehicle":
        """Connect as ``sysid``/``compid`` (defaults: :data:`~ksbo_mav.mav.link.DEFAULT_SYSID` ...) and download
        every parameter: over MAVLink FTP when the autopilot advertises it and ``param_ftp``, else (or when that
        fails) by the PARAM protocol; with ``param_cache``, a vehicle that hashes its parameter set (PX4) and
        still reports the hash of a set kept on disk is not asked for them again (:mod:`ksbo_mav.mav.params.cache`)."""
        kwargs = {k: v for k, v in (("sysid", sysid), ("compid", compid)) if v is not None}
        link = Link(endpoint, **kwargs)
        seen = SequenceLoss(link)
        streams: StreamQuieter | None = None
        try:
            hb = link.wait_heartbeat(timeout)
            cmd = Commander(link)
            ver = cmd.request_message(mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION")
            seen.stop()
            streams = quiet_while_connecting(cmd, int(hb.autopilot), seen, log)  # a full link: make room first
            if ver is None and streams.asked:
                ver = cmd.request_message(mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION")
            if ver is None:
                raise VehicleError(needs_key(link)
                                   or "the vehicle did not answer REQUEST_MESSAGE(AUTOPILOT_VERSION)")
            if needs_key(link):
                log("the vehicle signs its link but answers unsigned commands here (a USB port?)")
            ident = Identity(sysid=link.target_system, compid=link.target_component, autopilot=int(hb.autopilot),
                             vehicle_type=int(hb.type), vendor_id=int(ver.vendor_id), product_id=int(ver.product_id),
                             flight_sw_version=int(ver.flight_sw_version), capabilities=int(ver.capabilities),
                             uid=int(ver.uid))
            stack = detect_stack(ident)
            cmd.stack = stack
            log(f"vehicle sysid {ident.sysid}: {stack.name} {ident.firmware}, type {ident.vehicle_type}")
            params = ParamClient(link, stack.encoding)
            use_ftp = param_ftp and bool(ident.capabilities & CAPABILITY_FTP)
            if use_ftp and not serves_param_file(stack.name, ident.flight_sw_version):
                log(f"parameters: PX4 {ident.firmware.removesuffix('-official')} serves no @PARAM/param.pck (PX4 "
                    "serves it from 1.19 on, PR #28435): the PARAM protocol")
                use_ftp = False
            table = params.fetch_all(progress=lambda got, n: log(f"parameters: {got} of {n or '?'} so far"),
                                     ftp=use_ftp, cache=stack.name if param_cache and stack.param_hash else None)
            dl = params.last_download
            if params.ftp_failure:
                log(f"parameters: {params.ftp_failure}; falling back to the PARAM protocol")
            how = (f"{dl.path}, {dl.nbytes} bytes" if dl.nbytes else dl.path) + (
                f", {dl.requests} re-requested" if dl.requests else "")
            log(f"parameters: {len(table)} of {params.count} downloaded in {dl.seconds:.1f} s ({how})")
            prof = load_profile(profile or default_profile(ident, stack))
            want = str(prof.vehicle.get("autopilot", ""))
            if want and want != stack.name:
                raise InputError(f"profile {prof.name} is for autopilot {want!r}, the vehicle runs {stack.name}")
            gain_map = GainMap.build(prof.names, stack, table, prof)
            streams.stack_name = stack.name
            vehicle = cls(link, stack, ident, params, cmd, prof, gain_map, streams)
            log(vehicle.firmware_check.line)
            if vehicle.firmware_check.warning:
                log(vehicle.firmware_check.warning)
            return vehicle
        except BaseException:
            if streams is not None and streams.asked:
                try:
                    streams.restore()
                except VehicleError:
                    pass  # the link broke: a reboot puts them back
            link.close()
            raise

    def close(self) -> None:
        """Put back the streams asked down (the autopilot's own rates on this link), then close the link."""
        self.guided.hold_at(None)
        if self.stream_watch is not None:
            self.stream_watch.stop()
        if self.streams.asked and not self.link.closed:
            try:
                self.streams.restore()
            except VehicleError:  # the link broke: a reboot puts them back
                pass
        self.link.close()

    def set_mission_rate(self, rate_hz: int) -> None:
        """Fly the mission at ``rate_hz`` (setpoints sent and telemetry asked for); call :meth:`setup_streams`."""
        self.mission = replace(self.mission, rate_hz=int(rate_hz))
        self.telemetry.rate_wanted = float(rate_hz)

    def setup_streams(self) -> None:
        """LOCAL_POSITION_NED and ATTITUDE at the mission rate by SET_MESSAGE_INTERVAL (no stored change)."""
        if not self.telemetry.request_rates():
            raise VehicleError(f"vehicle refused to stream LOCAL_POSITION_NED/ATTITUDE at {self.mission.rate_hz} Hz")

    # --- shortcuts used across the campaign layer ------------------------------------------------------------
    @property
    def armed(self) -> bool:
        return self.guided.armed

    @property
    def last_lpn(self) -> Any:
        return self.telemetry.last_lpn

    def check_trial_gains(self, x: np.ndarray, baseline: np.ndarray) -> np.ndarray:
        return self.tuning.check_trial(x, baseline)

    def write_gains(self, x: np.ndarray) -> None:
        self.tuning.write(x)

    def restore(self, params: dict[str, float], attempts: int = 3, retries: int = 8) -> None:
        """Write ``{autopilot parameter name: value}`` and verify it by a fresh read."""
        self.tuning.restore(params, attempts, retries)

    def ensure_airborne(self, log: Callable[[str], None] = lambda s: None, at: np.ndarray | None = None) -> None:
        """Hovering at the figure-8 start (or ``at``, NED: a moving start's approach) in guided/offboard (takes off
        from the ground if needed). Once the vehicle has been ours, a mode the tuner did not leave it in or a
        disarmed vehicle is the pilot's (or a ground station's) doing: :class:`PilotTookOver`, nothing commanded."""
        m = self.mission
        # Start tolerance: 5 % of the figure-8's size (0.5 m for the 20 m copter pattern, 4 cm for the planar one).
        ensure_airborne(self.guided, float(m.center_up), m.start_ned() if at is None else np.asarray(at, float),
                        tol=max(0.03, 0.05 * m.scale), log=log, check=self._still_ours)
        self.had_control = True

    def _still_ours(self, hb: Any) -> None:
        if self.is_sim and not hb.base_mode & 128:
            return  # ksbo-mav sim disarms a crashed vehicle and re-arms it at home by design: no pilot did that
        why = taken_over(self.stack, hb) if self.had_control else None
        if why:
            raise PilotTookOver(why)

    def land(self, timeout_s: float = 120.0) -> None:
        land(self.guided, timeout_s)
        self.had_control = False  # landed by us: the next takeoff is ours too

    def statustext(self, text: str, severity: int = 6) -> None:
        """Tell the vehicle / other ground stations (and the tlog) what the tuner is doing."""
        link = self.link
        link.send(link.mav.statustext_encode(severity, text.encode()[:50]))
