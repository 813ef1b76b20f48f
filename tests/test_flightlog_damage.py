"""Damaged and unusual tlogs, made here from a ground station's tlog: a recording that begins mid-record, bytes
inserted in the middle, timestamps from a clock near 1970, a tiny file of one record. The reader resynchronises on
the next record whose frame checksum holds and says what it skipped; detection goes by the records, not the date."""

from __future__ import annotations

import json
import struct

import numpy as np

from flightlog_helpers import write_other_tlog

from ksbo_mav.cli import main
from ksbo_mav.flightlog import detect_format
from ksbo_mav.mav.wire import mavlink


def _score(capsys, path) -> tuple[int, dict, str]:
    rc = main(["score", str(path), "--json"])
    cap = capsys.readouterr()
    return rc, (json.loads(cap.out) if rc == 0 else {}), cap.err


def _lap2(doc: dict) -> float:
    return doc["segments"][0]["figure8"]["laps"][1]["vs_reference"]["h_rms_m"]


def test_a_recording_that_begins_mid_record_is_read_from_the_next_record(tmp_path, capsys) -> None:
    good = write_other_tlog(tmp_path / "good.tlog").read_bytes()
    rc, ref, _ = _score(capsys, tmp_path / "good.tlog")
    assert rc == 0 and not any("skipped" in w for w in ref["warnings"])
    late = tmp_path / "late.tlog"
    late.write_bytes(good[1003:])  # inside a record: the head is not a record start
    assert detect_format(late) == "tlog"
    rc, doc, err = _score(capsys, late)
    assert rc == 0, err
    assert any(w.startswith("skipped ") and "offset 0" in w for w in doc["warnings"])
    assert abs(_lap2(doc) - _lap2(ref)) < 0.01


def test_bytes_inserted_in_the_middle_are_skipped_and_counted(tmp_path, capsys) -> None:
    good = write_other_tlog(tmp_path / "good.tlog").read_bytes()
    rc, ref, _ = _score(capsys, tmp_path / "good.tlog")
    at = len(good) // 2 + 5
    bad = tmp_path / "inserted.tlog"
    bad.write_bytes(good[:at] + np.random.default_rng(7).bytes(64) + good[at:])
    rc, _, err = _score(capsys, bad)  # damage inside a segment: refused whole, told to pass --partial
    assert rc == 2 and "damaged bytes skipped" in err and "--partial" in err and err.count("\n") == 1, err
    rc = main(["score", str(bad), "--json", "--partial"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    doc = json.loads(cap.out)
    warn = [w for w in doc["warnings"] if w.startswith("skipped ")]
    # "skipped 1 damaged span(s): N damaged bytes skipped at offset ..."
    assert len(warn) == 1 and int(warn[0].split(": ")[1].split()[0]) >= 64
    assert abs(_lap2(doc) - _lap2(ref)) < 0.01


def test_timestamps_near_1970_are_a_tlog_all_the_same(tmp_path, capsys) -> None:
    good = bytearray(write_other_tlog(tmp_path / "good.tlog").read_bytes())
    rc, ref, _ = _score(capsys, tmp_path / "good.tlog")
    pos, base = 0, struct.unpack_from(">Q", good, 0)[0]
    while pos < len(good):  # every record's timestamp minus the first: a clock that started at 0
        (stamp,) = struct.unpack_from(">Q", good, pos)
        struct.pack_into(">Q", good, pos, stamp - base + 1000)
        n = good[pos + 9] + (12 if good[pos + 8] == 0xFD else 8) + (13 if good[pos + 8] == 0xFD and good[pos + 10] & 1
                                                                   else 0)
        pos += 8 + n
    epoch = tmp_path / "epoch.tlog"
    epoch.write_bytes(bytes(good))
    rc, doc, err = _score(capsys, epoch)
    assert rc == 0, err
    assert abs(_lap2(doc) - _lap2(ref)) < 1e-9


def test_a_tiny_tlog_of_one_record_is_a_tlog_and_says_what_it_lacks(tmp_path, capsys) -> None:
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    frame = mav.heartbeat_encode(2, 3, 0, 0, 0).pack(mav)
    tiny = tmp_path / "tiny.tlog"
    tiny.write_bytes(struct.pack(">Q", 12_345) + frame + struct.pack(">Q", 12_400) + frame)
    assert detect_format(tiny) == "tlog" and tiny.stat().st_size < 80
    rc, _, err = _score(capsys, tiny)
    assert rc == 2 and "no LOCAL_POSITION_NED" in err and "not a flight log" not in err


def _ground_tlog(path, armed: bool) -> None:
    """GUIDED on the ground for 20 s: heartbeats at 1 Hz, position and the autopilot's target both at the same
    spot at 10 Hz (the target of GUIDED chosen before take-off is where the vehicle stands)."""
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    t_us = 1_700_000_000_000_000
    for k in range(200):
        ms = 100 * k
        frames = []
        if k % 10 == 0:
            frames.append(mav.heartbeat_encode(2, 3, 1 | (128 if armed else 0), 4, 4))  # GUIDED
        frames.append(mav.local_position_ned_encode(ms, 0.01 * np.sin(k), 0.0, -0.02, 0, 0, 0))
        frames.append(mav.position_target_local_ned_encode(ms, 1, 0b110111111000, 0.0, 0.0, -0.02, 0, 0, 0, 0, 0, 0,
                                                           0, 0))
        for f in frames:
            out += struct.pack(">Q", t_us + 1000 * ms) + f.pack(mav)
    path.write_bytes(bytes(out))


def test_guided_on_the_ground_is_not_scored_as_perfect_tracking(tmp_path, capsys) -> None:
    for armed in (False, True):  # GUIDED chosen before arming; armed but never lifted off
        p = tmp_path / f"ground-{armed}.tlog"
        _ground_tlog(p, armed)
        rc, _, err = _score(capsys, p)
        assert rc == 2 and "\n" not in err.strip(), err
        if armed:
            assert "too little motion" in err and "moved 0.00 m" in err


def _global_target_tlog(path, origin=(47.397742, 8.545594, 488.0), relayed: bool = False) -> None:
    """The ground station's tlog of write_other_tlog, but the vehicle's target only as POSITION_TARGET_GLOBAL_INT
    (above home) and its position also as GLOBAL_POSITION_INT: what ArduPilot's default streams give a ground
    station. ``relayed``: as MAVProxy records a flight flown by a client behind it: the vehicle's global target only
    during the take-off (ArduCopter sends none while it follows streamed setpoints), the client's
    SET_POSITION_TARGET_LOCAL_NED relayed and recorded without a direction flag."""
    from flightlog_helpers import MASK_POS_VEL_ACC, T_DISARM, T_GUIDED, T_LAND, error, on_ground, target

    from ksbo_mav.flightlog.geo import R_EARTH
    from ksbo_mav.mav.tlog import LINK_RECEIVED, TlogWriter

    lat0, lon0, amsl0 = origin
    veh, gcs = mavlink.MAVLink(None, srcSystem=1, srcComponent=1), mavlink.MAVLink(None, 255, 190)
    wr = TlogWriter(path)
    now = [0]

    def put(msg, mav=veh):  # the ground station's clock follows the vehicle's
        wr.write(msg.pack(mav), LINK_RECEIVED, 1_700_000_000_000_000 + 1000 * now[0])

    def glob(ned):
        lat = lat0 + np.degrees(ned[0] / R_EARTH)
        lon = lon0 + np.degrees(ned[1] / (R_EARTH * np.cos(np.radians(lat0))))
        return int(round(lat * 1e7)), int(round(lon * 1e7)), -ned[2]

    k, t = 0, 1.0
    while t < T_DISARM:
        ms = now[0] = int(round(t * 1000))
        if k % 50 == 0:
            mode = 4 if T_GUIDED <= t < T_LAND else (9 if t >= T_LAND else 0)
            put(veh.heartbeat_encode(2, 3, 128 | 1 if t >= 5 else 1, mode, 4, 3))
        p, v = target(t)
        a = p + error([t])[0] if t >= T_GUIDED else on_ground(p)
        put(veh.local_position_ned_encode(ms, *a, *v))
        la, lo, up = glob(a)
        put(veh.global_position_int_encode(ms, la, lo, int((amsl0 + up) * 1000), int(up * 1000), 0, 0, 0, 0))
        if relayed and T_GUIDED <= t < T_GUIDED + 2.0 and k % 10 == 0:
            la, lo, up = glob(p)
            put(veh.position_target_global_int_encode(ms, 6, 0b110111111000, la, lo, up, 0, 0, 0, 0, 0, 0, 0, 0))
        elif relayed and T_GUIDED <= t < T_LAND:
            put(gcs.set_position_target_local_ned_encode(ms, 1, 1, 1, MASK_POS_VEL_ACC, *p, *v, 0, 0, 0, 0, 0), gcs)
        elif T_GUIDED <= t < T_LAND:
            la, lo, up = glob(p)
            put(veh.position_target_global_int_encode(ms, 6, 0b110111111000, la, lo, up, *v, 0, 0, 0, 0, 0))
        k += 1
        t = 1.0 + k * 0.02
    wr.close()


def test_targets_in_global_coordinates_are_scored_in_the_logs_own_local_frame(tmp_path, capsys) -> None:
    """A tlog with only POSITION_TARGET_GLOBAL_INT (used to be "no position targets") scores as the same flight
    against its local setpoints does, within a millimetre."""
    ref_path = write_other_tlog(tmp_path / "local.tlog")
    rc, ref, err = _score(capsys, ref_path)
    assert rc == 0, err
    glob = tmp_path / "global.tlog"
    _global_target_tlog(glob)
    rc, doc, err = _score(capsys, glob)
    assert rc == 0, err
    assert doc["target_source"].startswith("POSITION_TARGET_GLOBAL_INT")
    a, b = ref["segments"][0]["vs_target"], doc["segments"][0]["vs_target"]
    assert abs(a["h_rms_m"] - b["h_rms_m"]) < 1e-3 and abs(a["v_rms_m"] - b["v_rms_m"]) < 1e-3


def test_a_relay_s_tlog_is_scored_against_the_relayed_setpoints(tmp_path, capsys) -> None:
    """MAVProxy's tlog of a flight flown by a client behind it: the vehicle's POSITION_TARGET_GLOBAL_INT covers only
    the take-off (it used to be taken as the target, stood still, and the flight was refused as "too little
    motion"); the relayed SET_POSITION_TARGET_LOCAL_NED are the targets, and the log says why."""
    ref_path = write_other_tlog(tmp_path / "local.tlog")
    rc, ref, err = _score(capsys, ref_path)
    assert rc == 0, err
    relay = tmp_path / "relay.tlog"
    _global_target_tlog(relay, relayed=True)
    rc, doc, err = _score(capsys, relay)
    assert rc == 0, err
    assert doc["target_source"].startswith("SET_POSITION_TARGET_LOCAL_NED")
    assert any("POSITION_TARGET_GLOBAL_INT covers only" in w for w in doc["warnings"])
    assert abs(_lap2(doc) - _lap2(ref)) < 1e-3


def test_damage_whose_time_before_was_overwritten_counts_inside_every_segment() -> None:
    """The record the damage cut in two can carry a timestamp of 0xFF bytes (here 2^64 us, as in a PX4 SITL log
    with 4 kB overwritten): a span 'from 18446744073709.6 s to 57.9 s' cannot be placed, so a segment it may
    touch is refused rather than scored as whole."""
    from pathlib import Path

    from ksbo_mav.flightlog.analysis import damage_in
    from ksbo_mav.flightlog.model import FlightLog, Segment, Skipped

    log = FlightLog(Path("x.ulg"), "ulg", "px4", None, None, None, [])  # type: ignore[arg-type]
    log.skipped = [Skipped(13672940, 4097, t_before=18446744073709.6, t_after=57.9, why="record type 0xff")]
    assert damage_in(log, Segment(1, 38.3, 86.3, "OFFBOARD", False))
    log.skipped = [Skipped(100, 10, t_before=10.0, t_after=12.0)]
    assert not damage_in(log, Segment(1, 38.3, 86.3, "OFFBOARD", False))  # a placed span before it: not inside
