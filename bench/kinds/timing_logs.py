"""The ``score-big-log`` timing: throughput and peak memory of `ksbo-mav score` on a ~``size_mb`` MB ArduPilot
DataFlash log, against pymavlink's DFReader reading the same messages.

The big log is real: one ArduCopter SITL flight (boot, GUIDED take-off, two figure-8 laps, LAND; flown by the
plain pymavlink client ksbo_sim.sitl_flight) whose message stream is repeated with its TimeUS shifted so that the
copies follow each other in time — a long log with one GUIDED figure-8 segment per copy. It lives in a temporary
folder and is deleted afterwards. Each reader runs in its own process; peak memory is that process's maximum
resident set size (wait4). A one-log score is timed too (interpreter, imports and one SITL log), so the big file's
own cost can be told apart.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from ksbo_bench.cell_errors import InfraError

DFREADER = """
import sys, time
from pymavlink import DFReader
r = DFReader.DFReader_binary(sys.argv[1])
n = 0
while r.recv_match(type=["PSCN", "PSCE", "PSCD", "GUIP", "MODE"]) is not None:
    n += 1
print(n)
"""


def fly_source(tmp: Path) -> Path:
    from ksbo_sim.sitl_flight import fly_figure8
    from ksbo_sim.sitl_instances import start_claimed

    try:
        sitl = start_claimed("ardupilot", 10, workdir=tmp / "sitl")
    except (RuntimeError, OSError, TimeoutError) as e:
        raise InfraError(f"ardupilot SITL did not boot: {str(e)[:300]}") from e
    try:
        fly_figure8("ardupilot", sitl.device, tlog=tmp / "client.tlog")
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:  # wait for the logger to write the disarm
            logs = sitl.logs(".BIN")
            if logs and b"Disarming" in logs[-1].read_bytes():
                break
            time.sleep(0.5)
    finally:
        sitl.stop()
    return sitl.logs(".BIN")[-1]


def build_big(src: Path, dst: Path, size_mb: float) -> tuple[int, int]:
    """Repeat ``src``'s complete messages with TimeUS shifted until ``dst`` reaches ``size_mb``: (copies, bytes)."""
    from ksbo_mav.flightlog.dataflash import FMT_TYPE, read_dataflash

    c = read_dataflash(src, set())
    data = np.frombuffer(src.read_bytes()[: c.end], dtype=np.uint8)
    lengths = {f.type: f.length for f in c.formats.values()}
    timed = {f.type for f in c.formats.values() if f.columns[:1] == ["TimeUS"] and f.format[:1] == "Q"}
    pos, starts, raw = 0, [], data.tobytes()
    while pos < len(raw):
        typ = raw[pos + 2]
        if typ in timed:
            starts.append(pos + 3)
        pos += lengths[typ] if typ != FMT_TYPE else 89
    idx = np.array(starts)[:, None] + np.arange(8)
    stamps = data[idx].copy().view("<u8").ravel()
    span = int(stamps.max() - stamps.min()) + 1_000_000
    copies = int(np.ceil(size_mb * 1e6 / len(raw)))
    buf = data.copy()
    with open(dst, "wb") as fh:
        for k in range(copies):
            buf[idx] = (stamps + k * span).view(np.uint8).reshape(-1, 8)
            fh.write(buf.tobytes())
    return copies, copies * len(raw)


def run_child(argv: list[str], timeout: float) -> tuple[float, float, str]:
    """(wall s, peak RSS MB of that child alone (wait4), stdout)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t = time.perf_counter()
        proc = subprocess.Popen(argv, stdout=out, stderr=err)
        deadline = time.monotonic() + timeout
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() > deadline:
                proc.kill()
                raise subprocess.TimeoutExpired(argv, timeout)
            time.sleep(0.05)
        wall = time.perf_counter() - t
        out.seek(0)
        err.seek(0)
        if os.waitstatus_to_exitcode(status) != 0:
            raise RuntimeError(f"{argv[:4]} failed: {err.read()[-500:]}")
        return wall, usage.ru_maxrss / 1024.0, out.read()


def score_big_log(key: dict[str, Any]) -> dict[str, Any]:
    py = sys.executable
    with tempfile.TemporaryDirectory(prefix="ksbo-bench-logs-") as d:
        tmp = Path(d)
        src = fly_source(tmp)
        big = tmp / "big.BIN"
        copies, size = build_big(src, big, float(key.get("size_mb", 500)))
        w1, rss1, _ = run_child([py, "-m", "ksbo_mav.cli", "score", str(src), "--json"], 600)
        wall, rss, out = run_child([py, "-m", "ksbo_mav.cli", "score", str(big), "--json"], 1800)
        segs = json.loads(out)["segments"]
        rms = [s["figure8"]["score"]["rms_lap2_m"] for s in segs if s["figure8"]]
        w2, rss2, out2 = run_child([py, "-c", DFREADER, str(big)], 1800)
        src_mb = src.stat().st_size / 1e6
    return {"result": {"source_mb": round(src_mb, 1), "copies": copies, "mb": round(size / 1e6), "segments": len(segs),
                       "figure8s": len(rms), "rms_lap2_min": min(rms), "rms_lap2_max": max(rms),
                       "dfreader_messages": int(out2.split()[0])},
            "timing": {"seconds": wall, "mb_per_s": size / 1e6 / wall, "peak_rss_mb": rss, "one_log_s": w1,
                       "one_log_rss_mb": rss1, "dfreader_s": w2, "dfreader_rss_mb": rss2}}
