"""Benchmark: a default ArduCopter SITL campaign through a radio the vehicle overfills, and its cut re-flown by an
independent client.

One run: ArduCopter SITL at real time (a link's bandwidth is wall-clock bytes per second) whose SERIAL0 stream
rates a ground station left at ``--gcs-rate`` Hz for every group (REQUEST_DATA_STREAM, which ArduPilot stores in
its MAV1_* parameters, before the campaign; the SITL's own defaults are 0 and it then sends 0.14 kB/s by itself),
our link emulator on that port shaped as a SiK-class radio without RADIO_STATUS (``--shape``, default the ``sik``
case of ``ksbo_sim.linkshape``), ``ksbo-mav tune DIR --udp ... --end hold`` with every other setting at its default, a
bench pilot that centres the SITL's sticks while the vehicle is airborne (its simulated transmitter rests with the
throttle low, which the LOITER hold of the validation refuses; throttle low again on the ground). Then, over the
SITL's spare TCP ports (not the radio): every parameter read back and compared with the campaign's snapshot; the
baseline and the recommendation flown in turn (``--reps`` each) by ``scripts/figure8_client.py``, a pymavlink
client that shares nothing with the tuner, scored the same way (lap-2 3-D RMS at each sample's stamp):
``python -m ksbo_bench.figure8_client``.

Reported: the console's link lines (the quieting), flights, validation flights, aborted / interrupted trials, the
cut the campaign said (its confirmation flights against its baseline flights) against the cut re-flown, and the
parameters left changed. One JSON line per run in ``benchmarks/overfilled-radio/runs.jsonl``; ``--report`` writes
``results.md`` from them. A diagnostic beside the ``ksbo-bench`` sweeps: its cell (a campaign through the link
emulator with a ground station's stream rates left on the port, a bench pilot, and a re-fly by a separate client
over the SITL's spare port, not the radio) is not one the campaign kind declares yet.

    python scripts/diag/overfilled_radio.py [--shape sik] [--reps 3] [-- TUNE-ARGS]
    python scripts/diag/overfilled_radio.py --report
"""

from __future__ import annotations

import argparse
import json
import os
import re
import socket
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from ksbo_bench.kinds.independent_refly import changed_params  # noqa: E402
from ksbo_bench.record import machine  # noqa: E402
from ksbo_mav.mav.link import Endpoint  # noqa: E402
from ksbo_sim.linkproc import LinkEmulator  # noqa: E402
from ksbo_sim.process import free_udp_port  # noqa: E402
from ksbo_sim.sitl_instances import start_claimed  # noqa: E402

OUT = Path(__file__).resolve().parents[2] / "benchmarks" / "overfilled-radio"
RUNS = OUT / "runs.jsonl"


class BenchPilot:
    """The SITL's simulated transmitter: sticks centred while the vehicle is armed and above 1.5 m, throttle low
    otherwise (RC input packets to UDP 5501+10N twice a second; the state read on the SITL's third TCP port)."""

    def __init__(self, sitl) -> None:
        self.addr = ("127.0.0.1", 5501 + 10 * sitl.instance)
        self.conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{sitl.tcp_ports[2]}", source_system=247,
                                               source_component=190, autoreconnect=False)
        self.stop_flag = False
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        armed, up = False, 0.0
        asked = 0.0
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            while not self.stop_flag:
                if time.monotonic() - asked > 5.0:  # this port's own stream, in case nobody asked for it
                    self.conn.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                                    mavutil.mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 500_000,
                                                    0, 0, 0, 0, 0)
                    asked = time.monotonic()
                end = time.monotonic() + 0.5
                while time.monotonic() < end:
                    m = self.conn.recv_match(type=["HEARTBEAT", "GLOBAL_POSITION_INT"], blocking=True, timeout=0.1)
                    if m is None or m.get_srcSystem() != 1:
                        continue
                    if m.get_type() == "HEARTBEAT" and m.autopilot != mavutil.mavlink.MAV_AUTOPILOT_INVALID:
                        armed = bool(m.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
                    elif m.get_type() == "GLOBAL_POSITION_INT":
                        up = m.relative_alt / 1000.0
                throttle = 1500 if armed and up > 1.5 else 1000
                s.sendto(struct.pack("<16H", 1500, 1500, throttle, 1500, *([0] * 12)), self.addr)

    def close(self) -> None:
        self.stop_flag = True
        self.thread.join(5)
        self.conn.close()


def gcs_stream_rates(sitl, hz: int) -> None:
    """What a ground station did on SERIAL0 before the campaign: every stream group at ``hz`` (ArduPilot stores the
    rates in its MAV1_* parameters, so the tuner's snapshot holds them)."""
    c = mavutil.mavlink_connection(f"tcp:127.0.0.1:{sitl.tcp_port}", source_system=255, source_component=190,
                                   autoreconnect=False)
    try:
        c.wait_heartbeat(timeout=30)
        for _ in range(3):
            c.mav.request_data_stream_send(sitl.sysid, 1, mavutil.mavlink.MAV_DATA_STREAM_ALL, hz, 1)
            time.sleep(0.3)
    finally:
        c.close()


def set_gains(port: int, values: dict[str, float]) -> None:
    """Write parameters over the SITL's TCP port ``port`` (pymavlink only), each confirmed by its echo."""
    c = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=246, source_component=190,
                                   autoreconnect=False)
    try:
        c.wait_heartbeat(timeout=30)
        for name, value in values.items():
            for _ in range(10):
                c.mav.param_set_send(1, 1, name.encode(), float(value), mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
                m = c.recv_match(type="PARAM_VALUE", blocking=True, timeout=1.0,
                                 condition=f"PARAM_VALUE.param_id == '{name}'")
                if m is not None and abs(m.param_value - value) < 1e-5 * max(1.0, abs(value)):
                    break
            else:
                raise RuntimeError(f"{name} = {value} not confirmed")
    finally:
        c.close()


def fly_client(port: int, mission) -> float:
    """One figure-8 by the independent client on TCP ``port``: its lap-2 RMS (m)."""
    cmd = [sys.executable, "-m", "ksbo_bench.figure8_client", "--tcp", f"127.0.0.1:{port}", "--scale",
           str(mission.scale), "--scale-east", str(mission.scale2), "--period", str(mission.period), "--up",
           str(mission.center_up), "--laps", str(mission.laps), "--lead-in", str(mission.lead_in)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    if r.returncode != 0:
        raise RuntimeError(f"figure8_client: {(r.stderr.strip().splitlines() or ['?'])[-1]}")
    return float(json.loads(r.stdout.strip().splitlines()[-1])["rms_lap2_m"])


def said_cut(d: Path) -> tuple[float | None, list[float], list[float]]:
    """The campaign's own before/after: its baseline flights against its confirmation flights (lap RMS)."""
    entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
    opt = [e for e in entries if e["kind"] == "opt"]
    base = [e["rms"] for e in ([opt[0]] if opt else []) + [e for e in entries if e["kind"] == "baseline"]
            if e["outcome"] == "ok" and e.get("rms")]
    conf = [e["rms"] for e in entries if e["kind"] == "confirm" and e["outcome"] == "ok" and e.get("rms")]
    cut = 1 - statistics.mean(conf) / statistics.mean(base) if base and conf else None
    return cut, base, conf


def land(port: int) -> None:
    c = mavutil.mavlink_connection(f"tcp:127.0.0.1:{port}", source_system=246, source_component=190,
                                   autoreconnect=False)
    try:
        c.wait_heartbeat(timeout=30)
        c.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 9, 0, 0, 0, 0, 0)
    finally:
        c.close()


def run(a: argparse.Namespace) -> dict:
    from ksbo_mav.mav.mission import Mission
    from ksbo_mav.mav.params import load_snapshot
    from ksbo_mav.profiles import load_profile

    work = Path(tempfile.mkdtemp(prefix="bench-overfilled-"))
    d = work / "campaign"
    rec: dict = {"shape": a.shape, "gcs_rate": a.gcs_rate, "tune_args": a.tune, "reps": a.reps, "dir": str(d),
                 "load_start": os.getloadavg()[1]}
    sitl = start_claimed("ardupilot", 1.0, workdir=work / "sitl")
    pilot = None
    try:
        if a.gcs_rate:
            gcs_stream_rates(sitl, a.gcs_rate)
        gport = free_udp_port()
        emu = LinkEmulator(f"tcp:127.0.0.1:{sitl.tcp_port}", f"udp:127.0.0.1:{gport}", a.shape, startup_timeout=60)
        rec["emulator_ready"] = emu.ready_line
        pilot = BenchPilot(sitl)
        t0 = time.time()
        try:
            r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), "--udp", f"127.0.0.1:{gport}",
                                "--end", "hold", "--json", *a.tune], capture_output=True, text=True, timeout=14400,
                               env={**os.environ, "COLUMNS": "1000"})  # the console's lines unwrapped
        finally:
            rec["emulator"] = emu.stop()
        rec.update(rc=r.returncode, wall_s=round(time.time() - t0, 1))
        (work / "tune.log").write_text(r.stderr)
        said = " ".join(r.stderr.split())
        rec["link_lines"] = [ln.strip() for ln in r.stderr.splitlines() if ln.strip().startswith(("link", "commands"))]
        rec["params_line"] = next((m.group(0) for m in [re.search(r"parameters: \d+ of \d+ downloaded[^\n]*",
                                                                  r.stderr)] if m), None)
        if r.returncode != 0:
            rec["error"] = (r.stderr.strip().splitlines() or ["?"])[-1][:300]
        else:
            s = json.loads(r.stdout[r.stdout.index("{"):])
            entries = [json.loads(x) for x in (d / "journal.jsonl").read_text().splitlines() if x.strip()]
            val = d / "validation.jsonl"
            rec.update(flights=len(entries), aborted=s["n_aborted"], crashed=s["n_crashed"], unsafe=s["n_unsafe"],
                       interrupted=s["n_failed"], link_lost=said.count("link lost"),
                       validation_flights=len(val.read_text().splitlines()) if val.exists() else 0)
        if (d / "campaign.json").exists():
            rec["changed_params"] = changed_params(Endpoint("tcp", "127.0.0.1", sitl.tcp_port), "ardupilot", d)
        if r.returncode == 0 and a.reps:
            cut, base_rms, conf_rms = said_cut(d)
            rec.update(said_cut=cut, said_baseline_rms=base_rms, said_confirm_rms=conf_rms)
            base = load_snapshot(d).baseline()
            best = json.loads((d / "result.json").read_text())["best"]["values"]
            mission = Mission.from_profile(load_profile(load_snapshot(d).profile))
            flown: dict[str, list[float]] = {"baseline": [], "recommendation": []}
            for rep in range(a.reps):
                order = ("baseline", "recommendation") if rep % 2 == 0 else ("recommendation", "baseline")
                for label in order:
                    set_gains(sitl.tcp_ports[1], base if label == "baseline" else best)
                    flown[label].append(fly_client(sitl.tcp_ports[1], mission))
                    print(f"re-flown {label}: {flown[label][-1]:.3f} m", file=sys.stderr, flush=True)
            set_gains(sitl.tcp_ports[1], base)
            rec["reflown"] = flown
            rec["reflown_cut"] = 1 - statistics.mean(flown["recommendation"]) / statistics.mean(flown["baseline"])
            land(sitl.tcp_ports[1])
    finally:
        if pilot is not None:
            pilot.close()
        sitl.stop()
    rec["load_end"] = os.getloadavg()[1]  # 5-minute load average: the machine is shared
    rec["machine"] = f"{machine()}, {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}"  # as the earlier runs
    rec["at"] = time.strftime("%Y-%m-%d %H:%M", time.gmtime())
    return rec


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{-100 * x:+.0f} %"


def report(write: bool) -> str:
    runs = [json.loads(ln) for ln in RUNS.read_text().splitlines() if ln.strip()] if RUNS.exists() else []
    rows = ["| run (UTC) | shape | port's stream rates | exit | flights (+ validation) | aborted | interrupted "
            "| 'link lost' | cut said | cut re-flown (client, 3 + 3) | params left changed | campaign wall (s) |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in runs:
        err = f" {r['error']}" if "error" in r else ""
        rate = re.search(r"down ([\d.]+ kB/s)", r.get("emulator_ready", ""))
        shape = f"`{r['shape']}`" + (f" ({rate.group(1)})" if rate else "")
        rows.append(f"| {r['at']} | {shape} | {r.get('gcs_rate') or 0} Hz | {r['rc']}{err} | "
                    f"{r.get('flights', '-')} (+{r.get('validation_flights', '-')}) | {r.get('aborted', '-')} | "
                    f"{r.get('interrupted', '-')} | {r.get('link_lost', '-')} | {_pct(r.get('said_cut'))} | "
                    f"{_pct(r.get('reflown_cut'))} | {len(r.get('changed_params', []))} | {r['wall_s']:.0f} |")
    newest = runs[-1] if runs else {}
    quoted = "\n".join(f"    {ln}" for ln in newest.get("link_lines", []))
    machines = sorted({r["machine"].rsplit(",", 1)[0] for r in runs})
    body = f"""Machine: {'; '.join(machines)}. Script: `python scripts/diag/overfilled_radio.py` (runs in
`runs.jsonl`; the runs before 05:30 on 2026-12-07 by the same script as `scripts/bench_overfilled_radio.py`).

## A default campaign through a radio the vehicle overfills

ArduCopter SITL at real time, its SERIAL0 stream rates left by a ground station at the rate shown (every group;
its own defaults are 0); the link emulator on that port shaped as a SiK-class radio without RADIO_STATUS;
`ksbo-mav tune DIR --udp ... --end hold`, every other setting at its default; a bench pilot centring the SITL's
sticks while airborne. "cut said": the campaign's confirmation flights against its baseline flights (lap RMS);
"cut re-flown": the baseline and the recommendation flown in turn by `ksbo_bench.figure8_client` over the SITL's
spare TCP port (not the radio), means of each. "params left changed": every parameter read back after the campaign
against its snapshot (the autopilot's own calibration parameters excluded).

{chr(10).join(rows)}

The newest run's link lines, as the console printed them:

{quoted}
"""
    print(body)
    if write:
        (OUT / "results.md").write_text(body.strip() + "\n")
        print(f"wrote {OUT / 'results.md'}")
    return body


def main() -> int:
    argv = sys.argv[1:]
    tune = argv[argv.index("--") + 1:] if "--" in argv else []
    argv = argv[:argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--shape", default="sik", help="link emulator shape (default the sik case)")
    ap.add_argument("--gcs-rate", type=int, default=10,
                    help="SERIAL0's stream rates as a ground station left them, Hz per group (0: the SITL's own)")
    ap.add_argument("--reps", type=int, default=3, help="independent re-flights of each gain set (0: none)")
    ap.add_argument("--report", action="store_true", help="only write results.md from the runs kept")
    ap.add_argument("--no-write", action="store_true")
    a = ap.parse_args(argv)
    a.tune = tune
    if not a.report:
        rec = run(a)
        OUT.mkdir(parents=True, exist_ok=True)
        with RUNS.open("a") as f:
            f.write(json.dumps(rec) + "\n")
    report(not a.no_write)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
