"""Cell kind ``wind``: the wind the report infers against the wind ArduCopter SITL blows.

ArduCopter without drag fusion streams WIND 0 whatever blows; the report then infers the wind from each trial's own
telemetry (the lean angle against the ground velocity under a drag model: ksbo_mav.flightlog.wind_fit) and shows
the range over the trials. A fresh SITL (``speedup``, default 10) in a steady wind (``speed`` m/s from ``from_deg``,
default 45; no gusts) flies a short campaign (``ksbo-mav tune --budget 3 --confirm 1 --prior none --method random
--validation off``); each completed trial's inferred wind is read from the journal and compared with what the SITL
blows at the mission's height, from its own parameters (ksbo_mav.mav.wind_source.simulated_wind): ``shape`` "flat"
(``SIM_WIND_T`` 1) blows the set speed at every height; "sqrt" (0, SITL's default) shapes it by sqrt(h / 60 m),
41 % of the set speed at the mission's 10 m.

Figures: ``blows_mps``, the inferred ``inferred_median`` / ``inferred_min`` / ``inferred_max`` (m/s) and their
directions, ``error`` (the median against what blows), ``within_30pct``, ``range_contains`` (the report's range
holds what blows).

Key: ``speed``, ``shape``; ``from_deg``, ``speedup``, ``seed``.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import SweepError

SHAPES = {"flat": 1.0, "sqrt": 0.0}
#: The short campaign each cell flies: the baseline, two random trials, one confirmation.
TUNE = ("--budget", "3", "--confirm", "1", "--prior", "none", "--method", "random", "--validation", "off", "--end",
        "hold")


def check(key: dict[str, Any]) -> None:
    if key["shape"] not in SHAPES:
        raise SweepError(f"shape must be one of {', '.join(SHAPES)}, not {key['shape']!r}")
    if not isinstance(key["speed"], (int, float)) or key["speed"] <= 0:
        raise SweepError(f"speed is a wind speed in m/s above 0, not {key['speed']!r}")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {"sitl": 1}


def sitl_params(key: dict[str, Any]) -> dict[str, float]:
    return {"SIM_WIND_SPD": float(key["speed"]), "SIM_WIND_DIR": float(key.get("from_deg", 45.0)),
            "SIM_WIND_TURB": 0.0, "SIM_WIND_T": SHAPES[key["shape"]]}


def run(key: dict[str, Any], inputs: dict[str, Any] | None = None) -> dict[str, Any]:
    from ksbo_bench.kinds.campaign import GAIN_ABORTS
    from ksbo_bench.kinds.vehicles import fresh_vehicle
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.mav.wind_source import simulated_wind

    vkey = {"vehicle": "ardupilot", "speedup": key.get("speedup", 10.0), "sitl_params": sitl_params(key)}
    with tempfile.TemporaryDirectory(prefix="ksbo-bench-wind-") as tmp:
        d = Path(tmp) / "campaign"
        with fresh_vehicle(vkey, Path(tmp)) as fresh:
            r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *fresh.conn, *TUNE,
                                "--seed", str(key.get("seed", 0))], capture_output=True, text=True, timeout=3600)
        journal = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()] \
            if (d / "journal.jsonl").exists() else []
        snap = {n: v for n, (v, _) in load_snapshot(d).params.items()} if (d / "snapshot").exists() else {}
        height = json.loads((d / "campaign.json").read_text())["mission"]["center_up"] \
            if (d / "campaign.json").exists() else 10.0
    blows = simulated_wind(snap, height) if snap else None
    trials = [{"trial": k, "outcome": e["outcome"], "speed": e["cond"].get("wind_inferred_mps"),
               "from_deg": e["cond"].get("wind_inferred_from_deg")} for k, e in enumerate(journal) if e.get("cond")]
    how = next((e["cond"]["wind_inferred_how"] for e in journal if (e.get("cond") or {}).get("wind_inferred_how")),
               None)
    speeds = [t["speed"] for t in trials if t["outcome"] == "ok" and t["speed"] is not None]
    dirs = [t["from_deg"] for t in trials if t["outcome"] == "ok" and t["from_deg"] is not None]
    result: dict[str, Any] = {"rc": r.returncode, "height_m": height, "trials": trials, "how": how,
                              "blows_mps": None if blows is None else round(blows[0], 3),
                              "blows_from_deg": None if blows is None else blows[1],
                              "blows_how": None if blows is None else blows[2]}
    if speeds and blows:
        med = statistics.median(speeds)
        result.update(inferred_median=round(med, 3), inferred_min=round(min(speeds), 3),
                      inferred_max=round(max(speeds), 3), n_inferred=len(speeds),
                      error=round((med - blows[0]) / blows[0], 4), within_30pct=abs(med - blows[0]) <= 0.3 * blows[0],
                      range_contains=min(speeds) <= blows[0] <= max(speeds))
        if dirs:
            result.update(from_min_deg=round(min(dirs)), from_max_deg=round(max(dirs)))
    if r.returncode != 0:
        result["error_text"] = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
    safety = {"crashed": sum(e["outcome"] == "crash" for e in journal),
              "aborted": sum(e["outcome"] in GAIN_ABORTS for e in journal),
              "interrupted": sum(e["kind"] == "failed" for e in journal), "unsafe": 0}
    return {"status": "ok" if r.returncode == 0 else "failed", "flights": {"total": len(journal)},
            "safety": safety, "result": result, "timing": {"load_1min": round(os.getloadavg()[0], 1)}}
