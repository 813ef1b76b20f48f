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


def _validation(flights: list[dict[str, Any]]) -> dict[str, Any]:
    """The old run's validation flights as the ``validation`` analysis records them
    (ksbo_bench.kinds.campaign_validation)."""
    from ksbo_mav.campaign.verdict import DECIDING, judge

    judged = {}
    for m in dict.fromkeys(f["manoeuvre"] for f in flights):
        mine = [f for f in flights if f["manoeuvre"] == m]
        if any(f["outcome"] == "error" for f in mine):
            continue  # not flown by the vehicle: in validation_not_completed
        sides = [[f for f in mine if (f["gains"] == "baseline") == b] for b in (True, False)]
        j = judge(*([f["metrics"].get(DECIDING[m]) for f in s if f["outcome"] == "ok"] for s in sides),
                  *(sum(f["outcome"] != "ok" for f in s) for s in sides))
        judged[m] = {"verdict": j.verdict, "metric": DECIDING[m], "base": list(j.base), "cand": list(j.cand),
                     "spread": j.spread, "diff": j.diff, "base_aborted": j.base_aborted,
                     "cand_aborted": j.cand_aborted}
    return {"validation_flights": len(flights), "verdicts": {"recommendation": judged},
            "validation_by_manoeuvre": {m: sum(f["manoeuvre"] == m for f in flights)
                                        for m in dict.fromkeys(f["manoeuvre"] for f in flights)},
            "validation_not_completed": [{k: f[k] for k in ("manoeuvre", "gains", "outcome", "message")}
                                         for f in flights if f["outcome"] != "ok"]}


def wind_records() -> list[dict[str, Any]]:
    """The first PX4 main campaign in wind (benchmarks/px4-main-wind/runs.jsonl, scripts/bench_short_campaign.py)
    and the wind-preflight lean records (benchmarks/wind-preflight/runs.jsonl, scripts/bench_wind_lean.py) ->
    wind-campaigns, label "was-first": one record per campaign."""
    camp = BENCH / "px4-main-wind" / "runs.jsonl"
    lean = BENCH / "wind-preflight" / "runs.jsonl"
    if not camp.exists() or not lean.exists():
        return []
    leans = {r["stack"]: r for r in map(json.loads, lean.read_text().splitlines())}
    out = []

    def preflight(r: dict[str, Any]) -> dict[str, Any]:
        return {"drag": r["drag"], "decided": {k: v for k, v in r["decided"].items() if k != "text"},
                "flown_scale": r["flown_scale"], "predicted_full_deg": r["predicted_full_deg"],
                "predicted_flown_deg": r["predicted_flown_deg"], "baseline_leans_deg": r["baseline_leans_deg"]}

    for r in map(json.loads, camp.read_text().splitlines()):
        fl = r["flights"]
        confirm = [f["rms_lap2_m"] for f in fl if f["kind"] == "confirm"]
        result = {"rc": 2, "rms_per_flight": [f["rms_lap2_m"] for f in fl], "baseline_rms": [fl[0]["rms_lap2_m"]],
                  "confirm_rms": confirm, **_validation(r["validation"]),
                  "wind": {"set": {"mps": 5.0, "from_deg": 45.0}, "flights": len(fl),
                           "inferred_mps": sorted(f["wind_inferred_mps"] for f in fl)[len(fl) // 2],
                           "inferred_from_deg": 45, "sign_ok": True},
                  "wind_preflight": preflight(leans["px4"]), "error": r["verdicts"]["auto_mission"][:300],
                  "refly_note": "re-fly " + r["refly"].split(" (")[0]}
        out.append({"schema": SCHEMA, "sweep": "wind-campaigns", "kind": "campaign",
                    "key": {"label": "was-first", "vehicle": "px4", "build": "px4-main", "speedup": 1.0, "seed": 0,
                            "tune_args": ["--wind", "5"], "sitl_params": {"SIH_WIND_N": 3.54, "SIH_WIND_E": 3.54},
                            "candidates": 0},
                    "status": "failed", "flights": {"total": len(fl), "opt": len(fl) - 1, "confirm": 1, "reflown": 0},
                    "safety": {"crashed": 0, "aborted": 0, "interrupted": 0, "unsafe": 0},
                    "result": result, "timing": {}, "run": _run(r["machine"], "benchmarks/px4-main-wind/runs.jsonl")})
    a = leans["ardupilot"]
    out.append({"schema": SCHEMA, "sweep": "wind-campaigns", "kind": "campaign",
                "key": {"label": "was-first", "vehicle": "ardupilot", "speedup": 3.0, "seed": 0,
                        "tune_args": ["--wind", "5", "--prior", "none", "--budget", "3", "--validation", "off"],
                        "sitl_params": {"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 45.0, "SIM_WIND_TURB": 0.0},
                        "refly": 0},
                "status": "ok", "flights": {}, "safety": {},
                "result": {"wind_preflight": preflight(a), "refly_note": "lean only: the campaign not recorded"},
                "timing": {}, "run": _run(a["machine"], "benchmarks/wind-preflight/runs.jsonl")})
    return out


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
    wind = wind_records()
    if wind:
        out["wind-campaigns"] = wind
    for sweep, recs in out.items():
        _write(sweep, recs)
    fold_short_campaign()


if __name__ == "__main__":
    main()
