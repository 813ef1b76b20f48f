"""scripts/benchmarks_page.py: BENCHMARKS.md is exactly what the outputs under benchmarks/ give, each benchmark's
section carries its command, machine and headline table, and a changed output or a damaged one is noticed."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "benchmarks_page.py"


@pytest.fixture()
def page(monkeypatch):
    sys.path.insert(0, str(SCRIPT.parent))
    spec = importlib.util.spec_from_file_location("benchmarks_page", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    yield mod
    sys.path.remove(str(SCRIPT.parent))


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=120,
                          cwd=ROOT)


def test_committed_page_is_up_to_date():
    r = _run("--check")
    assert r.returncode == 0, r.stderr


def test_every_section_names_command_machine_and_a_table(page):
    for name, text in page.sections().items():
        assert text.startswith("## "), name
        assert "Machine" in text or "—" in text.split("\n\n")[1], name  # machine line
        assert "scripts/bench_" in text, name  # the command that made it
        assert "\n|---|" in text, name  # a headline table
    assert len(page.build().splitlines()) <= 450  # a page one reads, not an archive


def test_headline_keeps_the_introduction_and_the_first_table_only(page, tmp_path):
    out = tmp_path / "results.md"
    out.write_text("## Old title\n\nMachine: X. Script: `s`.\n\n### Speed\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\n"
                   "more prose\n\n| c |\n|---|\n| 3 |\n")
    assert page.headline(out) == "Machine: X. Script: `s`.\n\n**Speed**\n\n| a | b |\n|---|---|\n| 1 | 2 |"
    assert "| 3 |" in page.headline(out, tables=2) and "Old title" not in page.headline(out, tables=2)


def test_plant_table_follows_the_records(page, tmp_path, monkeypatch):
    """A record added under today's defaults changes the plant table (and so --check fails until rewritten)."""
    plants = tmp_path / "plants"
    plants.mkdir()
    (plants / "tables-frozen-2026-12-01.md").write_text((page.PLANTS / "tables-frozen-2026-12-01.md").read_text())
    base = {"mode": "monitor", "n_prior": 0, "budget": 100, "tag": "", "n_aborted": 1, "n_crashed": 0,
            "n_unsafe": 1, "reflown_counts": [8, 0, 0]}
    recs = [{**base, "plant": "nominal", "method": m, "seed": s, "EP": 0.5 + 0.01 * s}
            for m in ("ksbo", "ksbo-adaptive") for s in range(3)]
    (plants / "records.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    monkeypatch.setattr(page, "PLANTS", plants)
    text = page.plant_suite()
    assert "| nominal | 0.510 [0.500, 0.520] | 3/3 | 1 [1] | 0.510 [0.500, 0.520] | 3/3 | 1 [1] |" in text
    assert "seeds 0–2" in text and page.PLANTS_MACHINE in text
    recs.append({**base, "plant": "nominal", "method": "ksbo", "seed": 3, "EP": 0.9, "n_crashed": 1,
                 "machine": "Test CPU, 2026-12-03"})
    (plants / "records.jsonl").write_text("".join(json.dumps(r) + "\n" for r in recs))
    text = page.plant_suite()
    assert "| nominal | 0.515 [0.500, 0.900] | 3/4 |" in text and "Machine: Test CPU, 2026-12-03" in text


def test_check_fails_on_a_stale_page(tmp_path):
    stale = tmp_path / "BENCHMARKS.md"
    stale.write_text((ROOT / "BENCHMARKS.md").read_text().replace("0.927", "0.999", 1))
    r = _run("--check", "--out", str(stale))
    assert r.returncode == 1 and "is not what benchmarks/ gives" in r.stderr
    r = _run("--out", str(tmp_path / "new.md"))
    assert r.returncode == 0 and (tmp_path / "new.md").read_text() == (ROOT / "BENCHMARKS.md").read_text()


def test_a_missing_output_is_a_one_line_error(page, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(page, "BENCH", tmp_path)  # no results.md anywhere
    out = tmp_path / "page.md"
    assert page.main(["--out", str(out)]) == 2 and not out.exists()
    err = capsys.readouterr().err
    assert "cannot build the page" in err and len(err.strip().splitlines()) == 1
