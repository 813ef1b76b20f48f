"""ksbo-bench report: BENCHMARKS.md and the sweep pages are exactly what the stores and the remaining Markdown
outputs give, each section names its command, records or machine and a headline table, the page stays within 300
lines, a table follows the records, and a stale or unbuildable page is noticed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from ksbo_bench.report import figures, legacy, pages

ROOT = Path(__file__).resolve().parents[1]


def test_committed_pages_are_up_to_date():
    r = subprocess.run([sys.executable, "-m", "ksbo_bench", "report", "--check"], capture_output=True, text=True,
                       timeout=180, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    assert "pages up to date" in r.stdout


def test_every_section_names_its_command_its_machine_and_a_table():
    built = pages.build()
    text = built[pages.PAGE]
    assert len(text.splitlines()) <= pages.MAX_LINES
    sections = text.split("\n## ")[1:]
    assert len(sections) >= 10
    for s in sections:
        title = s.splitlines()[0]
        if title == "More results":
            assert s.count("](benchmarks/") >= 5
            continue
        assert "ksbo-bench run" in s or "scripts/" in s or "Script" in s, title  # the command that made it
        assert "Machine" in s or "—" in s.split("\n\n")[1], title  # a machine line (or "command — machine")
        assert "\n|---|" in s, title  # a headline table
    for path, page in built.items():  # every sweep page links its sweep file and its records
        if path != pages.PAGE:
            assert page.startswith("# ") and "../sweeps/" in page and "../store/" in page, path


def test_a_table_follows_the_records():
    rec = {"key": {"plant": "nominal", "method": "ksbo", "seed": 0}, "result": {"EP": 0.5},
           "safety": {"crashed": 0, "aborted": 1}}
    recs = [json.loads(json.dumps(rec)) for _ in range(3)]
    for s, r in enumerate(recs):
        r["key"]["seed"], r["result"]["EP"] = s, 0.5 + 0.01 * s
    spec = {"rows": "plant", "columns": "method",
            "cells": ["EP:median-range:E[P]", "crashed:zero-share:crash-free", "aborted:median-max:aborts"]}
    assert "| nominal | 0.510 [0.500, 0.520] | 3/3 | 1 [1] |" in figures.table(recs, spec)
    recs[0]["safety"]["crashed"], recs[0]["result"]["EP"] = 1, float("nan")  # a crashed seed, no E[P]
    assert "| nominal | 0.515 [0.510, 0.520], 1 none | 2/3 | 1 [1] |" in figures.table(recs, spec)


def test_headline_keeps_the_introduction_and_the_first_table_only(tmp_path):
    out = tmp_path / "results.md"
    out.write_text("## Old title\n\nMachine: X. Script: `s`.\n\n### Speed\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n"
                   "more prose\n\n| c |\n|---|\n| 3 |\n")
    assert legacy.headline(out) == "Machine: X. Script: `s`.\n\n**Speed**\n\n| a | b |\n|---|---|\n| 1 | 2 |"
    long = "| a |\n|---|\n" + "".join(f"| {i} |\n" for i in range(20))
    assert legacy.cap(long).endswith(f"({20 - legacy.MAX_ROWS} more rows in the full output)")


def test_a_stale_page_fails_the_check(tmp_path, monkeypatch, capsys):
    stale = tmp_path / "BENCHMARKS.md"
    stale.write_text(pages.PAGE.read_text().replace("Current results only", "Old results", 1))
    monkeypatch.setattr(pages, "PAGE", stale)
    assert pages.main(check=True) == 1
    assert "BENCHMARKS.md is not what the records give" in capsys.readouterr().err


def test_an_unbuildable_page_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(legacy, "BENCH", tmp_path)  # no Markdown output anywhere
    assert pages.main(check=True) == 2
    err = capsys.readouterr().err
    assert "cannot build the pages" in err and len(err.strip().splitlines()) == 1
