"""`ksbo-mav score FILE.tlog` and the strict tlog reader, on synthetic two-way tlogs (no network):
exact P(a) from the log alone, interpolation across lost samples, clear errors for empty / truncated / corrupted /
foreign / unfinished logs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ksbo_mav.cli import main
from ksbo_mav.mav.mission import MASK_POS_VEL_ACC, Mission
from ksbo_mav.mav.tlog import LINK_RECEIVED, LINK_SENT, TlogWriter, read_tlog
from ksbo_mav.mav.trajectory import end_text, start_text
from ksbo_mav.mav.wire import mavlink, mavutil
from ksbo_mav.profiles import load_profile
from ksbo_mav.scoring import score
from ksbo_task.figure8 import Figure8

T0, DT = 10_000, 20
OFFSET = np.array([0.03, 0.0, -0.02, 0.0, 0.01, 0.0])  # flown = reference + offset (planar x, vx, z, vz, th, om)


def write_trial(path: Path, drop: set[int] = frozenset(), end: bool = True, L: int | None = None) -> dict:
    """A trial tlog as the tuner writes it; returns the arrays the score should see (float32 as on the wire)."""
    prof = load_profile("sim-planar")
    m = Mission.from_profile(prof)
    n = m.steps
    L = n if L is None else L
    veh, gcs = mavlink.MAVLink(None, srcSystem=1, srcComponent=1), mavlink.MAVLink(None, 245, 191)
    w = TlogWriter(path)
    usec = [1_700_000_000_000_000]

    def put(mav, msg, link):
        usec[0] += 1000
        w.write(msg.pack(mav), link, usec[0])

    put(veh, veh.heartbeat_encode(2, 0, 153, 4, 4, 3), LINK_RECEIVED)
    put(gcs, gcs.heartbeat_encode(6, 8, 0, 0, 4, 3), LINK_SENT)
    put(gcs, gcs.statustext_encode(6, start_text("f8", T0, n, DT, n // 2).encode()), LINK_SENT)
    states, refs, inputs = [], [], []
    for j in range(L + 1):
        pos, vel, acc = m.setpoint(j)
        t = T0 + j * DT
        put(gcs, gcs.set_position_target_local_ned_encode(t, 1, 1, 1, MASK_POS_VEL_ACC, *pos, *vel, *acc, 0, 0),
            LINK_SENT)
        if j == L:
            break
        ref = Figure8().state((j + 1) * m.dt)
        s = ref + OFFSET
        tt = T0 + (j + 1) * DT
        if j not in drop:
            put(veh, veh.local_position_ned_encode(tt, s[0], 0, -s[2], s[1], 0, -s[3]), LINK_RECEIVED)
        put(veh, veh.attitude_encode(tt, 0, -s[4], 0, 0, -s[5], 0), LINK_RECEIVED)
        put(veh, veh.actuator_output_status_encode(tt * 1000, 2, [0.13, 0.135] + [0.0] * 30), LINK_RECEIVED)
        states.append(s)
        refs.append(ref)
        inputs.append([0.13, 0.135])
    if end:
        put(gcs, gcs.statustext_encode(6, end_text("f8", L, "ok" if L == n else "fence").encode()), LINK_SENT)
    w.close()
    f32 = lambda a: np.asarray(a, dtype=np.float32).astype(float)  # noqa: E731
    return {"states": f32(states), "refs": f32(refs), "inputs": f32(inputs), "n": n, "L": L}


def run_score(capsys, path) -> tuple[int, dict | None, str]:
    rc = main(["score", str(path), "--json"])
    out, err = capsys.readouterr()
    return rc, (json.loads(out) if rc == 0 else None), err


def test_score_from_tlog_is_exact(tmp_path, capsys):
    want = write_trial(tmp_path / "t.tlog")
    rc, out, _ = run_score(capsys, tmp_path / "t.tlog")
    assert rc == 0
    n = want["n"]
    exp = score(want["states"], want["refs"], np.arange(n), n, want["inputs"])
    assert out["score"]["P"] == pytest.approx(float(exp.P[0]), rel=1e-12)
    assert out["score"]["complete"] and out["trial"]["window"] == [300, 600]
    # Readable by pymavlink's own tlog reader (the one mavlogdump.py uses), both directions present.
    log = mavutil.mavlink_connection(str(tmp_path / "t.tlog"))
    types = set()
    while (msg := log.recv_match()) is not None:
        types.add((msg.get_type(), msg.get_srcSystem()))
    assert {("SET_POSITION_TARGET_LOCAL_NED", 245), ("LOCAL_POSITION_NED", 1), ("STATUSTEXT", 245)} <= types


def test_lost_samples_are_interpolated_and_reported(tmp_path, capsys):
    full = write_trial(tmp_path / "a.tlog")
    write_trial(tmp_path / "b.tlog", drop={350, 351, 352, 500})
    _, a, _ = run_score(capsys, tmp_path / "a.tlog")
    _, b, _ = run_score(capsys, tmp_path / "b.tlog")
    assert b["trial"]["filled"]["pos"] == 4 and b["score"]["complete"]
    assert b["score"]["P"] == pytest.approx(a["score"]["P"], abs=1e-4)  # smooth reference: tiny change
    assert full["n"] == 600


def test_aborted_trial_scores_unsafe(tmp_path, capsys):
    write_trial(tmp_path / "x.tlog", L=150)
    rc, out, _ = run_score(capsys, tmp_path / "x.tlog")
    assert rc == 0 and out["score"]["L"] == 150 and not out["score"]["safe"]
    assert out["score"]["P"] == pytest.approx(-(1 - (150 / 600) ** 2))


@pytest.mark.parametrize("damage,message", [
    ("empty", "is empty"),
    ("truncated", "truncated"),
    ("corrupted", "damaged bytes skipped"),
    ("foreign", "corrupted"),
    ("missing", "cannot read"),
    ("unfinished", "end marker"),
])
def test_bad_tlogs_give_clear_errors(tmp_path, capsys, damage, message):
    path = tmp_path / "t.tlog"
    write_trial(path, end=damage != "unfinished")
    data = path.read_bytes()
    if damage == "empty":
        path.write_bytes(b"")
    elif damage == "truncated":
        path.write_bytes(data[: len(data) - 7])
    elif damage == "corrupted":
        recs = read_tlog(path)
        assert len(recs) > 100
        buf = bytearray(data)
        buf[8 + 12] ^= 0x5A  # a payload byte of the first packet: its checksum no longer matches
        path.write_bytes(bytes(buf))
    elif damage == "foreign":
        path.write_bytes(np.random.default_rng(0).bytes(4096))
    elif damage == "missing":
        path.unlink()
    rc, _, err = run_score(capsys, path)
    assert rc == 2
    assert err.strip().startswith("error: ") and message in err and "Traceback" not in err


def test_a_damaged_trial_tlog_is_scored_as_a_flight_log_with_partial(tmp_path, capsys):
    """The exact live score needs every record; a damaged trial tlog is read like any field log instead: refused
    without --partial (one line naming the damage), scored with it, and the result says why it is not the trial's
    exact score."""
    path = tmp_path / "t.tlog"
    write_trial(path)
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2] + np.random.default_rng(3).bytes(64) + data[len(data) // 2:])
    rc, _, err = run_score(capsys, path)
    assert rc == 2 and "damaged bytes skipped" in err and "--partial" in err and err.count("\n") == 1, err
    rc = main(["score", str(path), "--json", "--partial"])
    cap = capsys.readouterr()
    assert rc == 0, cap.err
    out = json.loads(cap.out)
    assert out["warnings"][0].startswith("not re-scored as a trial") and out["damaged_spans"]
    assert out["segments"] and out["segments"][0]["vs_target"]["h_rms_m"] > 0
