"""The separate figure-8 client of the training-against-flown sweep (``python -m ksbo_bench.figure8_client``):
it scores lap 2 of its samples against the pattern at their own stamps (only lap 2, as the tuner's score), and it
starts and explains itself."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from ksbo_task.figure8_ne import Figure8H

from ksbo_bench import figure8_client as client


def _samples(f8: Figure8H, offset_lap1: np.ndarray, offset_lap2: np.ndarray) -> list[tuple[float, ...]]:
    """50 Hz samples over the whole pattern (t0 first, as the client returns them), displaced by ``offset_lap1``
    in lap 1 and ``offset_lap2`` in lap 2."""
    t_ms = np.arange(0, int(f8.duration * 1000) + 40, 20)
    pos = f8.position(t_ms / 1000.0)
    pos = pos + np.where((t_ms / 1000.0 > f8.duration - f8.period)[:, None], offset_lap2, offset_lap1)
    return [(0, np.nan, np.nan, np.nan)] + [(float(t), *p) for t, p in zip(t_ms, pos)]


def test_client_scores_lap_two_against_the_pattern_at_each_stamp():
    f8 = Figure8H(lead_in=5.0)
    exact = client.lap2(f8, _samples(f8, np.zeros(3), np.zeros(3)), 0.02)
    assert exact["rms_lap2_m"] == pytest.approx(0.0, abs=1e-9)
    assert exact["samples"] == 1000 and exact["rate_hz"] == pytest.approx(50.0)
    # a 0.3 m / 0.4 m displacement in lap 2 is a 0.5 m error; a 5 m one in lap 1 is not scored
    off = client.lap2(f8, _samples(f8, np.array([5.0, 0.0, 0.0]), np.array([0.3, 0.4, 0.0])), 0.02)
    assert off["rms_lap2_m"] == pytest.approx(0.5, abs=1e-9)
    assert off["rms_h_m"] == pytest.approx(0.5, abs=1e-9) and off["rms_v_m"] == pytest.approx(0.0, abs=1e-9)


def test_the_client_starts_and_explains_itself():
    r = subprocess.run([sys.executable, "-m", "ksbo_bench.figure8_client", "--help"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr
    assert "--lead-ms" in r.stdout
