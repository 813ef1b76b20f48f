"""The copters' simulated prior on our JSBSim copter fitted to the vehicle: a campaign whose snapshot holds a real
vehicle's parameter set (ArduCopter SITL's, tests/data) flies its prior episodes on the fitted copter, says what it
was fitted to and keeps the fit in prior.json; and the fitted airframe really hovers at the reported thrust."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ksbo_mav.campaign import CampaignConfig, CampaignDir
from ksbo_mav.campaign.prior import campaign_prior
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.mav.params.client import Param
from ksbo_mav.mav.params.snapshot import write_snapshot
from ksbo_mav.profiles import load_profile
from ksbo_mav.simulated.copter_objective import CopterObjective
from ksbo_mav.simulated.vehicle_fit import fit_vehicle
from ksbo_sim.copter3d import Copter3D
from ksbo_sim.vehicle import Setpoint
from test_vehicle_fit import DATA, read_params


def never(_x):  # a simulated prior flies nothing
    raise AssertionError("the simulator prior flew a trial")


def test_prior_episodes_fly_on_the_copter_fitted_to_the_snapshot(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("KSBO_PRIOR_FIT", "1")
    params = read_params("arducopter-sitl.params")
    types = {r.split("\t")[2]: int(r.split("\t")[4]) for r in (DATA / "arducopter-sitl.params").read_text()
             .splitlines() if r and not r.startswith("#")}
    profile = load_profile("ardupilot-copter")
    legacy = ["PSC_POSXY_P", "PSC_VELXY_P", "PSC_VELXY_I", "PSC_VELXY_D", "PSC_POSZ_P", "PSC_VELZ_P"]
    d = CampaignDir.at(tmp_path)
    d.snapshot.parent.mkdir(parents=True)
    table = {n: Param(n, v, types[n], i) for i, (n, v) in enumerate(sorted(params.items()))}
    write_snapshot(d.snapshot_stem, {"sysid": 1, "compid": 1}, "ardupilot", "legacy", profile.name, legacy, table)
    x0 = np.asarray(profile.default, dtype=float)
    bounds = opt_bounds(profile, x0)
    said: list[str] = []
    cfg = CampaignConfig(dir=str(tmp_path), prior="sim", n_prior=3, seed=4)
    X, y = campaign_prior("sim", cfg, d, profile, x0, bounds, [], never, said.append)
    assert any("our JSBSim copter fitted to the vehicle: hover thrust 0.39 (MOT_THST_HOVER); quad, 4 motors" in s
               for s in said)
    fit = fit_vehicle(params, "ardupilot")
    fitted = CopterObjective("copter3d-ardupilot", fit=fit, baseline=x0)
    assert fitted.vehicle.get_param("ATC_RAT_YAW_P") == pytest.approx(0.3)  # the vehicle's, not our default 0.18
    assert fitted.vehicle.get_param("MOT_THST_HOVER") == pytest.approx(0.39)
    assert np.allclose(y, [fitted(x).value for x in X], atol=1e-9)
    kept = json.loads(d.prior.read_text())
    assert kept["fit"]["hover"] == pytest.approx(0.39) and kept["fit"]["hover_source"] == "MOT_THST_HOVER"
    assert kept["fit"]["sim_params"]["PSC_NE_VEL_IMAX"] == pytest.approx(10.0)  # PSC_VELXY_IMAX 1000 cm/s^2


def test_a_campaign_without_a_snapshot_keeps_the_copter_as_built(tmp_path) -> None:
    profile = load_profile("px4-copter")
    x0 = np.asarray(profile.default, dtype=float)
    said: list[str] = []
    cfg = CampaignConfig(dir=str(tmp_path), prior="sim", n_prior=2, seed=1)
    d = CampaignDir.at(tmp_path)
    campaign_prior("sim", cfg, d, profile, x0, opt_bounds(profile, x0), [], never, said.append)
    assert not any("fitted" in s for s in said) and json.loads(d.prior.read_text())["fit"] is None


def test_px4_fit_applies_to_the_px4_copter_only() -> None:
    fit = fit_vehicle(read_params("px4-sitl.params"), "px4")
    with pytest.raises(ValueError, match="a fit to a px4 vehicle does not apply to ardupilot"):
        CopterObjective("copter3d-ardupilot", fit=fit)


@pytest.mark.parametrize("hover", [None, 0.39, 0.5])
def test_the_fitted_airframe_hovers_at_the_reported_thrust(hover) -> None:
    v = Copter3D("ardupilot")
    as_built = v.get_param("MOT_THST_HOVER")
    assert as_built == pytest.approx(v.af.hover_fraction, abs=1e-4)
    if hover is not None:
        v.set_param("MOT_THST_HOVER", hover)
    v.reset(np.array([0.0, 0.0, -10.0]), np.zeros(3))
    hold = Setpoint(pos=np.array([0.0, 0.0, -10.0]))
    for _ in range(150):  # 3 s
        s = v.step(hold)
    collective = float(np.sum(s.thrust)) / (4.0 * v.af.thrust_max)  # commanded, as a fraction of full thrust
    assert s.crashed == 0 and abs(s.pos[2] + 10.0) < 0.05
    assert collective == pytest.approx(as_built if hover is None else hover, abs=0.01)
