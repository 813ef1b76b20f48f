"""`ksbo-mav check LOG... --campaign DIR`: later flights against the campaign's confirmation flight."""

from __future__ import annotations

import json

from flightlog_helpers import write_bin, write_other_tlog, write_ulg

from ksbo_mav.cli import main


def _campaign(tmp_path):
    d = tmp_path / "camp"
    (d / "trials").mkdir(parents=True)
    write_other_tlog(d / "trials" / "trial_031.tlog")  # the confirmation flight
    entry = {"kind": "confirm", "trial": 31, "x": [1.0, 2.0], "P": 0.5, "outcome": "ok",
             "record": "trials/trial_031.json", "restored": True, "rms": 0.17}
    (d / "journal.jsonl").write_text(json.dumps(dict(entry, kind="opt", trial=0)) + "\n" + json.dumps(entry) + "\n")
    return d


def test_still_tracks_and_time_to_retune(tmp_path, capsys):
    camp = _campaign(tmp_path)
    same = [write_bin(tmp_path / "a.bin"), write_ulg(tmp_path / "b.ulg", err_scale=1.1)]
    rc = main(["check", *map(str, same), "--campaign", str(camp), "--plot", str(tmp_path / "c.png")])
    out = capsys.readouterr().out
    assert rc == 0 and "still tracks as when the gains were accepted" in out and "lag" in out
    assert (tmp_path / "c.png").stat().st_size > 5000
    worse = write_other_tlog(tmp_path / "worse.tlog", err_scale=2.5)
    rc = main(["check", str(same[0]), str(worse), "--campaign", str(camp), "--json"])
    doc = json.loads(capsys.readouterr().out)
    assert rc == 1 and doc["retune"] and 2.3 < doc["worst_ratio"] < 2.7
    ratios = [s["ratio"] for f in doc["flights"] for s in f["segments"]]
    assert min(ratios) < 1.2  # the unchanged flight


def test_check_errors_are_one_line(tmp_path, capsys):
    rc = main(["check", str(write_bin(tmp_path / "a.bin")), "--campaign", str(tmp_path)])
    err = capsys.readouterr().err
    assert rc == 2 and "not a campaign directory" in err and err.count("\n") == 1
    camp = _campaign(tmp_path)
    (tmp_path / "empty.bin").write_bytes(b"")
    rc = main(["check", str(tmp_path / "empty.bin"), "--campaign", str(camp)])
    err = capsys.readouterr().err
    assert rc == 2 and "no flight could be checked" in err and "is empty" in err
