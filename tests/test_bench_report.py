"""ksbo-bench report: BENCHMARKS.md and the sweep pages are exactly what the stores give, each section names its
command, records, machine and a headline table, the page stays within 300 lines, a table follows the records (one
row per cell too), the pages list their cells in the declared order and name the earlier outputs kept as history,
and a stale or unbuildable page is noticed."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from ksbo_bench import sweep as sweeps
from ksbo_bench.report import figures, headlines, pages

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
            assert s.count("](benchmarks/pages/") >= 5 and s.count("](benchmarks/archive/") >= 5
            continue
        assert "ksbo-bench run" in s, title  # the command that made it
        assert "Machine" in s, title
        assert "\n|---|" in s, title  # a headline table
    for path, page in built.items():  # every sweep page links its sweep file and its records
        if path != pages.PAGE:
            assert page.startswith("# ") and "../sweeps/" in page and "../store/" in page, path
    assert "scripts/" not in text  # every benchmark is a sweep now


def test_a_page_lists_its_cells_in_the_declared_order_and_names_the_history_it_replaced():
    sw = sweeps.load("training-vs-flown")
    recs = list(reversed(pages.Store(sw.store).records()))
    order = [r["key"].get("speedup") for r in pages.ordered(sw, recs)]
    declared = [c.key["speedup"] for c in sw.cells()]
    assert order[:len(declared)] == declared  # the declared cells first, a history record after them
    drift = pages.page(sweeps.load("drift"), pages.Store(sweeps.load("drift").store).records())
    assert "[benchmarks/archive/drift-planar-changes.md](../archive/drift-planar-changes.md)" in drift


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


def test_a_table_has_one_row_per_cell_and_a_headline_is_capped():
    recs = [{"key": {"what": "gp", "op": op, "repeats": 5}, "timing": {"seconds": t}}
            for op, t in (("fit-predict", 0.028), ("ml2", 0.114))]
    text = figures.table(recs, {"rows": "cell", "hide": ["repeats"], "cells": ["timing.seconds:min-ms:seconds"]})
    assert "| gp fit-predict | 28 ms |" in text and "| gp ml2 | 114 ms |" in text
    long = "| a |\n|---|\n" + "".join(f"| {i} |\n" for i in range(20))
    assert headlines.cap(long).endswith(f"({20 - headlines.HEADLINE_ROWS} more rows on the full page)")


def test_a_stale_page_fails_the_check(tmp_path, monkeypatch, capsys):
    stale = tmp_path / "BENCHMARKS.md"
    stale.write_text(pages.PAGE.read_text().replace("Current results only", "Old results", 1))
    monkeypatch.setattr(pages, "PAGE", stale)
    assert pages.main(check=True) == 1
    assert "BENCHMARKS.md is not what the records give" in capsys.readouterr().err


def test_an_unbuildable_page_is_a_one_line_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(pages, "_builders", lambda: {})  # a sweep names a builder the generator does not have
    assert pages.main(check=True) == 2
    err = capsys.readouterr().err
    assert "cannot build the pages" in err and len(err.strip().splitlines()) == 1
