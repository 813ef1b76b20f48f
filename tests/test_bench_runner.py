"""ksbo-bench: a sweep file's cells and keys, a run that writes one record per cell to the store and resumes
without running a stored cell again, the same records under the local executor and the Ray one (here: a tiny
planar sweep, in processes; slow: two Ray nodes on this machine), clear one-line errors for bad sweeps."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from ksbo_bench import sweep as sweeps
from ksbo_bench.driver import run
from ksbo_bench.local_executor import LocalExecutor
from ksbo_bench.store import Store
from ksbo_bench.store_compare import compare

ROOT = Path(__file__).resolve().parents[1]

TINY = """
[sweep]
kind = "plant"
title = "tiny"
[fixed]
plant = "nominal"
method = "ksbo"
budget = 4
[grid]
seed = "0-1"
"""


def _sweep(tmp_path: Path, text: str = TINY, name: str = "tiny") -> sweeps.Sweep:
    p = tmp_path / f"{name}.toml"
    p.write_text(text)
    return sweeps.load(p)


def test_only_takes_the_sweep_files_spelling_and_refuses_what_no_cell_has(tmp_path):
    from ksbo_bench.driver import pending
    from ksbo_bench.sweep import SweepError

    sw = _sweep(tmp_path, TINY.replace('budget = 4', 'budget = 4\n[grid]\npilot = [true, false]').replace(
        '[grid]\nseed', 'seed'))
    store = Store(tmp_path / "store")
    for spelled in ("true", "True"):  # the file's TOML spelling, and Python's
        todo, _ = pending(sw, store, where={"pilot": spelled})
        assert [c.key["pilot"] for c in todo] == [True, True], spelled
    assert len(pending(sw, store, where={"seed": "1", "pilot": "false"})[0]) == 1
    with pytest.raises(SweepError, match="no cell has it; pilot takes false, true"):
        pending(sw, store, where={"pilot": "yes"})
    with pytest.raises(SweepError, match="have no 'pilots'"):
        pending(sw, store, where={"pilots": "true"})


def test_a_sweep_file_declares_its_cells_and_their_keys(tmp_path):
    sw = _sweep(tmp_path, """
[sweep]
kind = "plant"
[fixed]
mode = "strict"
budget = 150
seed = 0
[[grid]]
plant = ["nominal", "gusts"]
method = ["ksbo", "safeopt"]
[[grid]]
plant = ["nominal"]
method = ["linebo"]
budget = [200]
""")
    cells = sw.cells()
    assert len(cells) == 5 and sw.store == ROOT / "benchmarks" / "store" / "tiny"
    assert cells[0].key == {"mode": "strict", "budget": 150, "seed": 0, "plant": "nominal", "method": "ksbo"}
    assert cells[-1].key["budget"] == 200 and cells[-1].key["method"] == "linebo"
    assert [c.key["seed"] for c in sw.cells(seeds=[3, 4])] == [3, 4] * 5  # --seeds replaces the seed axis
    assert sweeps.key_id({"b": 1, "a": 2}) == sweeps.key_id({"a": 2, "b": 1})  # the key, not its order


@pytest.mark.parametrize("text, said", [
    ("[sweep]\nkind = \"nope\"\n", "kind 'nope' is not one of"),
    ("[sweep]\nkind = \"plant\"\n[fixed]\nplant = \"nominal\"\n", "a plant cell needs method, seed, budget"),
    ("[sweep]\nkind = \"plant\"\n[fixed]\nmethod=\"ksbo\"\nseed=0\nbudget=3\nplant = \"moon\"\n", "unknown plant"),
    ("[sweep]\nkind = \"plant\"\n[grid]\nplant = \"x\"\n", "must be a non-empty list"),
    ("[sweep\n", "not TOML"),
])
def test_a_bad_sweep_is_a_one_line_error(tmp_path, text, said):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    r = subprocess.run([sys.executable, "-m", "ksbo_bench", "run", str(p), "--store", str(tmp_path / "s")],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and said in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "s").exists()


def test_every_declared_sweep_loads():
    names = {sw.name for sw in sweeps.all_sweeps()}
    assert {"plants-monitor", "plants-copter"} <= names


def test_a_local_run_writes_one_record_per_cell_and_resumes(tmp_path):
    sw = _sweep(tmp_path)
    store = Store(tmp_path / "store")
    log = tmp_path / "progress.txt"
    with open(log, "w") as out:
        summ = run(sw, LocalExecutor(jobs=2), store, out=out)
    assert (summ.total, summ.ran, summ.failed) == (2, 2, [])
    recs = store.records()
    assert sorted(r["key"]["seed"] for r in recs) == [0, 1]
    for r in recs:
        assert r["schema"] == 1 and r["kind"] == "plant" and r["status"] == "ok"
        assert r["flights"]["total"] == 4 and r["flights"]["reflown"] == 8  # the budget; 8 fixed re-flights
        assert set(r["safety"]) >= {"crashed", "aborted", "interrupted", "unsafe"}
        assert -1.0 <= r["result"]["EP"] <= 1.0 and r["run"]["executor"] == "local" and r["timing"]["wall_s"] > 0
    progress = log.read_text()
    assert "2 to run" in progress and "[2/2] seed=" in progress and "EP " in progress
    # resumed: the stored cells are skipped; a new seed is the only cell run
    with open(log, "w") as out:
        summ = run(sw, LocalExecutor(jobs=1), store, seeds=[0, 1, 2], out=out)
    assert (summ.skipped, summ.ran) == (2, 1) and len(store.records()) == 3
    # the same cells, run again elsewhere, give the same records (timing and provenance aside)
    again = Store(tmp_path / "again")
    with open(log, "w") as out:
        run(sw, LocalExecutor(jobs=1), again, out=out)
    text, same = compare(store.dir, again.dir)
    assert same and "2 cells in both, 0 differ" in text, text


def test_a_damaged_store_is_said_with_its_line(tmp_path):
    st = tmp_path / "s"
    st.mkdir()
    (st / "records.jsonl").write_text(json.dumps({"key": {"seed": 0}}) + "\n{not json\n")
    r = subprocess.run([sys.executable, "-m", "ksbo_bench", "run", str(ROOT / "benchmarks/sweeps/plants-copter.toml"),
                        "--store", str(st), "--dry-run"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "records.jsonl:2 is not a JSON record" in r.stderr


@pytest.mark.slow
def test_two_ray_nodes_on_this_machine_share_a_sweep_and_give_the_local_records(tmp_path):
    """A Ray cluster of two nodes (ray.cluster_utils.Cluster: a head and a worker node, each its own raylet with
    one CPU) runs a small sweep: cells land on both nodes and the records equal the local executor's."""
    ray = pytest.importorskip("ray")
    from ray.cluster_utils import Cluster

    from ksbo_bench.ray_executor import RayExecutor

    sw = _sweep(tmp_path, TINY.replace('"0-1"', '"0-5"'))
    cluster = Cluster(initialize_head=True, head_node_args={"num_cpus": 1, "resources": {"sitl": 1}})
    try:
        cluster.add_node(num_cpus=1, resources={"sitl": 1})
        cluster.wait_for_nodes()
        ray.init(address=cluster.address)
        ex = RayExecutor(address=cluster.address)
        with open(tmp_path / "ray.txt", "w") as out:
            summ = run(sw, ex, Store(tmp_path / "ray"), out=out)
        assert summ.ran == 6 and not summ.failed
    finally:
        ray.shutdown()
        cluster.shutdown()
    nodes = {r["run"]["node"] for r in Store(tmp_path / "ray")}
    assert len(nodes) == 2, nodes  # both nodes ran cells
    with open(tmp_path / "local.txt", "w") as out:
        run(sw, LocalExecutor(jobs=2), Store(tmp_path / "local"), out=out)
    text, same = compare(tmp_path / "ray", tmp_path / "local")
    assert same and "6 cells in both, 0 differ" in text, text


def test_an_infrastructure_failure_is_retried_and_gives_no_record(tmp_path):
    """A SITL cell whose SITL cannot start on this node (its declared build is not here) fails for the
    infrastructure: the runner runs it again --retries times, then names it and writes nothing."""
    from ksbo_sim.sitl import SitlNotFound, find_run_script

    try:
        find_run_script("ardupilot")
    except SitlNotFound as exc:
        pytest.skip(str(exc))
    p = tmp_path / "sitl.toml"
    p.write_text('[sweep]\nkind = "campaign"\n[fixed]\nvehicle = "ardupilot"\nbuild = "no-such-build"\nseed = 0\n')
    r = subprocess.run([sys.executable, "-m", "ksbo_bench", "run", str(p), "--store", str(tmp_path / "s"),
                        "--retries", "1"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 1, r.stderr
    assert "1 to run (1 on a SITL)" in r.stderr and "NO RECORD after 2 attempt(s) (infrastructure" in r.stderr
    assert "SITL build 'no-such-build' not found" in r.stderr and not (tmp_path / "s" / "records.jsonl").exists()


@pytest.mark.slow
@pytest.mark.network
def test_a_campaign_cell_flies_our_copter_and_re_flies_in_turn(tmp_path):
    """A campaign cell on our JSBSim copter over MAVLink (lockstep): the campaign's flights counted as the README
    counts them, the baseline, the recommendation and the best flown gains re-flown in turn, the given reference
    re-flown as "long", the cut and the share of the reference's cut computed from the re-flights."""
    sw = _sweep(tmp_path, """
[sweep]
kind = "campaign"
[fixed]
vehicle = "copter3d"
tune_args = ["--budget", "2", "--prior", "none", "--validation", "off", "--no-onboard-guard", "--confirm", "1"]
refly = 2
candidates = 1
seed = 0
[fixed.reference.gains]
PSC_NE_POS_P = 1.5
""", "camp")
    store = Store(tmp_path / "s")
    with open(tmp_path / "log.txt", "w") as out:
        summ = run(sw, LocalExecutor(), store, out=out)
    assert summ.ran == 1, (tmp_path / "log.txt").read_text()
    rec = store.records()[0]
    assert rec["status"] == "ok" and rec["flights"]["total"] == 3 and rec["flights"]["opt"] == 2
    assert rec["safety"] == {"crashed": 0, "aborted": 0, "interrupted": 0, "unsafe": 0}
    reflown = rec["result"]["reflown"]
    assert set(reflown) >= {"baseline", "rec", "long"} and all(len(v) == 2 for v in reflown.values())
    m = {k: sum(v) / 2 for k, v in reflown.items()}
    assert rec["result"]["cut"] == pytest.approx(1 - m["rec"] / m["baseline"])
    assert rec["result"]["share_of_long"] == pytest.approx((m["baseline"] - m["rec"]) / (m["baseline"] - m["long"]))
