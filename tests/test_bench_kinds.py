"""The cell kinds of the benchmarks that were scripts: an evaluation and a timing run through the runner and give
their figures (the planar task's known values, a MAVLink flight's P equal to the in-process one), bad keys are one
line, a cell whose input is another cell's record waits for it (a warm start after its earlier campaign), and
every stored record is a declared cell or history labelled as such; slow: a flights cell and a planar campaign
with its analyses on our simulators, a warm start from an exported campaign."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ksbo_bench import sweep as sweeps
from ksbo_bench.driver import run
from ksbo_bench.local_executor import LocalExecutor
from ksbo_bench.report import pages
from ksbo_bench.store import Store


def _sweep(tmp_path: Path, text: str, name: str = "s") -> sweeps.Sweep:
    p = tmp_path / f"{name}.toml"
    p.write_text(text)
    return sweeps.load(p)


def _run(tmp_path: Path, sw: sweeps.Sweep, jobs: int = 1) -> list[dict]:
    with open(tmp_path / f"{sw.name}.log", "w") as out:
        summ = run(sw, LocalExecutor(jobs=jobs), Store(tmp_path / sw.name), out=out)
    assert not summ.failed, (tmp_path / f"{sw.name}.log").read_text()
    return Store(tmp_path / sw.name).records()


def test_evaluation_cells_give_the_known_figures_and_their_page(tmp_path):
    """The planar task over 500 random gain vectors and a0's re-flown E[P] (the fact sheet's 0.197); our copter
    without its rotor drag tracks ten times better than SITL's 0.234 m."""
    sw = _sweep(tmp_path, """
[sweep]
kind = "evaluation"
[[grid]]
what = ["planar-task"]
n = [500]
[[grid]]
what = ["copter3d-tracking"]
variant = ["stock"]
[report]
builder = "evaluation"
""")
    recs = {r["key"]["what"]: r for r in _run(tmp_path, sw, jobs=2)}
    task = recs["planar-task"]["result"]
    assert task["EP_a0"] == pytest.approx(0.197, abs=0.005) and task["EP_oracle"] > 0.95
    assert 0.05 < task["safe_fraction"] < 0.3 and task["P_q50"] < 0 < task["P_q99"]
    assert recs["copter3d-tracking"]["result"]["rows"][0]["rms_lap2"] < 0.05
    page = pages.page(sw, list(recs.values()))
    assert "| re-flown E[P] of a0 (default gains) |" in page and "| defaults, no rotor drag |" in page


@pytest.mark.network
def test_timing_cells_time_an_operation_and_a_mavlink_flight(tmp_path):
    """A pure timing (the exact C_ree) and a whole-process one (our planar simulator and a lean client over
    loopback in lockstep): seconds in the record's timing, the flight's P (float32 on the wire) equal to the
    in-process simulation's to 1e-3."""
    sw = _sweep(tmp_path, """
[sweep]
kind = "timing"
[fixed]
repeats = 1
[[grid]]
what = ["cree-exact"]
[[grid]]
what = ["planar-mavlink-flight"]
runs = [1]
""")
    recs = {r["key"]["what"]: r for r in _run(tmp_path, sw)}
    assert 0 < recs["cree-exact"]["timing"]["seconds"] < 5
    fl = recs["planar-mavlink-flight"]
    assert fl["result"]["P_min"] == pytest.approx(fl["result"]["P_inprocess"], abs=1e-3)
    assert fl["timing"]["real_time_factor"] > 0 and fl["timing"]["cpu_sim_s"] > 0


@pytest.mark.parametrize("text, said", [
    ('kind = "flights"\n[fixed]\nvehicle = "ardupilot"\nways = ["streamed", "loop"]\n', "unknown way 'loop'"),
    ('kind = "flights"\n[fixed]\nvehicle = "copter3d"\nways = ["onboard"]\n', "streamed trial at its mission rate"),
    ('kind = "evaluation"\n[fixed]\nwhat = "moon"\n', "what must be one of"),
    ('kind = "campaign"\n[fixed]\nvehicle = "planar"\nseed = 0\nlink = "down=4000"\n', "between a SITL and the tuner"),
    ('kind = "campaign"\n[fixed]\nvehicle = "planar"\nseed = 0\nanalyses = ["tea"]\n', "unknown analysis 'tea'"),
    ('kind = "campaign"\n[fixed]\nvehicle = "planar"\nseed = 0\nreference = { sweep = "warm-start", key = '
     '{ label = "nothing-like-it" } }\n', "run those cells first"),
])
def test_a_bad_or_unready_cell_is_one_line(tmp_path, text, said):
    p = tmp_path / "bad.toml"
    p.write_text("[sweep]\n" + text)
    r = subprocess.run([sys.executable, "-m", "ksbo_bench", "run", str(p), "--store", str(tmp_path / "s")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and said in r.stderr and len(r.stderr.strip().splitlines()) <= 2, r.stderr
    assert not (tmp_path / "s" / "records.jsonl").exists()


def test_every_stored_record_is_a_declared_cell_or_labelled_history():
    """A converted or flown record either has a declared cell's key (a run skips it) or is history: an archive
    sweep, or a label of an earlier design (was-, try-; the short campaigns' paper runs). The short-campaign store
    also keeps early-stop runs flown before that label's re-fly settings were fixed (benchmarks/notes/
    early-stop.md): its page shows each seed's newest."""
    for sw in sweeps.all_sweeps():
        if sw.archive or sw.name == "short-campaign":
            continue
        declared = {c.id for c in sw.cells()}
        for rec in Store(sw.store):
            label = str(rec["key"].get("label", ""))
            assert sweeps.key_id(rec["key"]) in declared or label.startswith(("was-", "try-", "paper")), \
                (sw.name, rec["key"])


@pytest.mark.slow
@pytest.mark.network
def test_a_flights_cell_flies_fixed_gains_in_turn_on_our_copter(tmp_path):
    sw = _sweep(tmp_path, """
[sweep]
kind = "flights"
[fixed]
vehicle = "copter3d"
reps = 1
ways = ["streamed"]
gains = { tuned = { PSC_NE_POS_P = 1.5 } }
""")
    rec = _run(tmp_path, sw)[0]
    rows = {r["set"]: r for r in rec["result"]["flights"]}
    assert rec["flights"]["total"] == 2 and set(rows) == {"baseline", "tuned"}
    assert rows["baseline"]["true_rms"] == pytest.approx(rows["baseline"]["rms"], abs=1e-5)
    assert rows["tuned"]["rms"] < rows["baseline"]["rms"]  # a stiffer position loop tracks closer
    assert rec["result"]["sets"]["tuned"]["PSC_NE_POS_P"] == 1.5


@pytest.mark.slow
@pytest.mark.network
def test_a_planar_campaign_cell_runs_its_analyses(tmp_path):
    """Our planar vehicle over MAVLink: the recommendation re-flown in process (E[P] monitored, as `evaluate
    --fixed`), the same optimiser in process, the baseline's re-flights, the parameters read back unchanged."""
    sw = _sweep(tmp_path, """
[sweep]
kind = "campaign"
[fixed]
vehicle = "planar"
seed = 0
tune_args = ["--budget", "3", "--prior", "sim"]
refly = 0
check_params = true
analyses = ["drift", "planar", "planar-twin"]
""")
    rec = _run(tmp_path, sw)[0]
    res = rec["result"]
    assert rec["status"] == "ok" and rec["flights"]["opt"] == 3 and res["changed_params"] == []
    assert res["EP_baseline"] == pytest.approx(0.198, abs=0.002) and -1 <= res["EP"] <= 1
    assert set(res["twin"]) == {"EP", "unsafe", "aborted", "crashed"} and "unsafe_told" in res


@pytest.mark.slow
@pytest.mark.network
def test_a_warm_start_runs_after_the_campaign_it_starts_from(tmp_path):
    """Two waves in one run: the earlier campaign (its files kept in its record), then the warm start from them on
    a fresh copter, the earlier recommendation re-flown beside it, and what the tool said."""
    earlier = tmp_path / "w.toml"
    sw = _sweep(tmp_path, f"""
[sweep]
kind = "campaign"
store = "{tmp_path / 'w'}"
[fixed]
vehicle = "copter3d"
seed = 0
[[grid]]
label = ["earlier"]
tune_args = [["--budget", "2", "--prior", "none", "--validation", "off", "--no-onboard-guard", "--confirm", "1"]]
export = [true]
refly = [0]
[[grid]]
label = ["warm"]
tune_args = [["--budget", "2", "--validation", "off", "--no-onboard-guard", "--confirm", "0"]]
warm_start = [{{ sweep = "{earlier}", key = {{ label = "earlier" }}, match = ["vehicle"] }}]
reference = [{{ sweep = "{earlier}", key = {{ label = "earlier" }}, match = ["vehicle"] }}]
candidates = [0]
refly = [1]
""", "w")
    recs = {r["key"]["label"]: r for r in _run(tmp_path, sw)}
    assert set(recs["earlier"]["result"]["folder"]) >= {"campaign.json", "result.json", "journal.jsonl"}
    warm = recs["warm"]["result"]
    assert warm["warm_start"].startswith("warm start: the earlier recommendation flies")
    assert set(warm["reflown"]) == {"baseline", "rec", "long"} and warm["reached_at"] in (None, 2, 3)
    assert json.loads(recs["earlier"]["result"]["folder"]["result.json"])["best"]["values"] == \
        recs["earlier"]["result"]["best_values"]
