"""Baseline re-flights and the drift test on our simulator (its own process, loopback UDP, lockstep).

Static: a campaign of --budget N at the default cadence; counts the baseline re-flights against the budget.
Changing: a wind step (40 s of flight, seeded) at the default cadence; records where the test fired (or the
baseline could no longer fly), the exit code and the message. Writes one JSON line per run to stdout.

    PYTHONPATH=.dev-path python scripts/bench_drift_planar.py static 30
    PYTHONPATH=.dev-path python scripts/bench_drift_planar.py wind 30 --wind 0,0,20,0 --wind-step 40:1.0
    python scripts/bench_drift_planar.py static 30 --seed 1 --tune --seed 1 --baseline-every 0

Arguments after ``--tune`` go to ``ksbo-mav tune``. ``reflown_P``: the recommendation re-flown in process from
the 8 fixed starts (the planar task's re-flown score).
"""

from __future__ import annotations

import io
import json
import sys
import tempfile
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import sim_and_endpoint  # noqa: E402

from ksbo_mav.cli import main  # noqa: E402


def reflown_P(d: Path) -> float | None:
    """The recommendation's P re-flown in process from the 8 fixed starts (`ksbo-mav evaluate --fixed`)."""
    res = d / "result.json"
    if not res.exists():
        return None
    x = json.loads(res.read_text())["best"]["x"]
    out = io.StringIO()
    with redirect_stdout(out):
        main(["evaluate", "--gains", ",".join(repr(float(v)) for v in x), "--fixed", "--json"])
    return json.loads(out.getvalue())["P"]


def run(name: str, budget: int, sim_args: list[str], tune_args: list[str]) -> dict:
    d = Path(tempfile.mkdtemp()) / "camp"
    err = io.StringIO()
    t = time.time()
    with sim_and_endpoint(*sim_args) as (_sim, ep), redirect_stderr(err):
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--profile", "sim-planar", "--budget",
                   str(budget), *tune_args])
    entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
    text = " ".join(err.getvalue().split())
    drift = text[text.index("drift: "):].split(": check the vehicle")[0] if "drift: " in text else None
    return {"run": name, "budget": budget, "sim": sim_args, "rc": rc, "wall_s": round(time.time() - t, 1),
            "opt": sum(e["kind"] == "opt" for e in entries),
            "baseline_reflights": sum(e["kind"] == "baseline" for e in entries),
            "baseline_P": [round(e["P"], 3) for e in entries if e["kind"] == "baseline"],
            "first_P": round(entries[0]["P"], 3), "flights": len(entries), "drift": drift,
            "unsafe_opt": sum(e["kind"] == "opt" and e["P"] < 0 for e in entries), "tune": tune_args,
            "reflown_P": reflown_P(d)}


if __name__ == "__main__":
    name, budget, rest = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
    tune = rest[rest.index("--tune") + 1:] if "--tune" in rest else []
    sim = rest[:rest.index("--tune")] if "--tune" in rest else rest
    print(json.dumps(run(name, budget, sim, tune)), flush=True)
