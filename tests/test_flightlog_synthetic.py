"""Without a SITL: `ksbo-mav score` on synthetic DataFlash logs and other clients' tlogs with known
tracking errors — format detection by content, segments, the figure-8 and its laps, errors against the logged
target and the analytic reference, P from Mission.score, and one-line errors for damaged or unusable logs."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flightlog_helpers import EV, H_RMS, MISSION, T0, write_bin, write_other_tlog, write_ulg

from ksbo_mav.cli import main
from ksbo_mav.flightlog import detect_format, read_log
from ksbo_mav.flightlog.analysis import reference


def score_json(capsys, *argv) -> tuple[int, dict | None, str]:
    rc = main(["score", *map(str, argv), "--json"])
    out, err = capsys.readouterr()
    return rc, (json.loads(out) if rc == 0 else None), err


def test_reference_matches_mission_setpoints():
    t = np.linspace(0, 45, 77)
    pos, vel = reference(MISSION, t, np.zeros(3))
    for i, ti in enumerate(t):
        p, v, _ = MISSION.setpoint_at(float(ti))
        assert pos[i] == pytest.approx(p, abs=1e-12) and vel[i] == pytest.approx(v, abs=1e-12)


@pytest.mark.parametrize("name", ["flight.BIN", "flight.txt", "noextension"])
def test_bin_detected_by_content_and_scored_per_lap(tmp_path, capsys, name):
    path = write_bin(tmp_path / name)
    assert detect_format(path) == "bin"
    rc, out, err = score_json(capsys, path)
    assert rc == 0, err
    assert out["format"] == "bin" and out["autopilot"] == "ardupilot"
    (seg,) = out["segments"]
    assert seg["mode"] == "GUIDED"
    f8 = seg["figure8"]
    assert f8["t0_s"] == pytest.approx(T0, abs=0.01)  # recovered from the logged setpoints alone
    assert f8["laps_flown"] == pytest.approx(2.0, abs=0.02) and len(f8["laps"]) == 2
    for lap in f8["laps"]:
        for ref in ("vs_target", "vs_reference"):
            assert lap[ref]["h_rms_m"] == pytest.approx(H_RMS, rel=0.03)
            assert lap[ref]["h_max_m"] == pytest.approx(0.2, abs=0.01)
            assert lap[ref]["v_rms_m"] == pytest.approx(EV, rel=0.03)
    sc = f8["score"]
    assert sc["complete"] and sc["rms_lap2_m"] == pytest.approx(np.hypot(H_RMS, EV), rel=0.03)
    assert sc["P"] == pytest.approx(0.5)  # a flight without a campaign reference is its own reference


def test_a_bin_with_rcou_gives_each_laps_motor_oscillation(tmp_path, capsys):
    rc, out, err = score_json(capsys, write_bin(tmp_path / "rcou.bin", motor_shake_us=20.0))
    assert rc == 0, err
    laps = out["segments"][0]["figure8"]["laps"]
    assert len(laps) == 2 and all(lap["motor_osc_us"] == pytest.approx(20.0 / np.sqrt(2), rel=0.05) for lap in laps)
    rc, out, err = score_json(capsys, write_bin(tmp_path / "calm.bin", motor_shake_us=0.0))
    assert all(lap["motor_osc_us"] < 0.5 for lap in out["segments"][0]["figure8"]["laps"])  # the slow throttle: none
    rc, out, err = score_json(capsys, write_bin(tmp_path / "none.bin"))  # no RCOU logged: nothing said
    assert all("motor_osc_us" not in lap for lap in out["segments"][0]["figure8"]["laps"])
    assert main(["score", str(tmp_path / "rcou.bin")]) == 0
    assert "motor oscillation 14." in capsys.readouterr().out


def test_rms_ref_makes_p_comparable(tmp_path, capsys):
    path = write_bin(tmp_path / "a.bin", err_scale=0.5)
    rc, out, _ = score_json(capsys, path, "--rms-ref", np.hypot(H_RMS, EV))
    sc = out["segments"][0]["figure8"]["score"]
    assert sc["P"] == pytest.approx(1 - 0.5 / 2, abs=0.02)  # half the baseline's error -> 0.75


@pytest.mark.parametrize("prefix", ["SRC=245/191:", "GCS:"])
def test_marker_in_bin_gives_exact_start(tmp_path, capsys, prefix):
    # ArduPilot logs a STATUSTEXT from MAV_GCS_SYSID (the tuner, while its onboard guard runs) as "GCS:text"
    path = write_bin(tmp_path / "m.bin", markers=prefix)
    _, out, _ = score_json(capsys, path)
    f8 = out["segments"][0]["figure8"]
    assert f8["t0_s"] == T0 and f8["marker"].startswith("ksbo f8h start")


def test_text_output_and_plot(tmp_path, capsys):
    path = write_bin(tmp_path / "a.bin")
    rc = main(["score", str(path), "--plot", str(tmp_path / "p.png")])
    out = capsys.readouterr().out
    assert rc == 0 and "segment 1: GUIDED" in out and "lap 2:" in out and "P = 0.5000" in out
    assert (tmp_path / "p.png").stat().st_size > 10_000


@pytest.mark.parametrize("where", ["file-as-directory", "directory", "proc"])
def test_a_plot_path_that_cannot_be_written_is_one_line_before_any_work(tmp_path, capsys, where):
    """--plot into a path whose parent is a file, onto a directory, or where no directory can be made: exit 2 with
    one line naming the option and the path (it used to be a FileNotFoundError traceback after scoring)."""
    path = write_bin(tmp_path / "a.bin")
    (tmp_path / "afile").write_text("not a directory")
    plot = {"file-as-directory": tmp_path / "afile" / "p.png", "directory": tmp_path,
            "proc": "/proc/no-such-dir/p.png"}[where]
    for cmd in (["score", str(path)], ["compare", str(path), str(path)]):
        rc = main([*cmd, "--plot", str(plot)])
        err = capsys.readouterr().err.strip()
        assert rc == 2 and err.startswith("error: ") and "plot" in err and "\n" not in err, err
    assert not (tmp_path / "afile").is_dir()


def test_other_clients_tlog_is_scored(tmp_path, capsys):
    path = write_other_tlog(tmp_path / "mp.tlog")
    rc, out, err = score_json(capsys, path)
    assert rc == 0, err
    assert out["format"] == "tlog" and "SET_POSITION_TARGET_LOCAL_NED" in out["target_source"]
    f8 = out["segments"][0]["figure8"]
    assert f8["t0_s"] == pytest.approx(T0, abs=0.005)
    assert f8["laps"][1]["vs_reference"]["h_rms_m"] == pytest.approx(H_RMS, rel=0.01)
    assert out["warnings"]  # says the errors are against what the ground station sent


def test_segment_option(tmp_path, capsys):
    path = write_bin(tmp_path / "a.bin")
    rc, out, _ = score_json(capsys, path, "--segment", 1)
    assert rc == 0 and len(out["segments"]) == 1
    rc, _, err = score_json(capsys, path, "--segment", 2)
    assert rc == 2 and "--segment 2 does not exist" in err


def test_short_figure8_scores_laps_but_no_p(tmp_path, capsys):
    path = write_bin(tmp_path / "short.bin", laps=1.5)
    _, out, _ = score_json(capsys, path)
    f8 = out["segments"][0]["figure8"]
    assert len(f8["laps"]) == 1 and f8["score"]["P"] is None and "1.50 of the mission's 2 laps" in f8["score"]["reason"]


def _one_line_error(capsys, path, *extra) -> str:
    rc = main(["score", str(path), *extra])
    out, err = capsys.readouterr()
    assert rc == 2 and out == "" and "Traceback" not in err
    assert err.startswith("error: ") and err.count("\n") == 1
    return err


def test_bad_logs_give_one_line_errors(tmp_path, capsys):
    good = write_bin(tmp_path / "good.bin").read_bytes()
    (tmp_path / "empty.bin").write_bytes(b"")
    assert "is empty" in _one_line_error(capsys, tmp_path / "empty.bin")
    assert "cannot read" in _one_line_error(capsys, tmp_path / "missing.bin")
    # cut in the middle of the figure-8 (inside a message): truncated, the segment's end is missing
    cut = tmp_path / "cut.bin"
    cut.write_bytes(good[: good.index(b"\xa3\x95", len(good) // 2) + 7])
    err = _one_line_error(capsys, cut)
    assert "truncated" in err and "segment 1" in err and "--partial" in err
    boundary = tmp_path / "boundary.bin"  # cut between two messages: still a log that stops mid-flight
    boundary.write_bytes(good[: good.index(b"\xa3\x95", len(good) // 2)])
    assert "truncated" in _one_line_error(capsys, boundary)
    rc = main(["score", str(cut), "--partial", "--json"])
    partial = json.loads(capsys.readouterr().out)
    assert rc == 0 and partial["warnings"] and partial["segments"][0]["figure8"]["score"]["P"] is None
    # a cut right after the header
    head = tmp_path / "head.bin"
    head.write_bytes(good[:200])
    assert "truncated" in _one_line_error(capsys, head)
    # corruption in the middle: a message header overwritten
    bad = bytearray(good)
    i = bad.index(b"\xa3\x95", len(bad) // 3)
    bad[i] = 0x00
    (tmp_path / "bad.bin").write_bytes(bytes(bad))
    err = _one_line_error(capsys, tmp_path / "bad.bin")  # skipped, but inside the segment: refused without --partial
    assert "damaged bytes skipped at offset" in err and "segment 1" in err and "--partial" in err
    (tmp_path / "noise.bin").write_bytes(np.random.default_rng(1).bytes(5000))
    assert "corrupted or not a flight log" in _one_line_error(capsys, tmp_path / "noise.bin")


def test_no_tracking_segment(tmp_path, capsys):
    path = write_bin(tmp_path / "loiter.bin", guided=False)
    err = _one_line_error(capsys, path)
    assert "no segment where the vehicle tracked position targets" in err and "LOITER" in err


def test_psc_logging_disabled_names_the_bit(tmp_path, capsys):
    path = write_bin(tmp_path / "nopsc.bin", log_bitmask=180222 & ~(1 << 5))
    err = _one_line_error(capsys, path)
    assert "PSCN, PSCE, PSCD" in err and "LOG_BITMASK" in err and "bit 5" in err and "NTUN" in err


def test_truncated_tlog_of_other_client(tmp_path, capsys):
    data = write_other_tlog(tmp_path / "a.tlog").read_bytes()
    (tmp_path / "cut.tlog").write_bytes(data[: data.index(b"\xfd", len(data) * 2 // 3) + 5])  # inside a frame
    err = _one_line_error(capsys, tmp_path / "cut.tlog")
    assert "truncated" in err and "--partial" in err


def test_read_log_is_streaming_friendly(tmp_path):
    """The DataFlash reader keeps only the wanted messages (the IMU filler is counted, never stored)."""
    log = read_log(write_bin(tmp_path / "a.bin"))
    assert log.info["messages"] > 3000 and len(log.actual) < log.info["messages"] / 5


def test_ulg_scored_per_lap(tmp_path, capsys):
    path = write_ulg(tmp_path / "log.dat")
    assert detect_format(path) == "ulg"
    rc, out, err = score_json(capsys, path)
    assert rc == 0, err
    (seg,) = out["segments"]
    assert out["autopilot"] == "px4" and seg["mode"] == "OFFBOARD"
    f8 = seg["figure8"]
    assert f8["profile"] == "px4-copter" and f8["t0_s"] == pytest.approx(T0, abs=0.005)
    for lap in f8["laps"]:
        assert lap["vs_target"]["h_rms_m"] == pytest.approx(H_RMS, rel=0.03)
        assert lap["vs_reference"]["h_rms_m"] == pytest.approx(H_RMS, rel=0.03)
        assert lap["vs_reference"]["v_max_m"] == pytest.approx(EV, rel=0.01)
    assert f8["score"]["complete"]


def test_bad_ulgs_give_one_line_errors(tmp_path, capsys):
    good = write_ulg(tmp_path / "good.ulg").read_bytes()
    cut = tmp_path / "cut.ulg"
    cut.write_bytes(good[: len(good) // 2 + 5])
    err = _one_line_error(capsys, cut)
    assert "truncated" in err and "segment 1" in err
    assert main(["score", str(cut), "--partial"]) == 0
    assert "warning:" in capsys.readouterr().out
    (tmp_path / "head.ulg").write_bytes(good[:10])
    assert "truncated" in _one_line_error(capsys, tmp_path / "head.ulg")
    bad = bytearray(good)
    bad[len(bad) // 3:len(bad) // 3 + 512] = b"\xff" * 512
    (tmp_path / "bad.ulg").write_bytes(bytes(bad))
    err = _one_line_error(capsys, tmp_path / "bad.ulg")
    assert "damaged bytes skipped at offset" in err and "--partial" in err
    unsub = bytearray(good)  # intact framing, but a data message names a subscription that does not exist
    pos = 16
    while unsub[pos + 2] != ord("D"):
        pos += 3 + int.from_bytes(unsub[pos:pos + 2], "little")
    unsub[pos + 3:pos + 5] = (65325).to_bytes(2, "little")
    (tmp_path / "unsub.ulg").write_bytes(bytes(unsub))
    # the damage is before the flight: skipped and reported, the flight scored
    assert main(["score", str(tmp_path / "unsub.ulg")]) == 0
    out, err = capsys.readouterr()
    assert "warning: skipped 1 damaged span" in out and "no subscription found for message id 65325" in out
    nosp = write_ulg(tmp_path / "nosp.ulg", topics=("vehicle_local_position", "vehicle_status"))
    err = _one_line_error(capsys, nosp)
    assert "no vehicle_local_position_setpoint" in err
