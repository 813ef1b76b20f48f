"""ksbo_sim.copter3d: a 3-D quadrotor (JSBSim DJI F450) flown by an ArduCopter-style position controller.

Modules: ``backend`` (JSBSim FDM, fixed 2.5 ms physics, reset without reload), ``attitude`` (fixed attitude/rate
loops and mixer), ``poscontrol`` (AC_PosControl-like cascade), ``params`` (ArduPilot both generations / PX4
parameter tables onto one gain vector), ``personality`` (plain-data MAVLink identities), ``mission`` (the
horizontal figure-8 of :mod:`ksbo_task.figure8_ne` flown in process), ``vehicle`` (:class:`Copter3D`, a
VehicleModel).
"""

from ksbo_sim.copter3d.mission import fly
from ksbo_sim.copter3d.personality import PERSONALITIES
from ksbo_sim.copter3d.vehicle import Copter3D

__all__ = ["Copter3D", "fly", "PERSONALITIES", "make_vehicle"]


def make_vehicle(personality: str, seed: int | None = None) -> Copter3D:  # noqa: ARG001 - deterministic model
    """Endpoint hook (``ksbo_sim.mavlink.vehicles``): the copter named per ``personality``.

    "ours" (the built-in simulator identity, ArduCopter mode numbers) exposes the current ArduPilot names.
    """
    return Copter3D("ardupilot" if personality == "ours" else personality)
