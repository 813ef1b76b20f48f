"""The smoothness term on flown trials: the built-in JSBSim copter (ArduPilot names, lockstep, its own process over
loopback UDP) with raised sensor noise, which its position loops fly (as an autopilot flies its estimate). The
trust region's corner of gains tracks the figure-8 better than the baseline and shakes the vehicle more: the
score charges the roughness, so the smoother baseline wins; the motors shake more too (SERVO_OUTPUT_RAW, asked at
the mission rate); ``ksbo-mav score`` on the trial's tlog gives the live score and motor oscillation (the baseline's
roughness travels in the tlog's marker)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ksbo_mav.mav.objective import MavlinkObjective
from ksbo_mav.mav.vehicle import Vehicle
from mav_tune_helpers import short_figure8, sim_and_endpoint

pytestmark = [pytest.mark.network, pytest.mark.timeout(300)]

#: The trust region's corner (PSC_NE_POS_P, PSC_NE_VEL_P, PSC_NE_VEL_D) around the profile's baseline.
CORNER = {"PSC_NE_POS_P": 1.75, "PSC_NE_VEL_P": 3.5, "PSC_NE_VEL_D": 0.5}


def test_gains_that_track_better_and_shake_more_lose_to_the_smooth_baseline(tmp_path):
    profile = tmp_path / "short.toml"  # ardupilot-copter with a short figure-8: a trial takes seconds
    shutil.copy(Path(__file__).parents[1] / "params" / "ardupilot-copter.toml", profile)
    short_figure8(profile)
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", "ardupilot", "--noise", "0.05,0.1,0.2",
                          "--seed", "3") as (_, ep):
        v = Vehicle.connect(ep, str(profile))
        try:
            base = {n: v.params.read(n) for n in v.gain_map.param_names}
            v.setup_streams()
            assert v.cmd.set_interval(36, 1e6 / v.mission.rate_hz)  # SERVO_OUTPUT_RAW
            v.ensure_airborne()
            obj = MavlinkObjective(v, base, tmp_path)
            first = obj.fly(v.gain_map.from_params(base), label="baseline")
            obj.rms_ref, obj.rough_ref = first.score["rms_lap2_m"], first.score["rough_dps"]
            corner = obj.fly(v.gain_map.from_params({**base, **CORNER}), label="corner")
        finally:
            v.close()
    b, c = first.score, corner.score
    print(f"baseline: lap RMS {b['rms_lap2_m']:.3f} m, roughness {b['rough_dps']:.2f} deg/s, P {b['P']:.3f}; corner: "
          f"{c['rms_lap2_m']:.3f} m, {c['rough_dps']:.2f} deg/s, term {c['smooth_penalty']:.3f}, P {c['P']:.3f}")
    assert first.outcome == corner.outcome == "ok"
    assert b["rough_dps"] > 0.5 and b["smooth_penalty"] == 0.0  # the noise shakes the baseline too
    assert c["rms_lap2_m"] < 0.8 * b["rms_lap2_m"]  # tracking improves ...
    assert c["rough_dps"] > 1.5 * b["rough_dps"]  # ... and the vehicle shakes more
    tracking_alone = 1.0 - c["rms_lap2_m"] / (c["unsafe_rms_ratio"] * b["rms_lap2_m"])
    assert tracking_alone > 0.5 > c["P"]  # tracking alone would prefer the corner; the score prefers the baseline
    assert c["P"] == pytest.approx(tracking_alone - c["smooth_penalty"] / c["unsafe_rms_ratio"])
    assert c["rough_ref_dps"] == pytest.approx(b["rough_dps"], rel=1e-5)
    print(f"motor oscillation: baseline {b['motor_osc_us']:.1f} us, corner {c['motor_osc_us']:.1f} us")
    assert c["motor_osc_us"] > 1.3 * b["motor_osc_us"] > 0  # what RCOU would show (measured: 6.1 -> 9.6 us)
    r = subprocess.run([sys.executable, "-m", "ksbo_mav.cli", "score", corner.meta["tlog"], "--profile",
                        str(profile), "--json"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    replayed = json.loads(r.stdout)["score"]
    assert replayed["P"] == pytest.approx(c["P"], abs=1e-9)
    assert replayed["motor_osc_us"] == pytest.approx(c["motor_osc_us"], rel=1e-9)
