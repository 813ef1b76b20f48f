"""The onboard guard's Lua script on a real ArduCopter SITL, for the two cases its own stop must be read right:

* a trial whose figure-8, flown on board, leaves the guard's box: the guard restores the baseline and brakes; the
  tuner records the gains' abort (fence) with the guard's reason, not a pilot's take-over, and takes the vehicle
  back to GUIDED;
* validation flights flown with the guard armed and their modes declared the tool's own (``KSG_MODES``): a LOITER
  hold and an AUTO waypoint box fly; then the tuner's link is cut mid-hold (the link emulator drops every frame
  both ways): the guard restores the baseline and brakes on board, and once the link is back the tuner takes the
  vehicle back.

The guard's box is made tighter than the tuner's monitor (3 m north against the profile's 15 m) so that the guard,
not the monitor on the ground, is the one that finds the breach. The built-in simulator's version of both:
``test_guard_trip.py``.
"""

from __future__ import annotations

import socket
import struct
import threading
import time

import pytest
from conftest import sitl_or_skip
from guard_helpers import Observer
from onboard_helpers import short_mission
from ksbo_sim.sitl_instances import release_stopped

from ksbo_mav.campaign.onboard import install_guard, remove_guard
from ksbo_mav.mav.guard_script import GUARD_PARAMS, GuardState, modes_mask
from ksbo_mav.mav.link import Endpoint
from ksbo_mav.mav.monitor import Monitor, limits_from_profile
from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.outcome import TrialOutcome as T
from ksbo_mav.mav.tlog import read_tlog
from ksbo_mav.mav.trajectory import trajectory_from_tlog
from ksbo_mav.mav.validation import ManoeuvreSpec, fly_manoeuvre
from ksbo_mav.mav.vehicle import Vehicle

pytestmark = [pytest.mark.sitl, pytest.mark.network, pytest.mark.timeout(600)]

PROFILE = "ardupilot-copter"
SPEEDUP = 5
LOITER = 5


@pytest.fixture(scope="module")
def sitl():
    s = sitl_or_skip("ardupilot", SPEEDUP)  # booted with SCR_ENABLE 1
    yield s
    s.stop()
    release_stopped()


def _centre_sticks(sitl) -> None:
    """Roll, pitch, throttle, yaw at 1500 us on the SITL's RC input: LOITER holds only with centred sticks."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for _ in range(3):
            s.sendto(struct.pack("<16H", *([1500] * 4 + [0] * 12)), ("127.0.0.1", 5501 + 10 * sitl.instance))


def _tripped_at(v: Vehicle) -> list[int]:
    """Vehicle times (ms) of the guard's KSG_ALIVE reports of a trip, appended as they arrive on ``v``'s link."""
    times: list[int] = []

    def on_msg(m) -> None:
        if m.get_type() == "NAMED_VALUE_FLOAT" and str(m.name).rstrip("\0") == "KSG_ALIVE" \
                and m.value == GuardState.TRIPPED:
            times.append(int(m.time_boot_ms))

    v.link.handlers.append(on_msg)
    return times


def test_a_box_the_guard_finds_on_board_is_the_gains_abort(sitl, tmp_path):
    v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", sitl.tcp_port), PROFILE)
    try:
        v.mission = short_mission(v.mission)  # 4 m north: past the guard's 3 m
        base = {n: v.params.read(n) for n in v.gain_map.param_names}
        v.setup_streams()
        install_guard(v, True, base, {"x_max_m": 3.0}, print, on_board=True)
        v.ensure_airborne()
        tripped = _tripped_at(v)
        f = MavlinkObjective(v, base, tmp_path).fly(v.gain_map.from_params(base), label="box")  # no TrialStopped
        message = f.meta["message"]
        assert f.outcome is T.FENCE, (f.outcome, message)
        assert "the onboard guard tripped: box" in message and "north" in message, message
        assert "to GUIDED" in message, message
        assert f.meta["restored"] and v.guard.trip_code() == 2
        assert v.guided.armed and v.guided.in_mode("guided")
        assert {n: v.params.read(n) for n in base} == pytest.approx(base)
        v.ensure_airborne()  # what the next trial does first: the vehicle is the tool's
        _, info, _ = trajectory_from_tlog(read_tlog(f.meta["tlog"]))
        assert tripped, v.guard.texts
        print(f"figure-8 started at vehicle {info['t0_ms']} ms; the guard tripped (code 2, box) at {tripped[0]} ms, "
              f"{(tripped[0] - info['t0_ms']) / 1000:.2f} s into it; trial message: {message}")
        remove_guard(v, print)
        for name, default in GUARD_PARAMS.items():
            assert v.params.read(name) == default
    finally:
        v.close()


@pytest.mark.slow  # default run: a guarded validation flight: test_guard_trip; a link cut on SITL: test_sitl_guard
def test_a_validation_hold_flies_guarded_and_a_link_cut_mid_hold_trips_the_guard(sitl, tmp_path):
    from ksbo_sim.linkproc import LinkEmulator
    from ksbo_sim.process import free_udp_port

    gport = free_udp_port()
    emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}")
    obs = Observer(f"tcp:127.0.0.1:{sitl.tcp_ports[1]}")
    v = Vehicle.connect(Endpoint("udp", "127.0.0.1", gport), PROFILE)
    timers: list[threading.Timer] = []
    try:
        base = {n: v.params.read(n) for n in v.gain_map.param_names}
        v.setup_streams()
        install_guard(v, True, base, {}, print)
        guard = v.guard
        mon = Monitor(limits_from_profile(v.profile), v.stack.modes["guided"], v.stack.mode_name)
        v.ensure_airborne()
        _centre_sticks(sitl)
        hold = ManoeuvreSpec.from_dict("hold", {"seconds": 10})
        ok = fly_manoeuvre(v, hold, mon, gains_label="baseline", tlog_path=tmp_path / "hold.tlog",
                           baseline_params=base)
        assert ok.outcome is T.OK, ok.message
        assert f"KSG: trial armed, modes {int(modes_mask([LOITER]))}" in guard.texts, guard.texts
        assert not any("pilot mode change" in t for t in guard.texts), guard.texts
        assert guard.read("KSG_STATE") == 0 and guard.read("KSG_MODES") == 0
        box = fly_manoeuvre(v, ManoeuvreSpec.from_dict("auto_mission", {}).quick(), mon, gains_label="baseline",
                            tlog_path=tmp_path / "auto.tlog", baseline_params=base)
        assert box.outcome is T.OK, box.message  # AUTO declared the tool's own: no pilot trip
        assert f"KSG: trial armed, modes {int(modes_mask([3]))}" in guard.texts, guard.texts
        assert not any("pilot mode change" in t for t in guard.texts), guard.texts

        # The same hold, 40 s: 1 s (wall) after the heartbeat first shows LOITER, the link is cut for 8 s.
        cut: dict[str, float] = {}

        def on_msg(m) -> None:
            if m.get_type() == "HEARTBEAT" and v.link.is_vehicle(m) and m.custom_mode == LOITER and not timers:
                def do_cut() -> None:
                    cut["ms"], cut["wall"] = v.telemetry.clock.last_ms, time.monotonic()
                    emu.cut()

                timers.extend([threading.Timer(1.0, do_cut), threading.Timer(9.0, emu.reconnect)])
                for t in timers:
                    t.start()

        v.link.handlers.append(on_msg)
        f = fly_manoeuvre(v, ManoeuvreSpec.from_dict("hold", {"seconds": 40}), mon, gains_label="baseline",
                          tlog_path=tmp_path / "cut.tlog", baseline_params=base)
        v.link.handlers.remove(on_msg)
        assert "ms" in cut, "the hold never started"
        assert f.outcome is T.LINK and f.restored is True, (f.outcome, f.message)
        assert "the onboard guard tripped: tuner link lost" in f.message, f.message
        assert "to GUIDED" in f.message, f.message
        assert v.guided.armed and v.guided.in_mode("guided")
        assert guard.trip_code() == 1
        # what the second connection saw on board while the tuner was cut off (read from its backlog)
        assert obs.until(lambda: obs.first_alive(GuardState.TRIPPED, int(cut["ms"])) is not None, 20.0), obs.texts
        tripped_ms = obs.first_alive(GuardState.TRIPPED, int(cut["ms"]))
        print(f"link cut at vehicle {cut['ms']:.0f} ms during the guarded LOITER hold; the guard tripped (code 1, "
              f"link lost) at {tripped_ms} ms: {(tripped_ms - cut['ms']) / 1000:.2f} s of vehicle time "
              f"(its link timeout {guard.config.link_timeout_s:g} s); flight message: {f.message}")
        remove_guard(v, print)
        for name, default in GUARD_PARAMS.items():
            assert v.params.read(name) == default
        v.land()
    finally:
        for t in timers:
            t.cancel()
        v.close()
        obs.close()
        emu.stop()


@pytest.mark.slow
def test_a_vehicle_that_ran_an_older_guard_since_its_boot_is_told_to_reboot(tmp_path):
    """ArduPilot cannot grow a script's parameter table after it was added: a guard of four parameters (before
    ``KSG_MODES``) that ran since boot leaves no room for the fifth, and the new guard says so in one line."""
    from ksbo_mav.mav.ftp_files import put_file
    from ksbo_mav.mav.guard_script import config_for, new_config_id, render_script
    from ksbo_mav.mav.onboard_guard import GuardUnavailable, OnboardGuard

    fresh = sitl_or_skip("ardupilot", SPEEDUP)  # its own boot: no KSG_ table yet
    try:
        v = Vehicle.connect(Endpoint("tcp", "127.0.0.1", fresh.tcp_port), PROFILE)
        try:
            base = {n: v.params.read(n) for n in v.gain_map.param_names}
            cfg = config_for(limits_from_profile(v.profile), 3.0, base, new_config_id())
            older = render_script(cfg).decode().replace('"KSG_", 5)', '"KSG_", 4)')
            older = "\n".join(line for line in older.splitlines() if '"MODES"' not in line)
            texts: list[str] = []
            v.link.handlers.append(lambda m: texts.append(str(m.text)) if m.get_type() == "STATUSTEXT" else None)
            put_file(v.link, "scripts/ksbo_guard.lua", older.encode())
            OnboardGuard(v.link, v.params, v.cmd).restart_scripts()
            deadline = time.monotonic() + 30.0
            while not any(t.startswith("KSG: guard running") for t in texts) and time.monotonic() < deadline:
                v.link.pump(0.2)
            assert any(t.startswith("KSG: guard running") for t in texts), texts  # the older guard runs
            with pytest.raises(GuardUnavailable, match="reboot vehicle") as err:
                OnboardGuard(v.link, v.params, v.cmd).install(config_for(limits_from_profile(v.profile), 3.0, base,
                                                                         new_config_id()))
            print(f"installer: {err.value}")
        finally:
            v.close()
    finally:
        fresh.stop()
        release_stopped()
