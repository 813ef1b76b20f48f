"""Our JSBSim copter fitted to what a vehicle reports before takeoff: its parameter set (the snapshot).

What is taken, and what stands in when the vehicle does not report it:

* **hover thrust** (ArduPilot ``MOT_THST_HOVER``, PX4 ``MPC_THR_HOVER``, both a fraction of full thrust): the
  simulated airframe is made to hover there (its thrust-to-weight), and the position loop's hover feed-forward
  with it. Not reported: the F450's own (0.22).
* **frame and motor count** (ArduPilot ``FRAME_CLASS``, PX4 ``CA_ROTOR_COUNT``): our copter is a quad whatever
  the vehicle is; a vehicle with another motor count is named in the description (``frame_matches`` False).
* **attitude and rate loops, the position loop's own limits and filters**: every parameter our copter has
  under the vehicle's stack (``ATC_*``, ``ANGLE_MAX``, ``PSC_*`` filters and integrator limits; ``MC_*``,
  ``MPC_TILTMAX_AIR``, ``MPC_XY_VEL_MAX``, ...) takes the vehicle's value; ArduPilot's legacy names
  (``PSC_POSXY_*``, ``PSC_ACCZ_*``, ...) are converted to the current ones. Not reported: our copter's default.
* **mass** (only a simulator reports it, PX4 SIH's ``SIH_MASS``): recorded, not used; the hover thrust already
  gives the thrust-to-weight ratio, and no vehicle reports its inertia.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

#: ArduPilot FRAME_CLASS -> motor count (AP_Motors: quad, hexa, octa, octaquad, Y6, tri, dodecahexa, deca).
ARDUPILOT_FRAMES: dict[int, tuple[str, int]] = {1: ("quad", 4), 2: ("hexa", 6), 3: ("octa", 8), 4: ("octaquad", 8),
                                                5: ("Y6", 6), 7: ("tri", 3), 12: ("dodecahexa", 12), 14: ("deca", 10)}
#: Parameters the fit never copies: simulator settings, stored-only identities, and the hover (handled apart).
_NOT_COPIED = ("FENCE_", "GF_", "SIM_", "ARMING_CHECK", "SYS_AUTOSTART", "MC_AIRMODE", "MPC_POS_MODE")


@dataclass(frozen=True)
class VehicleFit:
    """Our copter's settings for one vehicle (see the module docstring).

    Attributes:
        personality: the simulator personality whose parameter names ``sim_params`` uses ("ardupilot", "px4").
        hover: hover thrust fraction the simulated airframe is given (None: the F450's own, 0.22);
            ``hover_source``: the parameter it came from, or why it was not used.
        frame: the vehicle's frame ("quad", "hexa", ... or "frame not reported"); motors: its motor count or None.
        mass_kg: the reported mass or None.
        sim_params: {our copter's parameter name: value} taken from the vehicle (hover included).
    """

    personality: str
    hover: float | None
    hover_source: str
    frame: str = "frame not reported"
    motors: int | None = None
    mass_kg: float | None = None
    sim_params: dict[str, float] = field(default_factory=dict)

    @property
    def frame_matches(self) -> bool:
        """False when the vehicle says it has other than four motors (our copter is a quad)."""
        return self.motors in (None, 4)

    def describe(self) -> str:
        """One line: what the simulated copter was fitted to."""
        hover = (f"hover thrust {self.hover:.3g} ({self.hover_source})" if self.hover is not None
                 else f"hover thrust of our copter's F450, 0.22 ({self.hover_source})")
        frame = self.frame if self.motors is None else f"{self.frame}, {self.motors} motors"
        if not self.frame_matches:
            frame += " (simulated as a quad)"
        mass = "mass not reported" if self.mass_kg is None else f"mass {self.mass_kg:g} kg (not used)"
        loops = len(self.sim_params) - (self.hover is not None)
        return f"{hover}; {frame}; {loops} loop gains and limits; {mass}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def fit_vehicle(params: Mapping[str, float], stack: str) -> VehicleFit:
    """The fit of our copter to a vehicle's parameter set ``params`` {name: value} of ``stack`` ("ardupilot" or
    "px4"); missing parameters take our copter's own values (module docstring)."""
    from ksbo_sim.copter3d.params import HOVER_NAMES, TABLES

    if stack not in HOVER_NAMES:
        raise ValueError(f"no simulated copter for the {stack!r} stack; known: {', '.join(HOVER_NAMES)}")
    target = stack
    source = "ardupilot-legacy" if stack == "ardupilot" and "PSC_POSXY_P" in params else target
    # The vehicle's names onto our copter's: the same internal gain (field and axis), converted by both scales.
    slot = {(r.target, r.field, r.index): r for r in TABLES[target] if r.target is not None}
    name = HOVER_NAMES[stack]
    sim: dict[str, float] = {}
    for r in TABLES[source]:
        v = _finite(params.get(r.spec.name))
        if v is None or r.spec.name.startswith(_NOT_COPIED) or r.spec.name == name:
            continue
        if r.target is None:
            if any(t.spec.name == r.spec.name for t in TABLES[target]):
                sim[r.spec.name] = v  # stored or read by our copter directly (ANGLE_MAX, MC_*RATE_K, ...)
            continue
        dst = slot.get((r.target, r.field, r.index))
        if dst is not None:
            sim[dst.spec.name] = v * r.scale / dst.scale
    hover = _finite(params.get(name))
    src = name
    if hover is None:
        src = f"{name} not reported"
    elif not 0.05 <= hover <= 0.95:
        hover, src = None, f"{name} {hover:g} out of 0.05..0.95, not used"
    else:
        sim[name] = hover
    frame, motors = _frame(params, stack)
    mass = _finite(params.get("SIH_MASS"))
    return VehicleFit(target, hover, src, frame, motors, mass, sim)


def _finite(v: Any) -> float | None:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _frame(params: Mapping[str, float], stack: str) -> tuple[str, int | None]:
    if stack == "ardupilot":
        c = _finite(params.get("FRAME_CLASS"))
        if c is None or int(c) not in ARDUPILOT_FRAMES:
            return ("frame not reported" if c is None else f"FRAME_CLASS {int(c)}"), None
        return ARDUPILOT_FRAMES[int(c)]
    n = _finite(params.get("CA_ROTOR_COUNT"))
    if n is None or n < 1:
        return "frame not reported", None
    return {4: "quad", 6: "hexa", 8: "octa"}.get(int(n), "multirotor"), int(n)
