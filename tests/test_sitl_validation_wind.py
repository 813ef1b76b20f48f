"""A campaign with its validation flights on ArduCopter SITL in a steady 5 m/s wind from the east (``SIM_WIND_SPD``
5, ``SIM_WIND_DIR`` 90, no height profile, no turbulence): the steps, the hold and the AUTO box flown A B A B and
judged, the verdict on the report page; the wind, which an ArduCopter without drag fusion does not estimate (its
``WIND`` reads 0), recorded as not estimated, never as 0, and inferred from the flights' lean angle against their
ground velocity close to the wind that was set; every parameter as the snapshot had it at the end."""

from __future__ import annotations

import json
import socket
import struct
import threading
from contextlib import contextmanager

import pytest

from sitl_helpers import param_diff, read_all, tool

pytestmark = [pytest.mark.sitl, pytest.mark.slow, pytest.mark.timeout(1500)]

WIND = {"SIM_WIND_SPD": 5.0, "SIM_WIND_DIR": 90.0, "SIM_WIND_T": 1.0, "SIM_WIND_TURB": 0.0}


@contextmanager
def centred_sticks(sitl, airborne):
    """The SITL's simulated transmitter (its RC input, UDP 5501 + 10N: eight PWM values) with the sticks centred,
    the throttle too once ``airborne()`` (ArduCopter arms only with the throttle low): LOITER holds only with
    centred sticks, and a bench's throttle otherwise rests low."""
    stop = threading.Event()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)

    def send() -> None:
        while not stop.is_set():
            throttle = 1500 if airborne() else 1000
            sock.sendto(struct.pack("<8H", 1500, 1500, throttle, 1500, 1000, 1000, 1000, 1000),
                        ("127.0.0.1", 5501 + 10 * sitl.instance))
            stop.wait(0.1)

    thread = threading.Thread(target=send, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        sock.close()


def _lines(path):
    return [json.loads(x) for x in path.read_text().splitlines() if x.strip()]


def test_campaign_with_validation_in_wind_labels_the_wind_honestly(tmp_path):
    from conftest import sitl_or_skip

    sitl = sitl_or_skip("ardupilot", 4)  # slower than the others: a shared machine keeps up
    d = tmp_path / "wind"
    try:
        for name, value in WIND.items():
            sitl.set_param(name, value, second_port=True)
        with centred_sticks(sitl, lambda: (d / "journal.jsonl").exists()):
            r = tool("tune", str(d), *sitl.cli_args, "--prior", "none", "--budget", "4", "--method", "random",
                     "--validation", "quick", timeout=1400)
        assert r.returncode == 0, r.stderr[-4000:]
        flights = _lines(d / "validation.jsonl")
        for m in ("steps", "hold", "auto_mission"):
            mine = [f for f in flights if f["manoeuvre"] == m and f["pair"] == "recommendation"]
            assert [f["gains"] for f in mine] == ["baseline", "recommendation"] * 2, mine
            assert all(f["restored"] for f in mine)
        text = " ".join(r.stderr.split())
        assert "validation, recommendation against the baseline:" in text
        page = (d / "report" / "index.html").read_text()
        assert "<h2>Validation flights</h2>" in page and "not estimated by the vehicle" in page
        # The vehicle streams WIND 0: never recorded as a measurement; the inferred wind is the one that blows.
        trials = _lines(d / "journal.jsonl")
        conds = [e["cond"] for e in trials] + [f["cond"] for f in flights]
        assert all(c["wind_estimated"] is False and c["wind_mps"] is None for c in conds)
        inferred = [c for c in [e["cond"] for e in trials if e["outcome"] == "ok"] if "wind_inferred_mps" in c]
        assert len(inferred) >= 3
        # An inference under a drag model (docs/report.md): measured within 30 % of the set wind on this bench.
        for c in inferred:
            assert c["wind_inferred_mps"] == pytest.approx(5.0, abs=1.5), c
            assert c["wind_inferred_from_deg"] == pytest.approx(90.0, abs=15.0), c
        holds = [f["cond"] for f in flights if f["manoeuvre"] == "hold" and "wind_inferred_mps" in f["cond"]]
        assert holds and all(c["wind_inferred_mps"] == pytest.approx(5.0, abs=1.5) for c in holds), holds
        now, armed = read_all(sitl, "ardupilot-copter")
        assert not armed
        assert set(param_diff(d, now)) <= set(WIND)
    finally:
        sitl.stop()
