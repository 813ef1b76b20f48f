"""Logs as they come from the field, made here: an unwritable plot path, ground time that must not be scored, a
DataFlash log that disarms and re-arms, a tiny tlog with a clock near the epoch, damaged and mid-stream copies."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from flightlog_helpers import MISSION, DFWriter, write_bin, write_other_tlog, write_ulg

from ksbo_mav.cli import main
from ksbo_mav.flightlog import detect_format, read_log
from ksbo_mav.mav.tlog import LINK_RECEIVED, TlogWriter
from ksbo_mav.mav.wire import mavlink


def one_line_error(capsys, *argv) -> str:
    rc = main([*map(str, argv)])
    out, err = capsys.readouterr()
    assert rc == 2 and "Traceback" not in err and err.startswith("error: ") and err.count("\n") == 1, (out, err)
    return err


def test_unwritable_plot_path_is_one_line(tmp_path, capsys):
    log = write_bin(tmp_path / "a.bin")
    (tmp_path / "file").write_text("x")
    err = one_line_error(capsys, "score", log, "--plot", tmp_path / "file" / "sub" / "p.png")
    assert "cannot write plot" in err
    err = one_line_error(capsys, "compare", log, log, "--plot", tmp_path / "file" / "p.png")
    assert "cannot write plot" in err


def _ground_bin(path, arm: bool, height: float):
    """GUIDED chosen at t=5 s; armed at t=10 s if ``arm`` (else disarmed throughout); the vehicle follows a
    moving target ``height`` m up."""
    w = DFWriter()
    w.define(120, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    w.define(186, "ARM", "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method")
    for i, ax in enumerate("NED"):
        w.define(200 + i, f"PSC{ax}", "Qfffffffff",
                 f"TimeUS,DP{ax},TP{ax},P{ax},DV{ax},TV{ax},V{ax},DA{ax},TA{ax},A{ax}")
    us = lambda t: int(t * 1e6)  # noqa: E731
    w.msg("MODE", us(1), 0, 0, 1)
    w.msg("MODE", us(5), 4, 4, 2)
    w.msg("ARM", us(10 if arm else 2), 1 if arm else 0, 0, 0, 1)  # armed at 10 s, or a disarm logged at 2 s
    for k in range(400):
        t = 1 + 0.1 * k
        p = (math.sin(0.2 * t) * 3, 0.0, -height)
        for i, ax in enumerate("NED"):
            w.msg(f"PSC{ax}", us(t), p[i], p[i], p[i], 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    path.write_bytes(bytes(w.buf))
    return path


def test_ground_time_is_not_scored(tmp_path, capsys):
    err = one_line_error(capsys, "score", _ground_bin(tmp_path / "disarmed.bin", arm=False, height=5.0))
    assert "no segment where the vehicle tracked" in err and "DISARMED" in err  # GUIDED chosen, never armed
    err = one_line_error(capsys, "score", _ground_bin(tmp_path / "ground.bin", arm=True, height=0.04))
    assert "on the ground" in err and "take-off point" in err  # armed, never above 0.04 m
    rc = main(["score", str(_ground_bin(tmp_path / "hover.bin", arm=True, height=0.0)), "--json"])
    assert rc == 2  # never 0.000 m "perfect" for ground time
    capsys.readouterr()


def test_dataflash_sees_rearm(tmp_path):
    w = DFWriter()
    w.define(120, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    w.define(186, "ARM", "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method")
    w.define(200, "PSCN", "Qfffffffff", "TimeUS,DPN,TPN,PN,DVN,TVN,VN,DAN,TAN,AN")
    w.define(201, "PSCE", "Qfffffffff", "TimeUS,DPE,TPE,PE,DVE,TVE,VE,DAE,TAE,AE")
    w.define(202, "PSCD", "Qfffffffff", "TimeUS,DPD,TPD,PD,DVD,TVD,VD,DAD,TAD,AD")
    for t, what in ((1, ("MODE", 1e6, 4, 4, 1)), (2, ("ARM", 2e6, 1, 0, 0, 1)), (3, ("ARM", 3e6, 0, 0, 0, 1)),
                    (4, ("ARM", 4e6, 1, 0, 0, 1))):
        w.msg(what[0], *[int(what[1])] + list(what[2:]))
    for k in range(60):
        for ax in "NED":
            w.msg(f"PSC{ax}", int(1e6 + k * 1e5), *([0.0] * 9))
    (tmp_path / "rearm.bin").write_bytes(bytes(w.buf))
    modes = read_log(tmp_path / "rearm.bin").modes
    assert [(m.t, m.name, m.tracking) for m in modes] == [(1.0, "DISARMED", False), (2.0, "GUIDED", True),
                                                          (3.0, "DISARMED", False), (4.0, "GUIDED", True)]


def test_tiny_tlog_with_epoch_clock_is_a_tlog(tmp_path, capsys):
    veh = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    path = tmp_path / "tiny.tlog"
    w = TlogWriter(path)
    w.write(veh.heartbeat_encode(2, 3, 1, 0, 3, 3).pack(veh), LINK_RECEIVED, 1_000_000)
    w.write(veh.statustext_encode(6, b"ArduCopter V3.4.6").pack(veh), LINK_RECEIVED, 1_001_000)
    w.close()
    assert path.stat().st_size < 100
    assert detect_format(path) == "tlog"
    err = one_line_error(capsys, "score", path)
    assert "has no LOCAL_POSITION_NED" in err and "3.4.6" in err and "SRn_POSITION" in err
    assert "SET_MESSAGE_INTERVAL" in err  # named as what this version lacks


def test_segments_skipped_are_listed(tmp_path, capsys):
    rc = main(["score", str(write_other_tlog(tmp_path / "a.tlog")), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and len(out["segments"]) == 1 and out["skipped_segments"] == []
    assert out["segments"][0]["t_start_s"] > 10.0 - 1e-6  # from when it was airborne in GUIDED


@pytest.mark.parametrize("writer", [write_bin, write_ulg, write_other_tlog])
def test_ground_reference_kept_for_flights(tmp_path, capsys, writer):
    assert main(["score", str(writer(tmp_path / "x.log")), "--json"]) == 0
    seg = json.loads(capsys.readouterr().out)["segments"][0]
    assert seg["figure8"]["laps_flown"] == pytest.approx(MISSION.laps, abs=0.05)


WRITERS = {"tlog": write_other_tlog, "bin": write_bin, "ulg": write_ulg}


def _inserted(good: bytes, at: float) -> bytes:
    i = int(len(good) * at)
    return good[:i] + bytes(range(100, 164)) + good[i:]  # 64 bytes of garbage


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_damage_inside_a_segment_same_partial_semantics(tmp_path, capsys, fmt):
    good = WRITERS[fmt](tmp_path / f"good.{fmt}").read_bytes()
    bad = tmp_path / f"bad.{fmt}"
    bad.write_bytes(_inserted(good, 0.5))
    err = one_line_error(capsys, "score", bad)  # without --partial: the damaged segment is refused, one line
    assert "segment 1" in err and "damaged bytes skipped at offset" in err and "--partial" in err
    assert main(["score", str(bad), "--partial", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (span,) = out["damaged_spans"]
    assert 64 <= span["nbytes"] < 64 + 200 and span["t_before"] is not None and span["t_after"] is not None
    assert 10.0 < span["t_before"] <= span["t_after"] < 62.0
    assert any("incomplete" in w for w in out["warnings"]) and out["segments"][0]["figure8"]


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_damage_outside_segments_is_skipped_and_reported(tmp_path, capsys, fmt):
    good = WRITERS[fmt](tmp_path / f"good.{fmt}").read_bytes()
    bad = tmp_path / f"bad.{fmt}"
    bad.write_bytes(_inserted(good, 0.98))  # after landing
    assert main(["score", str(bad), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["damaged_spans"]) == 1 and any("skipped 1 damaged span" in w for w in out["warnings"])
    assert out["segments"][0]["figure8"]["score"]["P"] is not None


@pytest.mark.parametrize("fmt,cut", [("tlog", 5), ("tlog", 1024), ("bin", 50)])
def test_recording_that_starts_mid_stream(tmp_path, capsys, fmt, cut):
    """The first bytes are not a record start (a tlog cut mid-frame; a DataFlash log whose first FMT is cut):
    the reader finds the first good record and reports what it skipped."""
    good = WRITERS[fmt](tmp_path / f"good.{fmt}").read_bytes()
    bad = tmp_path / f"mid.{fmt}"
    bad.write_bytes(good[cut:])
    assert detect_format(bad) == fmt
    assert main(["score", str(bad), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["damaged_spans"][0]["offset"] == 0 and out["segments"]


def test_ulog_head_cut_is_one_line(tmp_path, capsys):
    good = write_ulg(tmp_path / "good.ulg").read_bytes()
    (tmp_path / "mid.ulg").write_bytes(good[1024:])
    err = one_line_error(capsys, "score", tmp_path / "mid.ulg")
    assert "not a flight log" in err  # the ULog header and definitions are gone: nothing can be decoded
    (tmp_path / "headless.ulg").write_bytes(good[16:])  # the header alone cut: the formats show what it was
    err = one_line_error(capsys, "score", tmp_path / "headless.ulg")
    assert "looks like a PX4 ULog whose head is missing" in err


# --- targets the log has, whatever the message set --------------------------------------------------------------
LAT0, LON0, ALT0 = 47.397742, 8.545594, 488.0  # origin of the synthetic flights (deg, deg, m AMSL)


def _global_tlog(path, origin_msg: bool):
    """ArduPilot's default streams: LOCAL_POSITION_NED, GLOBAL_POSITION_INT and POSITION_TARGET_GLOBAL_INT
    (frame GLOBAL_INT, altitude AMSL), no local targets; GPS_GLOBAL_ORIGIN if ``origin_msg``."""
    from flightlog_helpers import T_DISARM, T_GUIDED, T_LAND, error, on_ground, target

    from ksbo_mav.flightlog.geo import R_EARTH

    veh = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    w = TlogWriter(path)
    usec = [1_700_000_000_000_000]

    def put(msg):
        usec[0] += 1000
        w.write(msg.pack(veh), LINK_RECEIVED, usec[0])

    def to_global(p):
        lat = LAT0 + math.degrees(p[0] / R_EARTH)
        lon = LON0 + math.degrees(p[1] / (R_EARTH * math.cos(math.radians(LAT0))))
        return int(round(lat * 1e7)), int(round(lon * 1e7)), ALT0 - p[2]

    put(veh.statustext_encode(6, b"ArduCopter V4.5.7 (2a3dc4b7)"))
    if origin_msg:
        put(veh.gps_global_origin_encode(int(LAT0 * 1e7), int(LON0 * 1e7), int(ALT0 * 1000)))
    k, t = 0, 1.0
    while t < T_DISARM:
        ms = int(round(t * 1000))
        if k % 50 == 0:
            mode = 4 if T_GUIDED <= t < T_LAND else (9 if t >= T_LAND else 0)
            put(veh.heartbeat_encode(2, 3, 128 | 1 if t >= 5 else 1, mode, 4, 3))
        p, v = target(t)
        a = p + error([t])[0] if t >= T_GUIDED else on_ground(p)
        put(veh.local_position_ned_encode(ms, *a, *v))
        if k % 5 == 0:
            la, lo, alt = to_global(a)
            put(veh.global_position_int_encode(ms, la, lo, int(alt * 1000), int(-a[2] * 1000), 0, 0, 0, 0))
        if k % 5 == 2 and T_GUIDED <= t < T_LAND:
            la, lo, alt = to_global(p)
            put(veh.position_target_global_int_encode(ms, 5, 0b110111000000, la, lo, alt, *v, 0, 0, 0, 0, 0))
        k += 1
        t = 1.0 + k * 0.02
    w.close()
    return path


@pytest.mark.parametrize("origin_msg", [True, False])
def test_global_targets_converted_with_the_logs_origin(tmp_path, capsys, origin_msg):
    from flightlog_helpers import EV, H_RMS

    assert main(["score", str(_global_tlog(tmp_path / "g.tlog", origin_msg)), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "POSITION_TARGET_GLOBAL_INT" in out["target_source"]
    assert ("GPS_GLOBAL_ORIGIN" if origin_msg else "pairs") in out["target_source"]
    f8 = out["segments"][0]["figure8"]
    lap = f8["laps"][1]["vs_target"]
    assert lap["h_rms_m"] == pytest.approx(H_RMS, rel=0.05) and lap["v_rms_m"] == pytest.approx(EV, abs=0.01)


def _old_bin(path, msgs: str, banner: str, psc: bool = True):
    """A Copter 3.x (NTUN in cm + CTUN) or 4.0 (PSC in m + CTUN) DataFlash log, EV for arming, the figure-8."""
    from flightlog_helpers import T_DISARM, T_GUIDED, T_LAND, error, target

    w = DFWriter()
    w.define(32, "PARM", "QNf", "TimeUS,Name,Value")
    w.define(120, "MODE", "QMB", "TimeUS,Mode,ModeNum")
    w.define(59, "MSG", "QZ", "TimeUS,Message")
    w.define(25, "EV", "QB", "TimeUS,Id")
    w.define(11, "CTUN", "Qfffffffh", "TimeUS,ThI,ThO,DAlt,Alt,BAlt,DSAlt,SAlt,CRt")
    if msgs == "NTUN":
        w.define(12, "NTUN", "Qffffffffff", "TimeUS,DPosX,DPosY,PosX,PosY,DVelX,DVelY,VelX,VelY,DAccX,DAccY")
    else:
        w.define(12, "PSC", "Qffffffffffff", "TimeUS,TPX,TPY,PX,PY,TVX,TVY,VX,VY,TAX,TAY,AX,AY")
    us = lambda t: int(round(t * 1e6))  # noqa: E731
    w.msg("MSG", us(0.5), banner)
    w.msg("PARM", us(0.5), "LOG_BITMASK", 830.0)
    w.msg("MODE", us(1.0), 0, 0)
    w.msg("EV", us(5.0), 10)
    w.msg("MODE", us(T_GUIDED), 4, 4)
    w.msg("MODE", us(T_LAND), 9, 9)
    w.msg("EV", us(T_DISARM), 11)
    for k in range(int((T_DISARM - 1.0) / 0.1)):
        t = 1.0 + k * 0.1
        p, v = target(t)
        a = p + error([t])[0] if t >= T_GUIDED else np.array([p[0], p[1], 0.0])
        w.msg("CTUN", us(t), 0.0, 0.4, -p[2], -a[2], 0.0, 0.0, 0.0, int(-v[2] * 100))
        if psc and T_GUIDED <= t <= T_LAND:
            s = 100.0 if msgs == "NTUN" else 1.0
            row = (p[0] * s, p[1] * s, a[0] * s, a[1] * s, v[0] * s, v[1] * s, v[0] * s, v[1] * s, 0.0, 0.0)
            w.msg(msgs, us(t), *(row if msgs == "NTUN" else row + (0.0, 0.0)))
    path.write_bytes(bytes(w.buf))
    return path


@pytest.mark.parametrize("msgs,banner", [("NTUN", "APM:Copter V3.6.12 (0fb0b7e3)"),
                                         ("PSC", "ArduCopter V4.0.7 (0bb18a15)")])
def test_older_message_sets_are_scored(tmp_path, capsys, msgs, banner):
    from flightlog_helpers import EV, H_RMS

    assert main(["score", str(_old_bin(tmp_path / "old.bin", msgs, banner)), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert msgs in out["target_source"] and "CTUN" in out["target_source"]
    assert out["version"].endswith(banner.split(" V")[1].split(" ")[0])
    (seg,) = out["segments"]
    assert seg["mode"] == "GUIDED"
    lap = seg["figure8"]["laps"][1]["vs_target"]
    assert lap["h_rms_m"] == pytest.approx(H_RMS, rel=0.05) and lap["v_rms_m"] == pytest.approx(EV, rel=0.05)


def test_old_log_without_position_messages_gets_this_versions_remedy(tmp_path, capsys):
    path = _old_bin(tmp_path / "nopsc.bin", "PSC", "APM:Copter V3.7.0 (1234abcd)", psc=False)
    err = one_line_error(capsys, "score", path)
    assert "ArduCopter 3.7.0 found" in err and "PSC and CTUN" in err and "GUIDED was flown" in err
    assert "never flew" not in err


def test_ulog_flown_only_manual_is_not_told_to_change_the_profile(tmp_path, capsys):
    import struct

    out = bytearray(b"ULog\x01\x12\x35\x01" + struct.pack("<Q", 0))
    rec = lambda t, p: struct.pack("<HB", len(p), t[0]) + p  # noqa: E731
    out += rec(b"F", b"vehicle_local_position:uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz;")
    out += rec(b"F", b"vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;")
    out += rec(b"A", struct.pack("<BH", 0, 0) + b"vehicle_local_position")
    out += rec(b"A", struct.pack("<BH", 0, 1) + b"vehicle_status")
    for k in range(500):
        t = int(1e6 + k * 2e4)
        if k % 50 == 0:
            out += rec(b"D", struct.pack("<HQBB", 1, t, 15 if k > 100 else 0, 2))  # MANUAL, then STAB
        out += rec(b"D", struct.pack("<HQ6f", 0, t, 0.0, 0.0, -2.0, 0.0, 0.0, 0.0))
    (tmp_path / "manual.ulg").write_bytes(bytes(out))
    err = one_line_error(capsys, "score", tmp_path / "manual.ulg")
    assert "flown only in MANUAL, STAB" in err and "whatever SDLOG_PROFILE is" in err


def _oscillating_bin(path, hz: float, amp: float, param_change_at: float | None = None):
    """GUIDED, airborne at 10 m, a target moving north at 1 m/s; the vehicle follows it with an ``amp`` m
    oscillation at ``hz`` east; optionally PSC_POSXY_P changed in flight."""
    w = DFWriter()
    w.define(32, "PARM", "QNf", "TimeUS,Name,Value")
    w.define(120, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    for i, ax in enumerate("NED"):
        w.define(200 + i, f"PSC{ax}", "Qfffffffff",
                 f"TimeUS,DP{ax},TP{ax},P{ax},DV{ax},TV{ax},V{ax},DA{ax},TA{ax},A{ax}")
    us = lambda t: int(round(t * 1e6))  # noqa: E731
    w.msg("PARM", us(0.5), "PSC_POSXY_P", 1.0)
    w.msg("MODE", us(1.0), 4, 4, 1)
    for k in range(int(60 / 0.05)):
        t = 1.0 + k * 0.05
        if param_change_at is not None and abs(t - param_change_at) < 1e-9:
            w.msg("PARM", us(t), "PSC_POSXY_P", 1.5)
        tp = (t - 1.0, 0.0, -10.0)
        a = (tp[0], amp * math.sin(2 * math.pi * hz * t), -10.0)
        for i, ax in enumerate("NED"):
            w.msg(f"PSC{ax}", us(t), tp[i], tp[i], a[i], 0.0, 1.0 if i == 0 else 0.0, 0.0, 0.0, 0.0, 0.0)
    w.msg("MODE", us(61.5), 9, 9, 1)
    path.write_bytes(bytes(w.buf))
    return path


def test_error_spectrum_shows_an_oscillation(tmp_path, capsys):
    assert main(["score", str(_oscillating_bin(tmp_path / "osc.bin", 1.2, 0.1)), "--json"]) == 0
    sp = json.loads(capsys.readouterr().out)["segments"][0]["spectrum"]
    assert sp["fs_hz"] == pytest.approx(20.0) and sp["peak_hz"] == pytest.approx(1.2, abs=0.03)
    assert sp["peak_amp_m"] == pytest.approx(0.1, rel=0.15)


def test_segment_split_where_a_tuned_parameter_changed(tmp_path, capsys):
    path = _oscillating_bin(tmp_path / "split.bin", 0.5, 0.05, param_change_at=31.0)
    assert main(["score", str(path), "--json"]) == 0
    segs = json.loads(capsys.readouterr().out)["segments"]
    assert [round(s["t_start_s"], 1) for s in segs] == [1.0, 31.0]
    assert segs[1]["note"] == "PSC_POSXY_P 1 -> 1.5"


def test_too_little_motion_is_refused_with_the_reason(tmp_path, capsys):
    w = DFWriter()
    w.define(120, "MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn")
    for i, ax in enumerate("NED"):
        w.define(200 + i, f"PSC{ax}", "Qfffffffff",
                 f"TimeUS,DP{ax},TP{ax},P{ax},DV{ax},TV{ax},V{ax},DA{ax},TA{ax},A{ax}")
    w.msg("MODE", 1_000_000, 4, 4, 1)
    for k in range(300):
        for i, ax in enumerate("NED"):
            w.msg(f"PSC{ax}", 1_000_000 + k * 100_000, *([-10.0 if i == 2 else 0.1 * (k % 2)] * 9))
    w.msg("MODE", 31_000_000, 9, 9, 1)
    (tmp_path / "hover.bin").write_bytes(bytes(w.buf))
    err = one_line_error(capsys, "score", tmp_path / "hover.bin")
    assert "too little motion to judge" in err and "target moved 0.10 m" in err
