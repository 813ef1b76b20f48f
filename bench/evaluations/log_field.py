"""Evaluation ``log-field``: `ksbo-mav score` on a log from one ``source``, recorded here, intact and damaged
here (cut in half, 64 bytes inserted in the middle, the first kilobyte cut, empty). Sources, each one figure-8
(two laps) flown by the plain pymavlink client ksbo_sim.sitl_flight unless said otherwise: ``ardupilot`` (the
client's own tlog and the onboard .BIN), ``ardupilot-mavproxy`` (the tlog MAVProxy records with its default
stream rates; the client asks for no POSITION_TARGET_LOCAL_NED, so the targets are the POSITION_TARGET_GLOBAL_INT
ArduPilot streams), ``px4`` (the .ulg and the client's tlog), ``sim`` (a trial tlog of `ksbo-mav demo` on our
simulator). Each score runs in its own process (`ksbo-mav score FILE --json`, then with `--partial` when refused);
its time is that process's wall time (interpreter start included). No log is kept."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from ksbo_bench.cell_errors import InfraError, SweepError

VARIANTS = ("intact", "cut in half", "64 B inserted", "first kB cut", "empty")
SOURCES = ("ardupilot", "ardupilot-mavproxy", "px4", "sim")


def check(key: dict[str, Any]) -> None:
    if key.get("source") not in SOURCES:
        raise SweepError(f"log-field: source must be one of {', '.join(SOURCES)}")


def resources(key: dict[str, Any]) -> dict[str, float]:
    return {} if key.get("source") == "sim" else {"sitl": 1}


def damaged(src: Path, variant: str, out: Path) -> Path:
    data = src.read_bytes()
    mid = len(data) // 2
    noise = bytes((i * 37 + 11) % 256 for i in range(64))  # fixed bytes: the same damage every run
    out.write_bytes({"intact": data, "cut in half": data[:mid], "first kB cut": data[1024:], "empty": b"",
                     "64 B inserted": data[:mid] + noise + data[mid:]}[variant])
    return out


def _wait_log(sitl, ext: str, text: bytes | None, timeout: float = 30) -> Path:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        logs = sitl.logs(ext)
        if logs and (text is None or text in logs[-1].read_bytes()):
            return logs[-1]
        time.sleep(0.5)
    return sitl.logs(ext)[-1]


def record(source: str, tmp: Path) -> dict[str, Path]:
    """{label: log file} of ``source``, flown here."""
    if source == "sim":
        d = tmp / "demo"
        subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "demo", "--budget", "3", "--dir", str(d)], check=True,
                       capture_output=True, timeout=600)
        tlogs = sorted(d.rglob("trial_*.tlog"))
        return {"our simulator, trial (tlog)": tlogs[0]} if tlogs else {}
    from ksbo_sim.process import free_udp_port
    from ksbo_sim.sitl_flight import fly_figure8
    from ksbo_sim.sitl_instances import start_claimed

    kind = "px4" if source == "px4" else "ardupilot"
    try:
        sitl = start_claimed(kind, 5, workdir=tmp / "sitl")
    except (RuntimeError, OSError, TimeoutError) as e:
        raise InfraError(f"{kind} SITL did not boot: {str(e)[:300]}") from e
    try:
        if source == "px4":
            fly_figure8("px4", sitl.device, tlog=tmp / "px4-client.tlog")
            time.sleep(5)
            return {"PX4 SITL, client (tlog)": tmp / "px4-client.tlog", "PX4 SITL, onboard (.ulg)":
                    _wait_log(sitl, ".ulg", None)}
        if source == "ardupilot":
            fly_figure8("ardupilot", sitl.device, tlog=tmp / "ap-client.tlog")
            return {"ArduCopter SITL, client (tlog)": tmp / "ap-client.tlog",
                    "ArduCopter SITL, onboard (.BIN)": _wait_log(sitl, ".BIN", b"Disarming")}
        mp_log, port = tmp / "mavproxy.tlog", free_udp_port()
        mp = subprocess.Popen(["mavproxy.py", f"--master=tcp:127.0.0.1:{sitl.tcp_port}", f"--out=udp:127.0.0.1:{port}",
                               f"--logfile={mp_log}", "--daemon", "--non-interactive"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, cwd=tmp, start_new_session=True)
        try:
            time.sleep(8)
            fly_figure8("ardupilot", f"udpin:127.0.0.1:{port}", stream_target=False)
            time.sleep(3)
        finally:
            os.killpg(mp.pid, signal.SIGTERM)
            mp.wait(20)
        return {"ArduCopter SITL via MAVProxy (tlog)": mp_log}
    finally:
        sitl.stop()


def _outcome(res: dict) -> str:
    if "score" in res and "trial" in res:  # our own trial tlog: the exact live score
        return f"trial re-scored, P {res['score']['P']:.3f}"
    segs = res["segments"]
    sc = [s["figure8"]["score"].get("rms_lap2_m") for s in segs if s.get("figure8")]
    sc = [x for x in sc if x is not None]
    parts = [f"{len(segs)} seg"]
    if sc:
        parts.append(f"lap-2 RMS {sc[0]:.3f} m")
    elif segs:
        parts.append(f"h RMS {segs[0]['vs_target']['h_rms_m']:.3f} m")
    if res.get("damaged_spans"):
        spans = res["damaged_spans"]
        parts.append(f"{len(spans)} span(s) skipped ({sum(s['nbytes'] for s in spans)} B)")
    if res.get("skipped_segments"):
        parts.append(f"{len(res['skipped_segments'])} seg skipped")
    return ", ".join(parts)


def score(path: Path) -> tuple[float, str]:
    """(wall s, outcome) of `ksbo-mav score`; a refused log is tried again with --partial."""
    cmd = [sys.executable, "-m", "ksbo_mav.cli", "score", str(path), "--json"]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    wall = time.perf_counter() - t
    if r.returncode == 0:
        return wall, _outcome(json.loads(r.stdout))
    if "Traceback" in r.stderr:
        return wall, "TRACEBACK"
    first = r.stderr.strip().splitlines()[0][7:] if r.stderr.strip() else f"exit {r.returncode}"
    t = time.perf_counter()
    r2 = subprocess.run(cmd + ["--partial"], capture_output=True, text=True, timeout=600)
    wall += time.perf_counter() - t
    if r2.returncode == 0:
        return wall, "refused; --partial: " + _outcome(json.loads(r2.stdout))
    text = first.split(": ", 1)[1] if first.startswith("/") and ": " in first else first
    return wall, "error: " + text.replace(str(path), "FILE")[:110]


def run(key: dict[str, Any]) -> dict[str, Any]:
    rows, seconds = [], []
    with tempfile.TemporaryDirectory(prefix="ksbo-bench-field-") as d:
        tmp = Path(d)
        for label, path in record(key["source"], tmp).items():
            for v in VARIANTS:
                f = damaged(path, v, tmp / f"v{VARIANTS.index(v)}-{path.name}")
                wall, outcome = score(f)
                rows.append({"log": label, "variant": v, "mb": round(f.stat().st_size / 1e6, 2), "outcome": outcome})
                seconds.append(round(wall, 2))
    return {"rows": rows, "tracebacks": sum(r["outcome"] == "TRACEBACK" for r in rows),
            "timing": {"score_s": seconds}}  # times differ run to run: the record's timing


def report(recs: list[dict[str, Any]]) -> str:
    out = ["| source (format) | variant | MB | time to score (s) | outcome |", "|---|---|---|---|---|"]
    for r in recs:
        secs = r.get("timing", {}).get("score_s") or [None] * len(r["result"]["rows"])
        out += [f"| {x['log']} | {x['variant']} | {x['mb']:.2f} | {'–' if s is None else f'{s:.2f}'} | "
                f"{x['outcome']} |" for x, s in zip(r["result"]["rows"], secs)]
    return "\n".join(out)
