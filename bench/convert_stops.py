"""The records of scripts/bench_fault_matrix.py and scripts/bench_wind_inference.py (before they were the ``fault``
and ``wind`` kinds), converted once into the stores ``fault-matrix`` and ``wind-inference`` (kept to say how each
old field maps; the old files are in git history: ``git show 38da817:benchmarks/fault-matrix/runs.jsonl``).

- A fault case's old record is the kind's ``result`` as it is (the same fields); its key the case's fault, phase and
  pilot with the script's fixed speed-up (10) and seed (0). The old script kept no journal: ``flights`` and
  ``safety`` are not known (None). A case that failed to set up (the kind raises InfraError and writes nothing) is
  left out.
- A wind case's trials are the kind's; the median, range and error are computed from its completed trials as the
  kind does; the exit status ``exit`` is ``rc``, the stderr's last line ``error_text``.

    python -m ksbo_bench.convert_stops OLD_FAULT_RUNS.jsonl OLD_WIND_RUNS.jsonl
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path
from typing import Any

from ksbo_bench.convert_legacy import _run, _write
from ksbo_bench.record import SCHEMA

FIXED = {"speedup": 10.0, "seed": 0}
UNKNOWN_SAFETY = {"crashed": None, "aborted": None, "interrupted": None, "unsafe": None}


def fault_record(r: dict[str, Any]) -> dict[str, Any] | None:
    if "fault" not in r:  # the case failed to set up: no record, as the kind writes none
        return None
    result = {k: v for k, v in r.items() if k not in ("fault", "phase", "pilot", "machine", "wall_s")}
    return {"schema": SCHEMA, "sweep": "fault-matrix", "kind": "fault",
            "key": {"fault": r["fault"], "phase": r["phase"], "pilot": r["pilot"], **FIXED}, "status": "ok",
            "flights": {"total": None, "validation": None}, "safety": dict(UNKNOWN_SAFETY), "result": result,
            "timing": {"case_s": r.get("wall_s")}, "run": _run(r.get("machine"), "benchmarks/fault-matrix/runs.jsonl")}


def wind_record(r: dict[str, Any]) -> dict[str, Any]:
    shape = "flat" if r["set"]["SIM_WIND_T"] == 1.0 else "sqrt"
    trials = [{k: t[k] for k in ("trial", "outcome", "speed", "from_deg")} for t in r["trials"]]
    speeds = [t["speed"] for t in trials if t["outcome"] == "ok" and t["speed"] is not None]
    dirs = [t["from_deg"] for t in trials if t["outcome"] == "ok" and t["from_deg"] is not None]
    blows = r.get("blows_mps")
    result: dict[str, Any] = {"rc": r["exit"], "height_m": r["height_m"], "trials": trials,
                              "how": next((t["how"] for t in r["trials"] if t.get("how")), None),
                              "blows_mps": blows, "blows_from_deg": r.get("blows_from_deg")}
    if speeds and blows:
        med = statistics.median(speeds)
        result.update(inferred_median=round(med, 3), inferred_min=round(min(speeds), 3),
                      inferred_max=round(max(speeds), 3), n_inferred=len(speeds),
                      error=round((med - blows) / blows, 4), within_30pct=abs(med - blows) <= 0.3 * blows,
                      range_contains=min(speeds) <= blows <= max(speeds))
        if dirs:
            result.update(from_min_deg=round(min(dirs)), from_max_deg=round(max(dirs)))
    if r["exit"] != 0:
        result["error_text"] = ([s for s in r.get("stderr_tail", "").splitlines() if s.strip()] or ["?"])[-1][:300]
    outcomes = [t["outcome"] for t in trials]
    return {"schema": SCHEMA, "sweep": "wind-inference", "kind": "wind",
            "key": {"speed": r["set"]["SIM_WIND_SPD"], "shape": shape, "from_deg": r["set"]["SIM_WIND_DIR"],
                    **FIXED},
            "status": "ok" if r["exit"] == 0 else "failed", "flights": {"total": len(trials)},
            "safety": {"crashed": outcomes.count("crash"), "aborted": None, "interrupted": outcomes.count("link"),
                       "unsafe": 0},
            "result": result, "timing": {"wall_s": r.get("wall_s")},
            "run": _run(r.get("machine"), "benchmarks/wind-inference/runs.jsonl")}


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()]


def main(argv: list[str]) -> None:
    fault_runs, wind_runs = map(Path, argv)
    _write("fault-matrix", [rec for r in _lines(fault_runs) if (rec := fault_record(r)) is not None])
    _write("wind-inference", [wind_record(r) for r in _lines(wind_runs)])


if __name__ == "__main__":
    main(sys.argv[1:])
