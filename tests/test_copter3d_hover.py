"""Our JSBSim copter reports the hover thrust an autopilot reports (ArduPilot MOT_THST_HOVER, PX4 MPC_THR_HOVER),
and a value written makes its airframe hover there: a heavier (or weaker-motored) vehicle for the benchmarks."""

from __future__ import annotations

import numpy as np
import pytest

from ksbo_sim.copter3d import Copter3D
from ksbo_sim.vehicle import Setpoint


@pytest.mark.parametrize("personality,name", [("ardupilot", "MOT_THST_HOVER"), ("px4", "MPC_THR_HOVER")])
@pytest.mark.parametrize("hover", [None, 0.39, 0.5])
def test_the_airframe_hovers_at_its_hover_parameter(personality, name, hover) -> None:
    v = Copter3D(personality)
    as_built = v.get_param(name)
    assert as_built == pytest.approx(v.af.hover_fraction, rel=1e-12)  # what the F450 hovers at: ~0.22
    assert [s.default for s in v.param_specs() if s.name == name] == [as_built]
    if hover is not None:
        v.set_param(name, hover)
    v.reset(np.array([0.0, 0.0, -10.0]), np.zeros(3))
    hold = Setpoint(pos=np.array([0.0, 0.0, -10.0]))
    for _ in range(150):  # 3 s
        s = v.step(hold)
    collective = float(np.sum(s.thrust)) / (4.0 * v.af.thrust_max)  # commanded, as a fraction of full thrust
    assert s.crashed == 0 and abs(s.pos[2] + 10.0) < 0.05
    assert collective == pytest.approx(as_built if hover is None else hover, abs=0.01)
