"""The console's firmware line as a user sees it (`ksbo-mav tune DIR --dry-run`: connect, read the parameters,
print the plan, fly nothing) on our simulator in each ArduPilot generation and PX4, and on the SITLs here.

    python scripts/diag/version_lines.py sim          # our simulator: 4.5, 4.6, 4.7, PX4 personalities
    heavy python scripts/diag/version_lines.py sitl   # ArduCopter SITL, PX4 1.15.4, PX4 main (one at a time)
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")

#: (what, simulator arguments, profile)
SIMS = [
    ("ArduPilot 4.5 (legacy names)", ["--personality", "ardupilot-legacy", "--firmware", "4.5.5"], "ardupilot-copter"),
    ("ArduPilot 4.6 (legacy names)", ["--personality", "ardupilot-legacy"], "ardupilot-copter"),
    ("ArduPilot 4.7 (new names)", ["--personality", "ardupilot"], "ardupilot-copter"),
    ("ArduPilot 4.8 (newer than verified)", ["--personality", "ardupilot", "--firmware", "4.8.0-dev"],
     "ardupilot-copter"),
    ("PX4 1.19 (param.pck)", ["--personality", "px4", "--firmware", "1.19.0-dev", "--param-file"], "px4-copter"),
]


def firmware_lines(text: str) -> list[str]:
    """What the console says from connecting to the plan's firmware line (the connect lines wrap at 80 columns),
    and any warning about the version."""
    lines = text.splitlines()
    end = next((i for i, ln in enumerate(lines) if ln.startswith("profile:")), len(lines))
    return [ln.rstrip() for ln in lines[:end]] + [ln for ln in lines[end:] if ln.startswith("warning")]


def dry_run(conn: list[str], profile: str | None) -> subprocess.CompletedProcess:
    d = Path(tempfile.mkdtemp(prefix="version-line-")) / "c"
    extra = ["--profile", profile] if profile else []
    return subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "tune", str(d), *conn, *extra, "--dry-run"],
                          capture_output=True, text=True, timeout=300)


def sims() -> None:
    for what, args, profile in SIMS:
        p = subprocess.Popen([sys.executable, "-m", "ksbo_mav.cli", "sim", "--vehicle", "copter3d", "--udp",
                              "127.0.0.1:0", *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            ready = p.stdout.readline().split()
            addr = next(w for w in ready if w.startswith("udp:"))[4:]
            r = dry_run(["--udp-out", addr], profile)
            print(f"## our simulator, {what}: ksbo-mav sim --vehicle copter3d {' '.join(args)}  (rc {r.returncode})")
            print("\n".join(firmware_lines(r.stderr + r.stdout)) or r.stderr[-600:])
        finally:
            p.terminate()
            p.wait(10)


def sitls() -> None:
    from ksbo_sim.sitl_instances import release_stopped, start_claimed

    for kind, build in (("ardupilot", None), ("px4", "1.15"), ("px4", "main")):
        sitl = start_claimed(kind, 5, **({"build": build} if build else {}))
        try:
            r = dry_run(sitl.cli_args, None)
            print(f"## {kind} SITL {build or ''} (rc {r.returncode})")
            print("\n".join(firmware_lines(r.stderr + r.stdout)) or r.stderr[-600:])
        finally:
            sitl.stop()
            release_stopped()


if __name__ == "__main__":
    {"sim": sims, "sitl": sitls}[sys.argv[1]]()
