"""`ksbo-mav compare A B` — the same segment type of two logs side by side (any formats), with a plot."""

from __future__ import annotations

import json

import pytest

from flightlog_helpers import write_bin, write_other_tlog

from ksbo_mav.cli import main


def test_compare_before_after(tmp_path, capsys):
    before = write_bin(tmp_path / "before.BIN")
    after = write_other_tlog(tmp_path / "after.tlog", err_scale=0.5)  # a tlog of a better-tuned flight
    rc = main(["compare", str(before), str(after), "--json", "--plot", str(tmp_path / "c.png")])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["kind"] == "figure-8"
    rows = {r["metric"]: r for r in out["rows"]}
    lap2 = rows["lap 2 vs reference h rms (m)"]
    assert lap2["b"] == pytest.approx(lap2["a"] / 2, rel=0.03)
    assert rows["lap-2 RMS (m)"]["b"] < rows["lap-2 RMS (m)"]["a"]
    assert (tmp_path / "c.png").stat().st_size > 10_000
    rc = main(["compare", str(before), str(after)])
    text = capsys.readouterr().out
    assert rc == 0 and "compare (figure-8)" in text and "lap 2 vs reference h rms (m)" in text and "-0.0" in text


def test_compare_without_figure8_uses_tracking_segments(tmp_path, capsys):
    a = write_bin(tmp_path / "a.bin")
    b = write_bin(tmp_path / "b.bin", laps=0.3)  # too short to be recognised as the figure-8
    rc = main(["compare", str(a), str(b), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["kind"].startswith("tracking segment")
    assert [r["metric"] for r in out["rows"]][0] == "vs target h rms (m)"


def test_compare_reports_bad_input_in_one_line(tmp_path, capsys):
    a = write_bin(tmp_path / "a.bin")
    (tmp_path / "e.ulg").write_bytes(b"")
    rc = main(["compare", str(a), str(tmp_path / "e.ulg")])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("error: ") and "is empty" in err


def test_compare_lines_segments_up(tmp_path, capsys):
    """Two logs split where PSC_POSXY_P changed: segment 1 beside segment 1, 2 beside 2."""
    from test_flightlog_field import _oscillating_bin

    a = _oscillating_bin(tmp_path / "a.bin", 1.2, 0.1, param_change_at=31.0)
    b = _oscillating_bin(tmp_path / "b.bin", 0.8, 0.05, param_change_at=31.0)
    rc = main(["compare", str(a), str(b), "--json"])
    rows = json.loads(capsys.readouterr().out)["by_segment"]
    assert rc == 0 and [r["pair"] for r in rows] == [1, 2]
    for r in rows:
        assert r["a"]["spectrum_peak_hz"] == pytest.approx(1.2, abs=0.05)
        assert r["b"]["spectrum_peak_hz"] == pytest.approx(0.8, abs=0.05)
        assert r["b"]["h_rms_m"] == pytest.approx(r["a"]["h_rms_m"] / 2, rel=0.1)
    assert main(["compare", str(a), str(b)]) == 0
    assert "segment by segment" in capsys.readouterr().out
