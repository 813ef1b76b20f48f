"""The copters' default prior: episodes of our JSBSim copter flown in process around the vehicle's baseline, kept
in the campaign's prior.json (a resume reads them back instead of simulating again), nothing flown."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ksbo_mav.campaign import CampaignConfig, CampaignDir
from ksbo_mav.campaign.prior import campaign_prior
from ksbo_mav.mav.gains import opt_bounds
from ksbo_mav.profiles import load_profile
from ksbo_mav.simulated.copter_objective import CopterObjective


@pytest.mark.slow  # default run: the simulated prior: test_trial_step
def test_copter_prior_is_simulated_on_the_jsbsim_copter_and_kept(tmp_path) -> None:
    profile = load_profile("ardupilot-copter")
    x0 = np.asarray(profile.default, dtype=float)
    bounds = opt_bounds(profile, x0)
    d = CampaignDir.at(tmp_path)
    said: list[str] = []

    def never(_x):  # a simulated prior flies nothing
        raise AssertionError("the simulator prior flew a trial")

    cfg = CampaignConfig(dir=str(tmp_path), prior="sim", n_prior=3, seed=4)
    X, y = campaign_prior("sim", cfg, d, profile, x0, bounds, [], never, said.append)
    assert X.shape == (3, len(x0)) and y.shape == (3,)
    assert np.all((X >= bounds[:, 0]) & (X <= bounds[:, 1]))
    # The same scores as the in-process copter objective gives those gains (the model is deterministic).
    want = [CopterObjective("copter3d-ardupilot")(x).value for x in X]
    assert np.allclose(y, want, atol=1e-9)
    assert any("JSBSim copter" in s for s in said)
    kept = json.loads(d.prior.read_text())
    assert kept["kind"] == "sim" and np.allclose(kept["y"], y)
    # Read back, not simulated again: the kept values come back even when the file says otherwise.
    d.prior.write_text(json.dumps({**kept, "y": [0.1, 0.2, 0.3]}))
    _, again = campaign_prior("sim", cfg, d, profile, x0, bounds, [], never, said.append)
    assert again.tolist() == [0.1, 0.2, 0.3]
