"""The records of the last benchmark scripts (warm start, drift, the real-time campaigns, training against flown,
the onboard trial, the link campaign and rates, the MAVLink campaigns on our planar vehicle, the field logs),
converted once into their sweeps' stores; kept to say how each old field maps. Running it again rewrites those
stores' converted records from the old files (``git show`` them back from the commit before they were removed;
benchmarks/archive/log-scoring.md is still here).

A record whose measurement is a declared cell's gets that cell's key (so a run skips it); one of an earlier design
gets a label ``was-…`` (or the old label) and stays in the store as history. Old fields without a place in the
schema go into ``result`` under their old names; ``run`` says "converted", the old file and the date of the run.

    python -m ksbo_bench.convert_outputs
"""

from __future__ import annotations

import json
from typing import Any

from ksbo_bench.convert_legacy import BENCH, _lines, _rec, _write

RADIO = "down=4000,up=2000,queue=1024,loss=0.05,latency=0.02,seed=1,radio=1"
WARM_REF = {"sweep": "warm-start", "key": {"label": "earlier"}, "match": ["vehicle"]}


def warm_start() -> list[dict[str, Any]]:
    out = []
    for r in _lines("warm-start/runs.jsonl"):
        key: dict[str, Any] = {"label": r.get("label", "warm"), "vehicle": r["stack"], "seed": 0,
                               "tune_args": ["--budget", str(r["budget"])], "warm_start": WARM_REF,
                               "reference": WARM_REF, "candidates": 0}
        if r.get("wind_mps"):
            key["sitl_params"] = {"SIM_WIND_SPD": r["wind_mps"]}
        if r.get("drag", 1.0) != 1.0:
            key["sim_args"] = ["--drag", f"{r['drag']:g}"]
        ref = r.get("reflown") or {}
        result = {"rc": r["rc"], "rms_per_flight": r["rms_per_flight"], "warm_start": r["said"],
                  "reached_at": r.get("reached_at"), "earlier_was": r["earlier"] + " (the long campaign of that day)",
                  "reflown": {"baseline": ref.get("baseline"), "long": ref.get("earlier"), "rec": ref.get("warm")}}
        out.append(_rec("warm-start", "campaign", key, result, "benchmarks/warm-start/runs.jsonl", r["machine"],
                        flights={"total": r["flights"], "reflown": sum(len(v) for v in ref.values())},
                        safety={"crashed": None, "aborted": r["aborted"], "interrupted": None, "unsafe": r["unsafe"]},
                        timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]}))
    return out


def _status(rc: int) -> str:
    return {0: "ok", 3: "stopped"}.get(rc, "failed")


def drift() -> list[dict[str, Any]]:
    out = []
    for r in _lines("drift/copter-runs.jsonl"):
        rising = r["run"] != "static"
        key = {"label": r["run"], "vehicle": "copter3d", "seed": r["seed"],
               "tune_args": ["--budget", str(r["budget"])] + (["--on-drift", "continue"] if r["run"] == "continue"
                                                               else []),
               "sim_args": ["--seed", str(r["seed"])] + (["--drag", f"1,{r['rise_per_min']:g}"] if rising else []),
               "candidates": 0, "analyses": ["drift", "drift-copter"]}
        reflown = {"baseline": r["reflown_baseline"], "rec": r["reflown_best"]} if r.get("reflown_baseline") else {}
        result = {"rc": r["rc"], "drift": r["drift"], "baseline_rms": [(None, x) for x in r["baseline_rms"]],
                  **{k: r[k] for k in ("detectable_trial", "stopped_trial", "unsafe_told", "unsafe_for_drift",
                                       "final_drag", "cut")}, **({"reflown": reflown} if reflown else {})}
        out.append(_rec("drift", "campaign", key, result, "benchmarks/drift/copter-runs.jsonl", r["machine"],
                        status=_status(r["rc"]), timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]},
                        flights={"total": r["flights"], "opt": r["opt"], "baseline": r["baseline_reflights"],
                                 "reflown": 6 if reflown else 0},
                        safety={"crashed": None, "aborted": None, "interrupted": None, "unsafe": None}))
    for r in _lines("drift/sitl-runs.jsonl"):
        args = ["--budget", str(r["budget"])]
        key: dict[str, Any] = {"label": "continue" if r["wind_mps"] else "static", "vehicle": "ardupilot",
                               "seed": r["seed"]}
        if r["wind_mps"]:
            key.update(change_at=r["wind_at"],
                       change_params={"SIM_WIND_SPD": r["wind_mps"], "SIM_WIND_TURB": r["turb"]})
            args += ["--on-drift", r["on_drift"]]
        elif r.get("baseline_every") is not None:
            args += ["--baseline-every", str(r["baseline_every"])]
        key.update(tune_args=args, candidates=0, analyses=["drift"])
        result = {k: r[k] for k in ("rc", "drift", "last_line", "baseline_rms", "unsafe_told", "unsafe_flown",
                                    "wind_seen", "cut", "changed_params") if k in r}
        result.update(reflown={"baseline": r["reflown_baseline"], "rec": r["reflown_best"]}, best_values=r["best"],
                      changed=r.get("wind_set"))
        out.append(_rec("drift", "campaign", key, result, "benchmarks/drift/sitl-runs.jsonl", r["machine"],
                        status=_status(r["rc"]), timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]},
                        flights={"total": r["flights"], **r["kinds"], "reflown": 6},
                        safety={"crashed": None, "aborted": None, "interrupted": None, "unsafe": r["unsafe_flown"]}))
    for r in _lines("drift/planar-static-runs.jsonl"):
        seed, every = r["tune"][1], r["tune"][3]
        key = {"label": "static", "vehicle": "planar", "seed": int(seed),
               "tune_args": ["--budget", str(r["budget"]), "--baseline-every", every], "refly": 0,
               "analyses": ["drift", "planar"]}
        result = {"rc": r["rc"], "drift": r["drift"], "baseline_P": r["baseline_P"], "first_P": r["first_P"],
                  "unsafe_flown": r["unsafe_opt"], "reflown_P": r["reflown_P"]}
        out.append(_rec("drift", "campaign", key, result, "benchmarks/drift/planar-static-runs.jsonl",
                        "AMD EPYC, 2 cores, Python 3.11.7, numpy 2.4.6, 2026-12-04 04:23 UTC (the drift report's)",
                        status=_status(r["rc"]), timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]},
                        flights={"total": r["flights"], "opt": r["opt"], "baseline": r["baseline_reflights"]},
                        safety={"crashed": None, "aborted": None, "interrupted": None, "unsafe": r["unsafe_opt"]}))
    return out


#: The old records' sensor words -> (label, seed) of the declared cell, or an earlier design's label.
SENSORS = {"SITL defaults": ("defaults", 0), "raised: IMU, baro, GPS 200 ms lag (notes)": ("raised sensors", 0),
           "SITL defaults, wind 5 m/s (SIM_WIND_TURB 1)": ("wind 5", 0),
           "SIH built-in noise (notes)": ("was-sih, the earlier validation steps, resumed", 0),
           "SIH built-in noise (notes), 3 m validation steps": ("was-sih, before the body-axis tilt monitor", 0),
           "SIH built-in noise (notes), 3 m validation steps, seed 1": ("was-sih, before the body-axis tilt monitor",
                                                                       1)}


def _realtime_key(r: dict[str, Any]) -> dict[str, Any]:
    """The declared cell the record measured (the sweep file's key: its SITL settings), or an earlier design's."""
    from ksbo_bench import sweep as sweeps

    words = r["sensors"]
    if words in SENSORS:
        label, seed = SENSORS[words]
    else:  # "SIH built-in noise (notes), 3 m validation steps, body-axis tilt monitor[, trial step][, seed 1]"
        label, seed = ("sih, trial step" if "trial step" in words else "sih"), (1 if words.endswith("seed 1") else 0)
    cells = {(c.key["label"], c.key["vehicle"], c.key["seed"]): c.key for c in sweeps.load("realtime-campaign").cells()}
    if (label, r["stack"], seed) in cells:
        return dict(cells[(label, r["stack"], seed)])
    like = cells[("sih" if r["stack"] == "px4" else "defaults", r["stack"], 0)]
    return {**like, "label": label, "seed": seed}


def realtime() -> list[dict[str, Any]]:
    out = []
    for r in _lines("realtime-campaign/runs.jsonl"):
        drop = {"stack", "speedup", "machine", "at", "n_unsafe", "n_aborted", "n_crashed", "n_failed", "wall_s",
                "flights", "search_end", "n_trials"}
        result = {k: v for k, v in r.items() if k not in drop}
        result.update(search_end_text=r["search_end"], n_trials=r["n_trials"])
        out.append(_rec("realtime-campaign", "campaign", _realtime_key(r), result,
                        "benchmarks/realtime-campaign/runs.jsonl", r["machine"],
                        flights={"total": r["flights"], **r["flights_by_label"]},
                        safety={"crashed": r["n_crashed"], "aborted": r["n_aborted"], "interrupted": r["n_failed"],
                                "unsafe": r["n_unsafe"]}, timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]}))
    return out


def link_campaign() -> list[dict[str, Any]]:
    out = []
    for r in _lines("link-campaign/runs.jsonl"):
        key = {"speedup": 1.0, "link": r["shape"], "tune_args": ["--budget", str(r["budget"])], "refly": 0, "seed": 0,
               "vehicle": r["kind"]}
        result = {k: r[k] for k in ("rc", "params", "rate_hz", "link_lost", "changed_params", "outcomes", "error")
                  if k in r}
        result["link"] = r["emulator"]
        out.append(_rec("link-campaign", "campaign", key, result, "benchmarks/link-campaign/runs.jsonl", r["machine"],
                        status=_status(r["rc"]), flights={"total": r.get("flights")},
                        safety={k: r.get(k) for k in ("crashed", "aborted", "interrupted", "unsafe")},
                        timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"]}))
    return out


#: The MAVLink campaigns' files of today's design (the rest: earlier designs, labelled was-<file>).
CURRENT = ("tune-stress-ksbo-adaptive.json", "tune-move-ksbo.json", "tune-stress-ksbo.json")
MACHINE = "Intel(R) Xeon(R) Processor, 2 cores, Python 3.11.7, numpy 2.4.6, 2026-12-02 08:51 UTC (the results page's)"


def _tune_args(method: str) -> list[str]:
    name, *opts = method.split()
    args = ["--budget", "60", "--prior", "sim", "--method", name]
    for o in opts:  # the old label wrote Python's True; tune's --option takes JSON
        args += ["--option", o.replace("=True", "=true").replace("=False", "=false")]
    return args


def mavlink_campaign() -> list[dict[str, Any]]:
    out = []
    for p in sorted((BENCH / "mavlink-campaign").glob("tune-*.json")):
        for r in json.loads(p.read_text()):
            key: dict[str, Any] = {"vehicle": "planar", "refly": 0, "check_params": True,
                                   "analyses": ["planar", "planar-twin"], "tune_args": _tune_args(r["method"]),
                                   "seed": r["seed"]}
            if p.name not in CURRENT:
                key["label"] = f"was-{p.stem[5:]}"
            result = {"EP": r["E_best"], "EP_baseline": r["E_base"], "P_confirm": r["P_confirm"], "P_base": r["P_base"],
                      "orders": r["orders"], "unrestored_trials": r["unrestored"],
                      "twin": {"EP": r["E_inproc"], "unsafe": r["unsafe_inproc"], "aborted": r["aborted_inproc"],
                               "crashed": r["crashed_inproc"]}}
            out.append(_rec("mavlink-campaign", "campaign", key, result, f"benchmarks/mavlink-campaign/{p.name}",
                            MACHINE, flights={"total": r["trials"]},
                            safety={"crashed": r["crashed"], "aborted": r["aborted"], "interrupted": None,
                                    "unsafe": r["unsafe"]},
                            timing={"wall_s": r["wall_s"], "campaign_s": r["wall_s"],
                                    "s_per_flight": r["wall_per_trial"]}))
    return out


def main() -> None:
    from ksbo_bench import convert_flights

    for sweep, fn in (("warm-start", warm_start), ("drift", drift), ("realtime-campaign", realtime),
                      ("link-campaign", link_campaign), ("mavlink-campaign", mavlink_campaign),
                      ("training-vs-flown", convert_flights.training), ("onboard-trial", convert_flights.onboard),
                      ("link-rates", convert_flights.link_rates), ("log-field", convert_flights.log_field)):
        recs = fn()
        if recs:
            _write(sweep, recs)


if __name__ == "__main__":
    main()
