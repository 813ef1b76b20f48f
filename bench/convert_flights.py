"""The flights sweeps' old records (training against flown, the onboard trial, the link rates) and the field
logs' table, converted into their stores (called by ksbo_bench.convert_outputs, which says how)."""

from __future__ import annotations

import re
from typing import Any

from ksbo_bench.convert_legacy import BENCH, _lines, _rec

NAMES = ("PSC_POSXY_P", "PSC_VELXY_P", "PSC_VELXY_I", "PSC_VELXY_D", "PSC_POSZ_P", "PSC_VELZ_P")


def _safety(rows: list[dict[str, Any]]) -> dict[str, int]:
    o = [r.get("outcome") for r in rows]
    return {"crashed": o.count("crash"), "aborted": sum(x in ("fence", "tilt", "track") for x in o),
            "interrupted": sum(x == "stopped" or bool(r.get("error")) for x, r in zip(o, rows)), "unsafe": 0}


def training() -> list[dict[str, Any]]:
    out = []
    for r in _lines("training-vs-flown/runs.jsonl"):
        base = dict(zip(NAMES, r["baseline"]))
        tuned = {n: v for n, v in zip(NAMES, r["tuned"]) if v != base[n]}
        ways = list(dict.fromkeys(x["source"] for x in r["rows"]))
        key: dict[str, Any] = {"vehicle": "ardupilot", "gains": {"tuned": tuned}, "speedup": r["speedup"],
                               "reps": r["reps"], "ways": ways}
        if r["sitl_set"]:
            key["sitl_params"] = {k: float(v) for k, v in (s.split("=") for s in r["sitl_set"])}
        if r["reps"] < 2:
            key["label"] = "was-first-look"
        rows = []
        for x in r["rows"]:
            row = {("way" if k == "source" else "rms" if k == "tool_rms" else k): v for k, v in x.items()}
            if row["way"].startswith("client") and "outcome" not in row:
                row["outcome"] = "client failed" if row.get("error") else "ok"
            rows.append(row)
        result = {"flights": rows, "baseline": base, "sets": {"baseline": base, "tuned": {**base, **tuned}},
                  "tuned_from": r["tuned_from"]}
        out.append(_rec("training-vs-flown", "flights", key, result, "benchmarks/training-vs-flown/runs.jsonl",
                        r["machine"], flights={"total": len(rows)}, safety=_safety(rows)))
    return out


def onboard() -> list[dict[str, Any]]:
    out = []
    for r in _lines("onboard-trial/runs.jsonl"):
        gains = {k: v for k, v in r["gain_sets"].items() if k != "baseline"}
        key: dict[str, Any] = {"vehicle": "ardupilot", "speedup": r["speedup"], "reps": r["reps"],
                               "ways": ["onboard", "streamed"], "gains": gains, "label": r["link"]}
        if r["link"] == "radio":
            key["link"] = r["shape"]
        rows = [{"rep": i, "set": name, "way": "streamed" if source == "ground" else source, **x}
                for name, by in r["flights"].items() for source, xs in by.items() for i, x in enumerate(xs)]
        result = {"flights": rows, "rate_hz": r["rate_hz"], "gain_sets": r["gain_sets"]}
        if r.get("emulator"):
            result["link"] = r["emulator"]
        if r.get("note"):
            result["note"] = r["note"]
        out.append(_rec("onboard-trial", "flights", key, result, "benchmarks/onboard-trial/runs.jsonl", r["machine"],
                        flights={"total": len(rows)}, safety=_safety(rows)))
    return out


def link_rates() -> list[dict[str, Any]]:
    """The two runs of results.md (no runs file was kept): its per-flight lap-2 RMS, by stack and rate."""
    p = BENCH / "link-rates" / "results.md"
    if not p.exists():
        return []
    out = []
    for part in p.read_text().split("Machine: ")[1:]:
        machine = part.split(". Script:")[0]
        speedup = re.search(r"--speedup (\S+)`?", part.split("\n")[0])
        rows: dict[str, list[dict[str, Any]]] = {}
        rates: dict[str, list[int]] = {}
        for m in re.finditer(r"^\| (ardupilot|px4) \| (\d+) \| ([\d., ]+) \|.*\| (\w+) \|$", part, re.M):
            stack, rate, vals, outcome = m.group(1), int(m.group(2)), m.group(3), m.group(4)
            rates.setdefault(stack, []).append(rate)
            rows.setdefault(stack, []).extend({"rep": i, "set": "baseline", "way": f"streamed@{rate}", "rms": float(v),
                                               "outcome": outcome} for i, v in enumerate(vals.split(", ")))
        for stack, rs in rows.items():
            key: dict[str, Any] = {"reps": 3, "vehicle": stack, "ways": [f"streamed@{x}" for x in rates[stack]]}
            if speedup:
                key["speedup"] = float(speedup.group(1))
            out.append(_rec("link-rates", "flights", key, {"flights": rs}, "benchmarks/link-rates/results.md", machine,
                            flights={"total": len(rs)}, safety=_safety(rs)))
    return out


SOURCE = {"ArduCopter SITL, client": "ardupilot", "ArduCopter SITL, onboard": "ardupilot",
          "ArduCopter SITL via MAVProxy": "ardupilot-mavproxy", "PX4 SITL": "px4", "our simulator": "sim"}


def log_field() -> list[dict[str, Any]]:
    """The field-log table of the scripts' last log-scoring output (now benchmarks/archive/log-scoring.md)."""
    p = BENCH / "archive" / "log-scoring.md"
    if not p.exists():
        return []
    text = p.read_text()
    machine = text.split("Machine: ")[1].split(". Script:")[0]
    by: dict[str, tuple[list, list]] = {}
    for m in re.finditer(r"^\| ([^|]+) \| (intact|cut in half|64 B inserted|first kB cut|empty) \| ([\d.]+) \| "
                         r"([\d.]+) \| (.+) \|$", text, re.M):
        log, variant, mb, secs, outcome = m.groups()
        source = next(v for k, v in SOURCE.items() if log.startswith(k))
        outcome = re.sub(r"/tmp/\S+?\.(tlog|BIN|ulg)", "FILE", outcome)
        rows, times = by.setdefault(source, ([], []))
        rows.append({"log": log, "variant": variant, "mb": float(mb), "outcome": outcome})
        times.append(float(secs))
    return [_rec("log-field", "evaluation", {"what": "log-field", "source": s}, {"rows": rows, "tracebacks": sum(
        r["outcome"] == "TRACEBACK" for r in rows)}, "benchmarks/log-scoring/results.md", machine,
        timing={"score_s": times}) for s, (rows, times) in by.items()]
