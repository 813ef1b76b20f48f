"""Cell kind ``campaign``: a full ``ksbo-mav tune`` campaign from the ground on a fresh vehicle (ksbo_bench.kinds.
vehicles), then, on the vehicle it left hovering, named gain sets re-flown in turn by separate flights
(ksbo_bench.kinds.independent_refly): the baseline, the recommendation, the best flown gains at the last flights
where they changed, and reference gains (another sweep's recorded recommendation: a long campaign, an oracle's optimum).

Key: ``vehicle``, ``seed``; ``tune_args`` (a list: what `tune` gets besides the vehicle, e.g. ["--budget", "10"]),
``refly`` (flights of each set, default 3; 0: none), ``candidates`` (best-so-far sets re-flown, default 4),
``refly_after`` (also the best flown gains after these flights), ``reference`` (gains re-flown as "long": a table
``gains`` of parameter values, or the recorded ``best_values`` of a sweep's cell — ``sweep``, the values its key
must have (``key``) and the names whose values must equal this cell's (``match``, e.g. ["vehicle",
"sitl_params"]); resolved on the driver's machine, the newest such record), ``export`` (keep in the record the
files a warm start reads: campaign.json, result.json, journal.jsonl), ``warm_start`` (the same kind of
reference to an exported record: `tune --warm-start` from it), ``change_at`` / ``change_params`` (a SITL condition
changed mid-campaign), ``analyses`` (ksbo_bench.kinds.campaign_analyses), ``check_params`` (our simulator: read
the parameters left changed too; SITLs always), ``keep`` (keep the working folder); the vehicle's own values
(vehicles.py: ``build``, ``speedup``, ``sitl_params``, ``personality``, ``sim_args``, ``link``).

Figures: flights (as the README counts them: the baseline is flight 1, every prior, re-flight and confirmation
counts), the campaign's safety (aborted and crashed by the gains, interrupted by the vehicle or link, P < 0), every
flight's lap-2 RMS, the re-flown RMS of each set, the cut (1 − R / B) and, with a reference, the share of the
reference's cut and the flight at which the best-so-far gains re-fly within 90 % of it; what the console said
(ksbo_bench.kinds.campaign_figures). A campaign the tool stopped by its own rule (exit 3: the drift test, a pack
to swap) is a result with status "stopped".
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import InfraError, NotYet, SweepError
from ksbo_bench.kinds import campaign_analyses
from ksbo_bench.kinds.campaign_figures import best_so_far, console_figures, reached_at, refly_figures
from ksbo_bench.kinds.independent_refly import changed_params, refly_in_turn
from ksbo_bench.kinds.work_folder import in_work_folder
from ksbo_bench.kinds.vehicles import OURS, VEHICLES, change_at, fresh_vehicle, is_sitl

__all__ = ["best_so_far", "check", "inputs", "resources", "run"]

N_CANDIDATES = 4
#: Journal outcomes of a trial the monitor stopped because of the gains (a crash is counted apart).
GAIN_ABORTS = ("fence", "tilt", "track")
#: The files of a finished campaign a warm start reads (``export``).
EXPORTED = ("campaign.json", "result.json", "journal.jsonl")


def check(key: dict[str, Any]) -> None:
    if key["vehicle"] not in VEHICLES:
        raise SweepError(f"vehicle must be one of {', '.join(VEHICLES)}, not {key['vehicle']!r}")
    if not isinstance(key.get("tune_args", []), list):
        raise SweepError("tune_args is a list of strings, e.g. [\"--budget\", \"10\"]")
    if key.get("link") and key["vehicle"] in OURS:
        raise SweepError("link: the link emulator stands between a SITL and the tuner (vehicle ardupilot or px4)")
    bad = [a for a in key.get("analyses", []) if a not in campaign_analyses.ANALYSES]
    if bad:
        raise SweepError(f"unknown analysis {bad[0]!r}; known: {', '.join(campaign_analyses.ANALYSES)}")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {"sitl": 1} if is_sitl(key) else {}


def recorded(key: dict[str, Any], ref: dict[str, Any], field: str) -> Any:
    """``field`` of ``result`` in the newest record of ``ref["sweep"]`` whose key has the ``ref["key"]`` values and
    this cell's values of ``ref["match"]``. NotYet when that sweep holds none (yet)."""
    from ksbo_bench import sweep as sweeps
    from ksbo_bench.store import Store

    sw = sweeps.load(ref["sweep"])
    want = {**{m: key.get(m) for m in ref.get("match", [])}, **ref.get("key", {})}
    found = [r for r in Store(sw.store) if r["result"].get(field)
             and all(r["key"].get(k) == v for k, v in want.items())]
    if not found:
        raise NotYet(f"no record of {sw.name} with {field} and {json.dumps(want)} (run those cells first)")
    return found[-1]["result"][field]


def reference_gains(key: dict[str, Any]) -> dict[str, float]:
    """The gains the cell's ``reference`` names: given, or another cell's recorded ``best_values``."""
    ref = key["reference"]
    return dict(ref["gains"]) if "gains" in ref else recorded(key, ref, "best_values")


def inputs(key: dict[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if "reference" in key:
        out["reference"] = reference_gains(key)
    if "warm_start" in key:
        out["warm_start"] = recorded(key, key["warm_start"], "folder")
    return out


def _tune(d: Path, conn: list[str], key: dict[str, Any], extra: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, "--seed", str(key["seed"]),
                           "--end", "hold", "--json", *extra, *map(str, key.get("tune_args", []))],
                          capture_output=True, text=True, timeout=float(key.get("timeout_s", 7200)))


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    """The cell's record parts; its working folder is removed after a campaign that ended normally (or stopped by
    the tool's own rule), kept and named in ``result.kept`` otherwise (ksbo_bench.kinds.work_folder)."""
    return in_work_folder("campaign", _run, key, inputs)


def _earlier(work: Path, files: dict[str, str] | None) -> list[str]:
    """`tune --warm-start DIR` with the exported files of the earlier campaign written to DIR."""
    if not files:
        return []
    d = work / "earlier"
    d.mkdir()
    for name, text in files.items():
        (d / name).write_text(text)
    return ["--warm-start", str(d)]


def _safety(entries: list[dict]) -> dict[str, int]:
    """The journal's outcomes (ksbo_mav.mav.outcome.TrialOutcome): crash; fence, tilt, track (the gains)."""
    return {"crashed": sum(e["outcome"] == "crash" for e in entries),
            "aborted": sum(e["outcome"] in GAIN_ABORTS for e in entries),
            "interrupted": sum(e["kind"] == "failed" for e in entries),
            "unsafe": sum(e["kind"] == "opt" and e.get("P") is not None and e["P"] < 0 for e in entries)}


def _run(key: dict[str, Any], inp: dict[str, Any], work: Path) -> dict[str, Any]:
    d = work / "campaign"
    result: dict[str, Any] = {}
    timing: dict[str, Any] = {}
    with fresh_vehicle(key, work) as v:
        t0 = time.time()
        with change_at(key, d / "journal.jsonl", v.sitl, result):
            r = _tune(d, v.conn, key, _earlier(work, inp.get("warm_start")))
        timing["campaign_s"] = round(time.time() - t0, 1)
        if v.sitl is not None and not v.sitl.alive:
            raise InfraError(f"the SITL died during the campaign: {v.sitl.output()[-300:]}")
        journal = d / "journal.jsonl"
        if r.returncode not in (0, 3) and not journal.exists():  # no flight made: the tool refused, or no link
            err = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
            if "link" in err.lower() or "heartbeat" in err.lower():
                raise InfraError(f"tune: {err}")
            return {"status": "failed", "result": {"error": err, "rc": r.returncode}, "timing": timing}
        entries = [json.loads(x) for x in journal.read_text().splitlines() if x.strip()] if journal.exists() else []
        out = json.loads((d / "result.json").read_text()) if (d / "result.json").exists() else {}
        kinds = {k: sum(e["kind"] == k for e in entries) for k in sorted({e["kind"] for e in entries})}
        result.update(rc=r.returncode, rms_per_flight=[round(e["rms"], 4) if e.get("rms") else None for e in entries],
                      rough_per_flight=[round(e["rough"], 3) if e.get("rough") else None for e in entries],
                      box=out.get("box"), search_end=out.get("search_end"), **console_figures(r.stderr))
        if r.returncode not in (0, 3):
            result["error"] = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
        best = out.get("best")
        if best and key.get("refly", 3):
            _refly(key, inp.get("reference"), d, v.ep, best, entries, result, timing)
        if best:
            result["best_values"] = best["values"]
        if v.sitl is not None or key.get("check_params"):
            stack = key["vehicle"] if v.sitl is not None else key.get("personality", "ours")
            result["changed_params"] = changed_params(v.direct, stack, d)
    if v.info.get("link"):
        result["link"] = v.info["link"]
    if "warm_start" in key and "long" in result.get("reflown", {}):
        result["reached_at"] = reached_at(result["rms_per_flight"], result["reflown"]["long"])
    if key.get("export") and best:
        result["folder"] = {n: (d / n).read_text() for n in EXPORTED if (d / n).exists()}
    campaign_analyses.run(key, d, result)
    flights = {"total": len(entries), **kinds, "reflown": sum(len(x) for x in result.get("reflown", {}).values())}
    status = {0: "ok", 3: "stopped"}.get(r.returncode, "failed")
    return {"status": status, "flights": flights, "safety": _safety(entries), "result": result, "timing": timing}


def _refly(key: dict[str, Any], ref: dict[str, float] | None, d: Path, ep, best: dict, entries: list[dict],
           result: dict[str, Any], timing: dict[str, Any]) -> None:
    """The re-fly in turn: baseline, recommendation, best-so-far gains, ``refly_after`` gains, the reference."""
    names = list(best["values"])
    found = best_so_far(entries, names)
    n = key.get("candidates", N_CANDIDATES)
    cands = found[-n:] if n else []
    result["candidates"] = [(k, round(rms, 4)) for k, _, rms in cands]
    gains = {"rec": best["values"], **{f"f{k}": g for k, g, _ in cands}}
    for k in key.get("refly_after", []):
        upto = [g for j, g, _ in found if j <= k]
        if upto:
            gains[f"after{k}"] = upto[-1]
    if ref:
        gains["long"] = ref
    t1 = time.time()
    smooth: dict[str, dict[str, list[float | None]]] = {}
    result["reflown"] = refly_in_turn(d, ep, gains, key.get("refly", 3), smooth)
    for name, per_set in smooth.items():  # reflown_rough (deg/s), reflown_motor (µs)
        if any(v is not None for values in per_set.values() for v in values):
            result[f"reflown_{name}"] = per_set
    timing["refly_s"] = round(time.time() - t1, 1)
    refly_figures(result, cands, len(entries))
