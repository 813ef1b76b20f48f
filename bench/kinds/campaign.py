"""Cell kind ``campaign``: a full ``ksbo-mav tune`` campaign from the ground on a fresh vehicle (ksbo_bench.kinds.
vehicles), then, on the vehicle it left hovering, named gain sets re-flown in turn by separate flights
(ksbo_bench.kinds.independent_refly): the baseline, the recommendation, the best flown gains at the last flights
where they changed, and reference gains (another sweep's recorded recommendation: a long campaign, an oracle's optimum).

Key: ``vehicle``, ``seed``; ``tune_args`` (a list: what `tune` gets besides the vehicle, e.g. ["--budget", "10"]),
``refly`` (flights of each set, default 3; 0: none), ``candidates`` (best-so-far sets re-flown, default 4),
``refly_after`` (also the best flown gains after these flights), ``reference`` (gains re-flown as "long": a table
``gains`` of parameter values, or the recorded ``best_values`` of a sweep's cell — ``sweep``, the values its key
must have (``key``) and the names whose values must equal this cell's (``match``, e.g. ["vehicle",
"sitl_params"]); resolved on the driver's machine, the newest such record),
``change_at`` / ``change_params`` (a SITL condition changed mid-campaign), ``keep`` (keep the working folder);
the vehicle's own values (vehicles.py).

Figures: flights (as the README counts them: the baseline is flight 1, every prior, re-flight and confirmation
counts), the campaign's safety (aborted and crashed by the gains, interrupted by the vehicle or link, P < 0), every
flight's lap-2 RMS, the re-flown RMS of each set, the cut (1 − R / B) and, with a reference, the share of the
reference's cut and the flight at which the best-so-far gains re-fly within 90 % of it.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import InfraError
from ksbo_bench.kinds.independent_refly import changed_params, mean, refly_in_turn
from ksbo_bench.kinds.vehicles import VEHICLES, change_at, fresh_vehicle, is_sitl
from ksbo_bench.cell_errors import SweepError

N_CANDIDATES = 4
#: Journal outcomes of a trial the monitor stopped because of the gains (a crash is counted apart).
GAIN_ABORTS = ("fence", "tilt", "track")


def check(key: dict[str, Any]) -> None:
    if key["vehicle"] not in VEHICLES:
        raise SweepError(f"vehicle must be one of {', '.join(VEHICLES)}, not {key['vehicle']!r}")
    if not isinstance(key.get("tune_args", []), list):
        raise SweepError("tune_args is a list of strings, e.g. [\"--budget\", \"10\"]")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {"sitl": 1} if is_sitl(key) else {}


def reference_gains(key: dict[str, Any]) -> dict[str, float]:
    """The gains the cell's ``reference`` names: given, or the newest recorded ``best_values`` of a sweep's cell
    whose key has the ``key`` values and this cell's values of ``match``."""
    ref = key["reference"]
    if "gains" in ref:
        return dict(ref["gains"])
    from ksbo_bench import sweep as sweeps
    from ksbo_bench.store import Store

    sw = sweeps.load(ref["sweep"])
    want = {**{m: key.get(m) for m in ref.get("match", [])}, **ref.get("key", {})}
    found = [r for r in Store(sw.store) if r["result"].get("best_values")
             and all(r["key"].get(k) == v for k, v in want.items())]
    if not found:
        raise SweepError(f"reference: no record of {sw.name} with best_values and {json.dumps(want)}")
    return found[-1]["result"]["best_values"]


def inputs(key: dict[str, Any]) -> dict[str, Any]:
    return {"reference": reference_gains(key)} if "reference" in key else {}


def best_so_far(entries: list[dict], names: list[str]) -> list[tuple[int, dict[str, float], float]]:
    """[(flight number, gains, its flown lap RMS)] each time the best flown gains changed (baseline excluded)."""
    out: list[tuple[int, dict[str, float], float]] = []
    best = None
    for k, e in enumerate(entries):
        if k == 0 or e["kind"] == "baseline" or e["outcome"] != "ok" or not e.get("rms"):
            continue
        if best is None or e["rms"] < best:
            best = e["rms"]
            out.append((k + 1, dict(zip(names, e["x"])), e["rms"]))
    return out


def _tune(d: Path, conn: list[str], key: dict[str, Any]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, "--seed", str(key["seed"]),
                           "--end", "hold", "--json", *map(str, key.get("tune_args", []))],
                          capture_output=True, text=True, timeout=float(key.get("timeout_s", 7200)))


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """The cell's record parts; its working folder (the campaign, its logs, the SITL's) is removed after a
    campaign that ended normally, kept and named in ``result.kept`` otherwise (a few MB each: 1,000 cells would
    fill a node's /tmp)."""
    work = Path(tempfile.mkdtemp(prefix="ksbo-bench-campaign-"))
    try:
        out = _run(key, (inputs or {}).get("reference"), work)
    except BaseException:
        print(f"campaign cell: its folder is kept: {work}", file=sys.stderr)
        raise
    if out["status"] == "ok" and not key.get("keep"):
        shutil.rmtree(work, ignore_errors=True)
    else:
        out["result"]["kept"] = str(work)
    return out


def _run(key: dict[str, Any], ref: dict[str, float] | None, work: Path) -> dict[str, Any]:
    d = work / "campaign"
    result: dict[str, Any] = {}
    timing: dict[str, Any] = {}
    with fresh_vehicle(key, work) as (conn, ep, sitl):
        t0 = time.time()
        with change_at(key, d / "journal.jsonl", sitl, result):
            r = _tune(d, conn, key)
        timing["campaign_s"] = round(time.time() - t0, 1)
        if sitl is not None and not sitl.alive:
            raise InfraError(f"the SITL died during the campaign: {sitl.output()[-300:]}")
        journal = d / "journal.jsonl"
        if r.returncode != 0 and not journal.exists():  # no flight made: the tool refused (a bad option, no link)
            err = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
            if "link" in err.lower() or "heartbeat" in err.lower():
                raise InfraError(f"tune: {err}")
            return {"status": "failed", "result": {"error": err, "rc": r.returncode}, "timing": timing}
        entries = [json.loads(x) for x in journal.read_text().splitlines() if x.strip()]
        out = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else {}
        # the journal's outcomes (ksbo_mav.mav.outcome.TrialOutcome): crash; fence, tilt, track (the gains)
        safety = {"crashed": sum(e["outcome"] == "crash" for e in entries),
                  "aborted": sum(e["outcome"] in GAIN_ABORTS for e in entries),
                  "interrupted": sum(e["kind"] == "failed" for e in entries),
                  "unsafe": sum(e["kind"] == "opt" and e.get("P") is not None and e["P"] < 0 for e in entries)}
        kinds = {k: sum(e["kind"] == k for e in entries) for k in sorted({e["kind"] for e in entries})}
        result.update(rc=r.returncode, rms_per_flight=[round(e["rms"], 4) if e.get("rms") else None for e in entries],
                      search_end=out.get("search_end"))
        if r.returncode != 0:
            result["error"] = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
        best = out.get("best")
        if best and key.get("refly", 3):
            names = list(best["values"])
            found = best_so_far(entries, names)
            cands = found[-key.get("candidates", N_CANDIDATES):] if key.get("candidates", N_CANDIDATES) else []
            result["candidates"] = [(k, round(rms, 4)) for k, _, rms in cands]
            gains = {"rec": best["values"], **{f"f{k}": g for k, g, _ in cands}}
            for k in key.get("refly_after", []):
                upto = [g for j, g, _ in found if j <= k]
                if upto:
                    gains[f"after{k}"] = upto[-1]
            if ref:
                gains["long"] = ref
            t1 = time.time()
            result["reflown"] = refly_in_turn(d, ep, gains, key.get("refly", 3))
            timing["refly_s"] = round(time.time() - t1, 1)
            _figures(result, cands, len(entries))
        if best:
            result["best_values"] = best["values"]
        if sitl is not None:
            result["changed_params"] = changed_params(sitl, d)
    flights = {"total": len(entries), **kinds, "reflown": sum(len(v) for v in result.get("reflown", {}).values())}
    return {"status": "ok" if r.returncode == 0 else "failed", "flights": flights, "safety": safety,
            "result": result, "timing": timing}


def _figures(result: dict[str, Any], cands: list, n_flights: int) -> None:
    """cut, and against a reference: the target, the share of its cut, the flights to 90 % of it."""
    m = {k: mean(v) for k, v in result["reflown"].items()}
    if m.get("rec") is None or not m.get("baseline"):
        return
    result["cut"] = 1 - m["rec"] / m["baseline"]
    if m.get("long") is not None:
        target = m["baseline"] - 0.9 * (m["baseline"] - m["long"])
        result["target_rms"] = target
        hits = [k for k, _, _ in cands if m.get(f"f{k}") is not None and m[f"f{k}"] <= target]
        result["flights_to_90"] = min(hits) if hits else (n_flights if m["rec"] <= target else None)
        if m["baseline"] != m["long"]:
            result["share_of_long"] = (m["baseline"] - m["rec"]) / (m["baseline"] - m["long"])
