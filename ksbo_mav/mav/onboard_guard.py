"""The tuner's side of the onboard guard: install it, arm and disarm it around each trial, remove it at the end.

The protocol is :mod:`ksbo_mav.mav.guard_script`'s. Installing on ArduPilot: scripting must be on
(``SCR_ENABLE`` 1 takes effect after a reboot, so the tuner says so and stops rather than rebooting a vehicle);
the guard counts the link as alive while heartbeats arrive from the system id in ``MAV_GCS_SYSID`` (older
firmware: ``SYSID_MYGCS``), so that is set to the tuner's own id for the campaign and put back on removal
(refused when ``MAV_OPTIONS`` bit 0 makes the vehicle accept MAVLink from that id only: the ground station would be
locked out; run the tuner with that ``--sysid`` instead). The rendered script goes to ``APM/scripts/`` (a flight
controller's SD card) or ``scripts/`` (a SITL's working directory) over MAVLink FTP, then MAV_CMD_SCRIPTING
restarts the scripts and the guard must report this campaign's configuration id within :data:`ALIVE_WAIT_S`.

Removing sets the guard's parameters (``GUARD_PARAMS``: ``KSG_STATE``, ``KSG_TRIP``, ``KSG_F8``, ``KSG_T0``) back to
their defaults, deletes the file and restarts the scripts: the parameters leave the list at the next reboot
(ArduPilot keeps a script's table until then).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from typing import Any

from ksbo_mav.errors import InputError, VehicleError
from ksbo_mav.mav.commands import Commander
from ksbo_mav.mav.ftp_files import list_dir, put_file, remove_file
from ksbo_mav.mav.guard_script import (
    ALIVE_NAME,
    CONFIG_NAME,
    GUARD_PARAMS,
    MODES_PARAM,
    SCRIPT_NAME,
    STATE_PARAM,
    TRIP_PARAM,
    TRIP_REASONS,
    GuardConfig,
    GuardState,
    modes_mask,
    render_script,
)
from ksbo_mav.mav.link import Link
from ksbo_mav.mav.params import Param, ParamClient
from ksbo_mav.mav.wire import mavlink

#: Where ArduPilot looks for scripts: a flight controller's SD card, then a SITL's working directory.
SCRIPT_DIRS = ("APM/scripts", "scripts")
GCS_SYSID_PARAMS = ("MAV_GCS_SYSID", "SYSID_MYGCS")
ALIVE_WAIT_S = 10.0
CMD_SCRIPTING = mavlink.MAV_CMD_SCRIPTING
SCRIPTING_RESTART = mavlink.SCRIPTING_CMD_STOP_AND_RESTART


class GuardUnavailable(VehicleError):
    """The vehicle cannot run the guard now (the message says what to set)."""


class OnboardGuard:
    """One vehicle's guard. ``params``/``cmd`` are the vehicle's services; ``log`` gets one line per step."""

    def __init__(self, link: Link, params: ParamClient, cmd: Commander,
                 log: Callable[[str], None] = lambda s: None) -> None:
        self.link, self.params, self.cmd, self.log = link, params, cmd, log
        self.alive_state: GuardState | None = None
        self.alive_config = 0
        self.alive_wall = 0.0
        self.texts: list[str] = []
        self.config: GuardConfig | None = None
        self.script_path: str | None = None
        self.gcs_sysid_param: str | None = None
        self.gcs_sysid_before: float | None = None
        self._last_beat_ms: int | None = None
        link.handlers.append(self._on_msg)

    # --- what the guard says ------------------------------------------------------------------------------
    def _on_msg(self, msg: Any) -> None:
        if not self.link.is_vehicle(msg):
            return
        self._beat(msg)
        kind = msg.get_type()
        if kind == "NAMED_VALUE_FLOAT":
            name = str(msg.name).rstrip("\0")
            if name == ALIVE_NAME:
                self.alive_state = GuardState(int(msg.value)) if 0 <= msg.value <= 3 else None
                self.alive_wall = time.monotonic()
            elif name == CONFIG_NAME:
                self.alive_config = int(msg.value)
        elif kind == "STATUSTEXT" and str(msg.text).startswith("KSG:"):
            self.texts.append(str(msg.text).rstrip("\0"))

    def answering(self, within_s: float = 2.0) -> bool:
        """The guard of this configuration reported within ``within_s`` seconds (wall: a liveness check)."""
        return (self.config is not None and self.alive_config == self.config.config_id
                and time.monotonic() - self.alive_wall < within_s)

    def last_text(self) -> str:
        return self.texts[-1] if self.texts else ""

    def trip_code(self) -> int:
        """``KSG_TRIP`` read fresh from the vehicle (:data:`TRIP_REASONS`)."""
        return int(self.read(TRIP_PARAM))

    def trip_reason(self) -> str:
        return TRIP_REASONS.get(self.trip_code(), "unknown")

    def _beat(self, msg: Any) -> None:
        """A heartbeat every sixth of the link timeout of *vehicle* time while a guard is installed: the guard counts
        on the vehicle's clock, and the link's own 1 Hz (wall) heartbeat is 10 s of vehicle time on a SITL at 10x
        or a lockstep simulator running ahead."""
        t = getattr(msg, "time_boot_ms", None)
        if self.config is None or t is None or self.link.closed:
            return
        if self._last_beat_ms is None or t < self._last_beat_ms or \
                t - self._last_beat_ms >= self.config.link_timeout_s * 1000.0 / 6.0:
            self._last_beat_ms = int(t)
            self.link.send(self.link.mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                                          mavlink.MAV_STATE_ACTIVE))

    # --- parameters the script adds (not in the list downloaded before it ran) --------------------------------
    def _learn(self, name: str) -> None:
        if name not in self.params.table:
            self.params.table[name] = Param(name, 0.0, mavlink.MAV_PARAM_TYPE_REAL32, -1)

    def read(self, name: str) -> float:
        """One of the guard's parameters (``KSG_*``, :mod:`ksbo_mav.mav.guard_script`), read fresh."""
        self._learn(name)
        return self.params.read(name)

    def write(self, name: str, value: float) -> None:
        """Write one of the guard's parameters, verified by the vehicle's echo."""
        self._learn(name)
        self.params.set_verified(name, value)

    # --- install -------------------------------------------------------------------------------------------
    def check_scripting(self) -> None:
        """:class:`GuardUnavailable` naming what to set when the vehicle runs no scripts."""
        if "SCR_ENABLE" not in self.params.table:
            raise GuardUnavailable("this firmware has no Lua scripting (no SCR_ENABLE): the onboard guard cannot "
                                   "run; fly with --no-onboard-guard to tune without it")
        if self.params.read("SCR_ENABLE") != 1:
            raise GuardUnavailable("the onboard guard needs Lua scripting: set SCR_ENABLE to 1 and reboot the "
                                   "vehicle (or fly with --no-onboard-guard)")

    def _claim_gcs_sysid(self) -> None:
        name = next((n for n in GCS_SYSID_PARAMS if n in self.params.table), None)
        if name is None:
            raise GuardUnavailable("the vehicle has neither MAV_GCS_SYSID nor SYSID_MYGCS: the guard cannot see "
                                   "the tuner's heartbeat")
        ours = self.link.mav.srcSystem
        before = self.params.read(name)
        if int(before) == ours:
            return
        if "MAV_OPTIONS" in self.params.table and int(self.params.read("MAV_OPTIONS")) & 1:
            raise InputError(f"the vehicle accepts MAVLink from {name} {int(before)} only (MAV_OPTIONS bit 0): "
                             f"run ksbo-mav with --sysid {int(before)}")
        self.params.set_verified(name, float(ours))
        self.gcs_sysid_param, self.gcs_sysid_before = name, before
        self.log(f"onboard guard: {name} {int(before)} -> {ours} (the tuner's heartbeat is the guard's link "
                 "check; put back at the end)")

    def _quiet_s(self) -> float:
        """How long a file request's silence counts as its answer: the command waits sized to the link (MAVLink
        FTP's own floor, :data:`~ksbo_mav.mav.ftp_files.QUIET_S`, when they are shorter)."""
        return self.cmd.ack_wait_s

    def _script_dir(self) -> str:
        for d in SCRIPT_DIRS:
            if list_dir(self.link, d, self._quiet_s()) is not None:
                return d
        raise GuardUnavailable(f"no scripts directory on the vehicle ({' or '.join(SCRIPT_DIRS)} over MAVLink FTP)")

    def restart_scripts(self) -> None:
        self.cmd.require("restart of the vehicle's scripts", CMD_SCRIPTING, float(SCRIPTING_RESTART))

    def install(self, config: GuardConfig) -> None:
        """Upload ``config``'s guard, restart the scripts and wait until it reports that configuration. A failed
        install takes back what it changed (the GCS system id, the script) before it raises: nobody else knows of
        this guard yet, so nothing else would."""
        self.check_scripting()
        self._claim_gcs_sysid()
        try:
            self._upload_and_start(config)
        except (VehicleError, InputError):
            try:
                self.remove()
            except (VehicleError, InputError) as exc:
                self.log(f"onboard guard: the failed install was not fully taken back ({exc}); `ksbo-mav restore "
                         "DIR` tries again")
            raise

    def _upload_and_start(self, config: GuardConfig) -> None:
        directory = self._script_dir()
        data = render_script(config)
        self.script_path = f"{directory}/{SCRIPT_NAME}"
        put_file(self.link, self.script_path, data, quiet_s=self._quiet_s())
        self.config = config
        self.restart_scripts()
        deadline = time.monotonic() + ALIVE_WAIT_S
        while not self.answering() and time.monotonic() < deadline:
            self.link.pump(0.1)
        if not self.answering():
            raise GuardUnavailable(f"the onboard guard did not report within {ALIVE_WAIT_S:g} s of the upload to "
                                   f"{self.script_path} ({self.last_text() or 'no KSG STATUSTEXT'}; is "
                                   "SCR_HEAP_SIZE large enough?)")
        self.log(f"onboard guard: running ({self.script_path}, {len(data)} bytes, {len(config.gains)} gains, "
                 f"configuration {config.config_id})")

    # --- trials --------------------------------------------------------------------------------------------
    def _wait_state(self, want: set[GuardState], timeout_s: float = 3.0) -> GuardState | None:
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.alive_state in want:
                return self.alive_state
            self.link.pump(0.05)
        return self.alive_state

    def arm_trial(self, own_modes: Iterable[int] = ()) -> None:
        """Arm the guard for a trial or a validation flight (airborne, in GUIDED, baseline gains still on the
        vehicle or not): it watches until :meth:`disarm_trial`. ``own_modes``: the custom modes the tuner itself
        switches to during this flight besides GUIDED (a validation flight's LOITER or AUTO), which the guard must
        not take for a pilot's (``KSG_MODES``, put back to 0 by the guard when the flight ends).
        :class:`GuardUnavailable` with the guard's reason when it refuses or is silent."""
        if not self.answering():
            raise GuardUnavailable("the onboard guard is not answering (no KSG_ALIVE of this campaign's "
                                   "configuration): not flying a trial without it")
        own = tuple(own_modes)
        if own:
            self.write(MODES_PARAM, modes_mask(own))
        self.alive_state = None
        self.write(STATE_PARAM, float(GuardState.ARMED))
        got = self._wait_state({GuardState.ARMED, GuardState.REFUSED})
        if got != GuardState.ARMED:
            raise GuardUnavailable(f"the onboard guard did not arm the trial ({self.last_text() or got})")

    def disarm_trial(self) -> GuardState | None:
        """End the trial's watch; returns the state the guard was in (TRIPPED: it acted, see :meth:`trip_reason`)."""
        was = self.alive_state
        self.write(STATE_PARAM, float(GuardState.IDLE))
        self._wait_state({GuardState.IDLE})
        return was

    # --- removal -------------------------------------------------------------------------------------------
    def remove(self) -> None:
        """Disarm, put the guard's parameters to their defaults, delete the script, restart the scripts and give
        the GCS system id back. Each step is tried even when an earlier one failed; the first failure is raised."""
        first: Exception | None = None
        steps: list[tuple[str, Callable[[], Any]]] = [
            (name, lambda n=name, v=value: self.write(n, v)) for name, value in GUARD_PARAMS.items()
        ] if self._params_present() else []
        steps.append(("script", self._remove_script))
        if self.gcs_sysid_param is not None:
            steps.append((self.gcs_sysid_param, lambda: self.params.set_verified(self.gcs_sysid_param,
                                                                                   self.gcs_sysid_before)))
        for what, step in steps:
            try:
                step()
            except (VehicleError, InputError) as exc:
                self.log(f"onboard guard: removing {what} failed: {exc}")
                first = first or exc
        self.config = None
        if first is not None:
            raise first
        self.log("onboard guard: removed")

    def _params_present(self) -> bool:
        """The guard's parameters are in the vehicle's list (a guard ran since the last reboot)."""
        self._learn(STATE_PARAM)
        try:
            self.params.read(STATE_PARAM, retries=2)
            return True
        except VehicleError:  # ArduPilot does not answer a name it does not have
            del self.params.table[STATE_PARAM]
            return False

    def _remove_script(self) -> None:
        paths = [self.script_path] if self.script_path else [f"{d}/{SCRIPT_NAME}" for d in SCRIPT_DIRS]
        for path in paths:
            remove_file(self.link, path, self._quiet_s())
        self.restart_scripts()
