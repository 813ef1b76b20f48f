"""`ksbo-mav tune` against the JSBSim copter in each autopilot personality (own process,
loopback UDP, lockstep): the client detects the stack and ArduPilot's name generation, flies the horizontal
figure-8, improves the lap-2 tracking error over the default gains, and leaves the baseline on the vehicle."""

from __future__ import annotations

import json

import pytest

from mav_tune_helpers import fresh_read, sim_and_endpoint

from ksbo_mav.cli import main

pytestmark = [pytest.mark.network, pytest.mark.slow, pytest.mark.timeout(400)]

NAMES = {
    "ardupilot": ["PSC_NE_POS_P", "PSC_NE_VEL_P", "PSC_NE_VEL_I", "PSC_NE_VEL_D", "PSC_D_POS_P", "PSC_D_VEL_P"],
    "ardupilot-legacy": ["PSC_POSXY_P", "PSC_VELXY_P", "PSC_VELXY_I", "PSC_VELXY_D", "PSC_POSZ_P", "PSC_VELZ_P"],
    "px4": ["MPC_XY_P", "MPC_XY_VEL_P_ACC", "MPC_XY_VEL_I_ACC", "MPC_XY_VEL_D_ACC", "MPC_Z_P", "MPC_Z_VEL_P_ACC"],
}


@pytest.mark.parametrize("personality", list(NAMES))
def test_short_campaign_per_personality(tmp_path, capsys, personality):
    d = tmp_path / "c"
    with sim_and_endpoint("--vehicle", "copter3d", "--personality", personality) as (sim, ep):
        before = fresh_read(sim, NAMES[personality], None)
        rc = main(["tune", str(d), "--udp", f"127.0.0.1:{ep.port}", "--budget", "6", "--n-prior", "4",
                   "--end", "hold", "--json"])
        out = capsys.readouterr()
        assert rc == 0, out.err
        summary = json.loads(out.out)
        # The copter's prior is simulated on the ground, before the first flight.
        assert out.err.index("prior: 4 JSBSim copter episodes") < out.err.index("trial: baseline gains")
        snap = json.loads((d / "snapshot" / "vehicle.json").read_text())
        assert snap["generation"] == {"ardupilot": "new", "ardupilot-legacy": "legacy", "px4": ""}[personality]
        assert list(summary["baseline"]["values"]) == NAMES[personality]
        result = [json.loads(line) for line in (d / "journal.jsonl").read_text().splitlines()]
        assert not any(e["kind"] == "prior" for e in result)  # the copter's prior is simulated, nothing flown
        base_rms = json.loads(open(result[0]["record"]).read())["score"]["rms_lap2_m"]  # the baseline flight
        tuned = json.loads(open(result[-1]["record"]).read())["score"]["rms_lap2_m"]  # confirmation flight
        assert tuned < base_rms  # the tracking error fell
        assert fresh_read(sim, NAMES[personality], None) == pytest.approx(before, rel=1e-6)
