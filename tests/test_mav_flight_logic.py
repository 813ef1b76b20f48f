"""The pure parts of the flight logic: the vehicle clock, STATUSTEXT on one line, the 3-D score relative
to the baseline at any telemetry rate, and the tlog trial markers (reference RMS, packet loss)."""

from __future__ import annotations

import time
from types import SimpleNamespace

import numpy as np
import pytest

from ksbo_mav.errors import ClockStalled
from ksbo_mav.mav.clock import VehicleClock
from ksbo_mav.mav.commands import Commander, one_line
from ksbo_mav.mav.mission import MIN_SCORE_RATE_HZ, Mission
from ksbo_mav.mav.trajectory import TrialRecorder, end_text, ref_text, start_text
from ksbo_mav.profiles import load_profile
from ksbo_task.flight import Trajectory


def test_clock_waits_on_vehicle_time_not_on_message_count():
    clock = VehicleClock()
    t = [1000]

    def pump(_timeout: float) -> None:  # a vehicle at 10x: 50 Hz telemetry, many messages per vehicle second
        t[0] += 20
        clock.feed(SimpleNamespace(time_boot_ms=t[0]))
        time.sleep(0.002)

    clock.feed(SimpleNamespace(time_boot_ms=t[0]))
    assert clock.wait(3.0, pump) is True
    assert t[0] - 1000 >= 3000  # 3 s of vehicle time, whatever the number of pump calls
    assert clock.wait(10.0, pump, until=lambda: t[0] > 5000) is True and t[0] <= 5020


def test_clock_stall_is_reported():
    clock = VehicleClock()
    clock.feed(SimpleNamespace(time_boot_ms=500))
    with pytest.raises(ClockStalled, match="has not advanced"):
        clock.wait(5.0, lambda _t: time.sleep(0.01), stall_s=0.2)


def test_clock_ignores_old_stamps_and_extrapolates_a_bounded_amount():
    clock = VehicleClock(max_extrapolation_ms=50)
    clock.feed(SimpleNamespace(time_boot_ms=2000))
    clock.feed(SimpleNamespace(time_boot_ms=1990))  # an older stream's sample of an earlier instant
    assert clock.last_ms == 2000
    time.sleep(0.2)
    assert 2000 <= clock.now_ms() <= 2050


def test_statustext_chunks_are_joined_on_one_line():
    link = SimpleNamespace(handlers=[], is_vehicle=lambda m: True)
    cmd = Commander(link)

    def text(s: str, tid: int = 0, seq: int = 0):
        return SimpleNamespace(get_type=lambda: "STATUSTEXT", severity=4, text=s, id=tid, chunk_seq=seq)

    cmd._on_msg(text("Arming denied: Resolve system health failures first\n"))
    a = "Preflight Fail: a very long explanation that does no"
    cmd._on_msg(text(a[:50], tid=7, seq=0))
    cmd._on_msg(text("t fit in one\nmessage", tid=7, seq=1))
    assert cmd.texts[0][1] == "Arming denied: Resolve system health failures first"
    assert cmd.texts[1][1] == one_line(a[:50] + "t fit in one message")
    assert "\n" not in cmd.recent_text()


def test_a_refusal_reason_is_found_after_many_earlier_texts():
    """The mark a command takes before it is sent still counts once the bounded store of texts is full (an onboard
    script's chatter filled it before the arming refusal's reason came)."""
    link = SimpleNamespace(handlers=[], is_vehicle=lambda m: True)
    cmd = Commander(link)

    def text(s: str):
        return SimpleNamespace(get_type=lambda: "STATUSTEXT", severity=6, text=s, id=0, chunk_seq=0)

    for i in range(cmd.texts.maxlen + 5):
        cmd._on_msg(text(f"KSG: chatter {i}"))
    mark = cmd.received
    assert cmd.recent_text(mark) == ""
    cmd._on_msg(text("Arm: Battery 1 below minimum arming voltage"))
    assert cmd.recent_text(mark) == "Arm: Battery 1 below minimum arming voltage"


def _mission() -> Mission:
    return Mission.from_profile(load_profile("ardupilot-copter"))


def _trajectory(m: Mission, err: float, rate_hz: float = 50.0, L: int | None = None) -> Trajectory:
    """Samples at ``rate_hz`` (vehicle time) with a constant north error ``err``."""
    n = m.steps
    T = np.arange(1, int(n * m.dt * rate_hz) + 1) / rate_hz  # s after t0
    refs = np.array([[*m.setpoint_at(t)[0][:1], 0, *m.setpoint_at(t)[0][1:2], 0, 10.0, 0] for t in T])
    states = refs.copy()
    states[:, 0] += err
    steps = np.rint(T / m.dt).astype(int) - 1
    return Trajectory(t=T, steps=steps, states=states, refs=refs, inputs=None, L=n if L is None else L,
                      source="test")


def test_copter_score_is_relative_to_the_baseline():
    m = _mission()
    base = m.score(_trajectory(m, 1.4))  # a vehicle that tracks 1.4 m badly (PX4 SIH) is still its own baseline
    assert base["complete"] and base["rms_lap2_m"] == pytest.approx(1.4) and base["P"] == pytest.approx(0.5)
    assert m.score(_trajectory(m, 0.7), rms_ref=1.4)["P"] == pytest.approx(0.75)
    worse = m.score(_trajectory(m, 3.0), rms_ref=1.4)
    assert worse["P"] < 0 and not worse["safe"]  # more than 2x the baseline's error is "unsafe"
    assert m.score(_trajectory(m, 2.7), rms_ref=1.4)["P"] > 0


def test_copter_score_at_any_rate_above_the_minimum():
    m = _mission()
    slow = m.score(_trajectory(m, 0.2, rate_hz=12.5), rms_ref=0.2)  # a ground station's 12.5 Hz stream
    assert slow["complete"] and slow["rms_lap2_m"] == pytest.approx(0.2) and slow["rate_hz"] == pytest.approx(12.5)
    sparse = m.score(_trajectory(m, 0.2, rate_hz=4.0), rms_ref=0.2)
    assert not sparse["complete"] and sparse["P"] < 0
    assert f"{MIN_SCORE_RATE_HZ:g} Hz" in sparse["incomplete"] and "4.0 Hz" in sparse["incomplete"]
    short = m.score(_trajectory(m, 0.2, L=1500))
    assert not short["complete"] and "1500 of 2000" in short["incomplete"]


def test_recorder_reads_reference_marker_and_counts_lost_packets():
    rec = TrialRecorder(vehicle=(1, 1))

    def sent_text(s: str):
        return SimpleNamespace(get_type=lambda: "STATUSTEXT", text=s)

    def lpn(t: int, seq: int):
        return SimpleNamespace(get_type=lambda: "LOCAL_POSITION_NED", time_boot_ms=t, x=0.0, y=0.0, z=-10.0, vx=0.0,
                               vy=0.0, vz=0.0, get_srcSystem=lambda: 1, get_srcComponent=lambda: 1,
                               get_seq=lambda: seq)

    rec.feed(sent_text(start_text("f8h", 1000, 10, 20, 5)), True)
    rec.feed(sent_text(ref_text("f8h", 0.234567)), True)
    for k, seq in enumerate([10, 11, 14, 15]):  # two packets lost between 11 and 14
        rec.feed(lpn(1020 + 20 * k, seq), False)
    rec.feed(sent_text(end_text("f8h", 10, "ok")), True)
    assert rec.rms_ref == pytest.approx(0.234567) and rec.lost == 2


def test_lost_samples_are_filled_inside_and_held_at_the_ends_of_a_trial():
    """A sample lost at a trial's first or last step has one neighbour: it is held (CI once aborted a lossy-link
    trial as "telemetry too sparse" for one lost last ATTITUDE); inside, short gaps are interpolated; a gap longer
    than MAX_GAP stays missing wherever it is."""
    from ksbo_mav.mav.trajectory import MAX_GAP, _fill

    col = np.column_stack([np.arange(12.0), -np.arange(12.0)])
    col[[0, 4, 5, 11]] = np.nan
    assert _fill(col) == 4
    np.testing.assert_allclose(col[:, 0], [1, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 10])
    long = np.column_stack([np.arange(20.0)])
    long[: MAX_GAP + 1] = np.nan
    long[-3:] = np.nan
    assert _fill(long) == 3 and np.isnan(long[: MAX_GAP + 1]).all() and (long[-3:] == 16).all()
    assert _fill(np.full((3, 2), np.nan)) == 0


def test_a_trip_right_after_the_stream_stalled_is_blamed_on_the_client():
    from ksbo_mav.mav.trial_record import STALL_MS, lag_stats, stall_before

    lag = [0.0] * 300
    lag[250] = 2 * STALL_MS  # the tuner fell 1 s behind at step 250
    assert stall_before(lag, 280) > STALL_MS  # a trip 30 steps later: the client's doing
    assert stall_before(lag, 299 + 200) == 0.0  # long after it: the gains'
    assert stall_before([], 10) == 0.0
    stats = lag_stats(lag, 200)
    assert stats["lag_max_ms"] == 2 * STALL_MS and stats["late_fraction"] == pytest.approx(1 / 100)
