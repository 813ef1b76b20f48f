"""Benchmark of flight-log scoring: throughput and peak memory of `ksbo-mav score` on a ~500 MB
ArduPilot DataFlash log, against pymavlink's DFReader reading the same messages.

The big log is real: one ArduCopter SITL flight (boot, GUIDED take-off, two figure-8 laps, LAND; flown by the plain
pymavlink client ksbo_sim.sitl_flight) whose message stream is repeated with its TimeUS shifted so the copies follow
each other in time — a long log with one GUIDED figure-8 segment per copy. It is written to a temporary directory
and deleted afterwards (never committed). Each reader runs in its own process; peak memory is that process's
maximum resident set size (getrusage RUSAGE_CHILDREN, read right after it exits).

    python scripts/bench_log_scoring.py [--size-mb 500] [--bin SOURCE.BIN] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _bench_common import machine, write_result  # noqa: E402

DFREADER_SNIPPET = """
import sys, time
from pymavlink import DFReader
t = time.time()
r = DFReader.DFReader_binary(sys.argv[1])
n = 0
while True:
    m = r.recv_match(type=["PSCN", "PSCE", "PSCD", "GUIP", "MODE"])
    if m is None:
        break
    n += 1
print(n, time.time() - t)
"""


def fly_source(tmp: Path) -> Path:
    from ksbo_sim.sitl import start_sitl
    from ksbo_sim.sitl_flight import fly_figure8

    sitl = start_sitl("ardupilot", instance=6, speedup=10, workdir=tmp / "sitl")
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
    """Repeat ``src``'s complete messages with TimeUS shifted until ``dst`` reaches ``size_mb``. Returns (copies,
    bytes)."""
    from ksbo_mav.flightlog.dataflash import FMT_TYPE, read_dataflash

    c = read_dataflash(src, set())
    data = np.frombuffer(src.read_bytes()[: c.end], dtype=np.uint8)
    # offsets of every message and of its TimeUS field (formats whose first column is TimeUS, type Q)
    lengths = {f.type: f.length for f in c.formats.values()}
    timed = {f.type for f in c.formats.values() if f.columns[:1] == ["TimeUS"] and f.format[:1] == "Q"}
    pos, starts = 0, []
    raw = data.tobytes()
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
        proc.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        if proc.returncode != 0:
            raise RuntimeError(f"{argv} failed: {err.read()[-2000:]}")
        return wall, usage.ru_maxrss / 1024.0, out.read()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size-mb", type=float, default=500.0)
    ap.add_argument("--bin", type=Path, default=None, help="source .BIN (default: fly one on ArduCopter SITL)")
    ap.add_argument("--no-dfreader", action="store_true", help="skip the pymavlink DFReader comparison")
    ap.add_argument("--no-write", action="store_true",
                    help="print only, do not write benchmarks/log-scoring/results.md")
    args = ap.parse_args()
    load0 = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="ksbo-bench-logs-") as d:
        tmp = Path(d)
        src = args.bin or fly_source(tmp)
        src_mb = src.stat().st_size / 1e6
        big = tmp / "big.BIN"
        t = time.perf_counter()
        copies, size = build_big(src, big, args.size_mb)
        print(f"built {big} ({size / 1e6:.0f} MB, {copies} copies of {src.stat().st_size / 1e6:.1f} MB) in "
              f"{time.perf_counter() - t:.1f} s", flush=True)
        py = sys.executable
        # Small-file baseline: interpreter + imports + one SITL log (so the big file's cost can be told apart).
        w_small, rss_small, _ = run_child([py, "-m", "ksbo_mav.cli", "score", str(src), "--json"], 600)
        wall, rss, out = run_child([py, "-m", "ksbo_mav.cli", "score", str(big), "--json"], 1800)
        res = json.loads(out)
        segs = res["segments"]
        f8 = [s for s in segs if s["figure8"]]
        rms = [s["figure8"]["score"]["rms_lap2_m"] for s in f8]
        print(f"ksbo-mav score: {wall:.1f} s, {size / 1e6 / wall:.1f} MB/s, peak RSS {rss:.0f} MB; "
              f"{len(segs)} segments, {len(f8)} figure-8s, lap-2 RMS {min(rms):.4f}..{max(rms):.4f} m", flush=True)
        rows = [("`ksbo-mav score`, one SITL log", src_mb, w_small, rss_small, ""),
                (f"`ksbo-mav score`, {copies} copies", size / 1e6, wall, rss,
                 f"{len(segs)} segments, {len(f8)} figure-8s scored")]
        if not args.no_dfreader:
            try:
                w2, rss2, out2 = run_child([py, "-c", DFREADER_SNIPPET, str(big)], 1800)
                rows.append(("pymavlink `DFReader_binary` + `recv_match(type=[PSC*, GUIP, MODE])` (reading only)",
                             size / 1e6, w2, rss2, f"{out2.split()[0]} messages"))
                print(f"DFReader: {w2:.1f} s, peak RSS {rss2:.0f} MB", flush=True)
            except (RuntimeError, subprocess.TimeoutExpired) as exc:
                rows.append(("pymavlink DFReader", size / 1e6, float("nan"), float("nan"), f"failed: {exc}"[:80]))
    table = ["| reader | file (MB) | wall (s) | MB/s | peak RSS (MB) | notes |", "|---|---|---|---|---|---|"]
    for name, mb, w, r, note in rows:
        table.append(f"| {name} | {mb:.0f} | {w:.1f} | {mb / w:.0f} | {r:.0f} | {note} |")
    body = f"""Machine: {machine()}. Script: `python scripts/bench_log_scoring.py --size-mb {args.size_mb:g}`.

Input: one ArduCopter SITL flight (`ksbo_sim.sitl_flight`, 10x: GUIDED take-off, two figure-8 laps, LAND;
{src_mb:.1f} MB of default logging) repeated {copies} times with TimeUS shifted: {size / 1e6:.0f} MB in /tmp, deleted
afterwards. Each reader runs in its own process; peak RSS = that process's maximum resident set size. The 2 cores
were shared with other work (1-min load average {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end): wall
times are upper bounds.

{chr(10).join(table)}

`ksbo-mav score` walks the DataFlash message chain once, 8 MB at a time, and keeps only the bodies of
PSCN/PSCE/PSCD, GUIP, MODE, MSG, PARM and ARM, decoded at the end with numpy. Its memory is the interpreter and
libraries (the one-log row) plus the kept messages, which grow with the flight time logged, not with the file
size. Every copy's figure-8 is recognised and scored (lap-2 RMS {min(rms):.4f}..{max(rms):.4f} m: identical copies,
identical scores). pymavlink's DFReader mmaps the file (its pages count in its RSS once touched) and indexes the
offset of every message before returning the first one; it only reads, it does not score.
"""
    print(body)
    if not args.no_write:
        write_result("log-scoring", body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
