"""The records of the benchmark scripts before ksbo-bench, converted once into the stores (kept to say how each old
field maps; running it again rewrites the converted stores from the old files if they are still there).

- benchmarks/plants/records.jsonl (bench_plants.py): today's monitored runs -> plants-monitor, the strict ones ->
  plants-strict, the paper setting -> plants-paper; every tagged run -> plants-history, its tag in the key;
  benchmarks/plants/tuning.jsonl (the tuning seeds, 100 and up) -> plants-tuning, its tag in the key.
- benchmarks/campaign/{vehicle,paper}/*.json (bench_campaign.py) -> paper-comparison; benchmarks/campaign-tuning/
  vehicle/*.json -> paper-tuning.
- benchmarks/short-campaign/runs.jsonl (bench_short_campaign.py) -> short-campaign: the wind as ``sitl_params``, a
  reference given by label as a reference to that label's record on the same vehicle and condition, one given by
  a campaign folder (long gone from /tmp) as the "long" record's; the old reference said in ``result``.

A converted record has ``run.executor`` "converted" and ``run.code`` "before ksbo-bench"; its date is the machine
line's where the old record had one; an old record without a machine line gets the one its last report named.

    python -m ksbo_bench.convert_legacy
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

from ksbo_bench.record import SCHEMA
from ksbo_bench.store import Store
from ksbo_bench.sweep import STORES

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
#: The machine of old records that name none: the one their last report named (runs not dated one by one).
LAST_REPORT_MACHINE = "AMD EPYC, 2 cores, Python 3.11.7, numpy 2.4.6 (as the last report of these records named it)"


def _run(machine: str | None, source: str) -> dict[str, Any]:
    machine = machine or LAST_REPORT_MACHINE
    m = re.search(r"(\d{4}-\d\d-\d\d) (\d\d:\d\d) UTC", machine or "")
    return {"code": "before ksbo-bench", "dirty": False,
            "machine": re.sub(r",? ?\d{4}-\d\d-\d\d \d\d:\d\d UTC", "", machine).strip(", ") if machine else None,
            "node": "", "executor": "converted", "started": f"{m.group(1)}T{m.group(2)}:00Z" if m else None,
            "attempts": 1, "source": source}


def _lines(rel: str):
    """The JSON lines of an old records file under benchmarks/ (none if it is gone)."""
    p = BENCH / rel
    if p.exists():
        yield from (json.loads(x) for x in p.read_text().splitlines() if x.strip())


def _rec(sweep: str, kind: str, key: dict, result: dict, source: str, machine: str | None, *, status: str = "ok",
         flights: dict | None = None, safety: dict | None = None, timing: dict | None = None) -> dict[str, Any]:
    """A converted record of ``source`` (an old file under benchmarks/) made on ``machine``."""
    return {"schema": SCHEMA, "sweep": sweep, "kind": kind, "key": key, "status": status, "flights": flights or {},
            "safety": safety or {}, "result": result, "timing": timing or {}, "run": _run(machine, source)}


FILES = {"plants-tuning": "tuning.jsonl"}


def plant_record(r: dict[str, Any], sweep: str) -> dict[str, Any]:
    key = {k: r[k] for k in ("mode", "budget", "n_prior", "plant", "method", "seed")}
    if r.get("local_prior"):
        key["local_prior"] = True
    if r.get("options"):
        key["options"] = r["options"]
    if sweep in ("plants-history", "plants-tuning"):
        key["tag"] = r["tag"]
    result = {k: r[k] for k in ("EP", "reflown_counts", "x", "orders", "reselection_changes", "stopped",
                                "first_unsafe_at", "stop", "rms_ref", "rms_change", "best_flown_change", "sitl",
                                "error") if k in r}
    if "kinds" in r:
        result["proposal_kinds"] = r["kinds"]
    n_prior = r.get("n_prior", 0)
    return {"schema": SCHEMA, "sweep": sweep, "kind": "plant", "key": key, "status": "ok",
            "flights": {"total": n_prior + (r.get("nfev") or 0), "prior": n_prior, "search": r.get("nfev"),
                        "reflown": int(sum(r.get("reflown_counts") or []))},
            "safety": {"crashed": r["n_crashed"], "aborted": r["n_aborted"], "interrupted": 0,
                       "unsafe": r["n_unsafe"], "prior_unsafe": r.get("n_prior_unsafe", 0)},
            "result": result,
            "timing": {"wall_s": r.get("wall_s"), "s_per_iter": r.get("s_per_iter"),
                       "s_per_iter_last20": r.get("s_per_iter_last20")},
            "run": _run(r.get("machine"), f"benchmarks/plants/{FILES.get(sweep, 'records.jsonl')}")}


def plant_sweep(r: dict[str, Any]) -> str:
    if r.get("tag"):
        return "plants-history"
    if r["mode"] == "monitor":
        return "plants-monitor"
    return "plants-strict" if r["n_prior"] == 0 else "plants-paper"


def paper_record(r: dict[str, Any], sweep: str, source: str) -> dict[str, Any]:
    drop = {"setting", "method", "seed", "n_unsafe", "unsafe_flights", "prior_unsafe", "n_prior", "seconds",
            "s_per_iter", "wall", "flights"}
    return {"schema": SCHEMA, "sweep": sweep, "kind": "paper",
            "key": {"setting": r["setting"], "method": r["method"], "seed": r["seed"]}, "status": "ok",
            "flights": {"total": len(r["flights"]), "prior": r["n_prior"], "search": len(r["y"]), "reflown": 16},
            "safety": {"crashed": None, "aborted": None, "interrupted": 0, "unsafe": r["unsafe_flights"],
                       "prior_unsafe": r["prior_unsafe"], "optimiser_unsafe": r["n_unsafe"]},
            "result": {k: v for k, v in r.items() if k not in drop},
            "timing": {"wall_s": r["wall"], "seconds": r["seconds"], "s_per_iter": r["s_per_iter"]},
            "run": _run(None, source)}


SPEED = {"ardupilot": 10.0, "px4": 5.0}


def campaign_record(r: dict[str, Any]) -> dict[str, Any]:
    key: dict[str, Any] = {"label": r.get("label", ""), "vehicle": r["stack"], "seed": r["seed"],
                           "tune_args": r["tune_args"]}
    if r.get("wind_mps"):
        key["sitl_params"] = {"SIM_WIND_SPD": r["wind_mps"], "SIM_WIND_TURB": r["turb"]}
    if r.get("speedup") and r["speedup"] != SPEED.get(r["stack"]):
        key["speedup"] = r["speedup"]
    if r.get("candidates_reflown") is not None and r["candidates_reflown"] != 4:
        key["candidates"] = r["candidates_reflown"]
    ref = r.get("reference") or ""
    if ref.startswith("label ") or (ref and key["label"] in ("default", "try-orders-1")):  # today's long campaigns
        label = ref[6:] if ref.startswith("label ") else "long"
        key["reference"] = {"sweep": "short-campaign", "key": {"label": label}, "match": ["vehicle", "sitl_params"]}
    elif ref:  # a long campaign of an earlier default, by its folder: said, not resolvable again
        key["reference"] = {"campaign_dir": ref}
    kinds = r.get("kinds", {})
    result = {k: r[k] for k in ("rc", "rms_per_flight", "search_end", "candidates", "reflown", "best_values", "cut",
                                "target_rms", "flights_to_90", "share_of_long", "error") if k in r}
    result["reference_was"] = r.get("reference")
    aborted = r.get("aborted", 0)  # the old count: aborted and crashed by the gains
    return {"schema": SCHEMA, "sweep": "short-campaign", "kind": "campaign", "key": key,
            "status": "ok" if r.get("rc") == 0 and "error" not in r else "failed",
            "flights": {"total": r.get("flights"), **kinds,
                        "reflown": sum(len(v) for v in r.get("reflown", {}).values())},
            "safety": {"crashed": None, "aborted": aborted, "interrupted": r.get("interrupted", 0),
                       "unsafe": r.get("unsafe")},
            "result": result, "timing": {"wall_s": r.get("wall_s"), "campaign_s": r.get("wall_s")},
            "run": _run(r.get("machine"), "benchmarks/short-campaign/runs.jsonl")}


def _write(sweep: str, recs: list[dict[str, Any]]) -> None:
    """The converted records first, then those the runner wrote (kept: converting again changes only the
    converted ones)."""
    st = Store(STORES / sweep)
    own = [r for r in st if r.get("run", {}).get("executor") != "converted"]
    st.dir.mkdir(parents=True, exist_ok=True)
    st.path.write_text("".join(json.dumps(r) + "\n" for r in recs + own))
    print(f"{sweep}: {len(recs)} records converted, {len(own)} of the runner kept -> {st.path}")


def fold_short_campaign(runs: Path = BENCH / "short-campaign" / "runs.jsonl") -> None:
    """The runs of scripts/bench_short_campaign.py, converted into the short-campaign store (again: the store's
    converted records are replaced, the runner's kept)."""
    if runs.exists():
        _write("short-campaign", [campaign_record(json.loads(x)) for x in runs.read_text().splitlines() if x.strip()])


def main() -> None:
    out: dict[str, list[dict[str, Any]]] = {}
    plants = BENCH / "plants" / "records.jsonl"
    if plants.exists():
        for line in plants.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                s = plant_sweep(r)
                out.setdefault(s, []).append(plant_record(r, s))
    tuning = BENCH / "plants" / "tuning.jsonl"
    if tuning.exists():
        out["plants-tuning"] = [plant_record(json.loads(x), "plants-tuning") for x in tuning.read_text().splitlines()
                                if x.strip()]
    for folder, sweep in ((BENCH / "campaign", "paper-comparison"), (BENCH / "campaign-tuning", "paper-tuning")):
        for setting in ("vehicle", "paper"):
            for p in sorted((folder / setting).glob("*.json")):
                out.setdefault(sweep, []).append(paper_record(json.loads(p.read_text()), sweep,
                                                              p.relative_to(BENCH.parent).as_posix()))
    for sweep, recs in out.items():
        _write(sweep, recs)
    fold_short_campaign()


if __name__ == "__main__":
    main()
