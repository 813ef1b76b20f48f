"""Vehicle models the endpoint can serve, by ``--vehicle`` name.

Hook for new models: a factory ``(personality_name, seed) -> VehicleModel``. The JSBSim copter plugs
in as ``copter3d`` by providing ``ksbo_sim.copter3d.make_vehicle(personality: str, seed: int | None)``; the
endpoint picks HEARTBEAT autopilot type, custom modes and INT32 encoding from the personality
(``ksbo_sim.mavlink.personality``), the model only supplies its ParamSpecs (named per personality) and physics.
"""

from __future__ import annotations

import importlib

from ksbo_sim.errors import SimInputError
from ksbo_sim.vehicle import VehicleModel

#: --vehicle name -> (factory "module:function", AUTOPILOT_VERSION.product_id, personalities it supports)
VEHICLES: dict[str, tuple[str, int, tuple[str, ...]]] = {
    "planar": ("ksbo_sim.mavlink.vehicles:_planar", 1, ("ours",)),
    "copter3d": ("ksbo_sim.copter3d:make_vehicle", 2, ("ardupilot", "ardupilot-legacy", "px4", "ours")),
}


def _planar(personality: str, seed: int | None) -> VehicleModel:  # noqa: ARG001 - one personality only
    from ksbo_sim.planar_vehicle import PlanarVehicle

    return PlanarVehicle()


def make_vehicle(name: str, personality: str, seed: int | None) -> tuple[VehicleModel, int]:
    """Instantiate a vehicle model; returns (model, product_id)."""
    if name not in VEHICLES:
        raise SimInputError(f"unknown vehicle {name!r}; choose from {', '.join(VEHICLES)}")
    target, product_id, personalities = VEHICLES[name]
    if personality not in personalities:
        raise SimInputError(f"vehicle {name!r} supports personalities {', '.join(personalities)}, not {personality!r}")
    module, func = target.split(":")
    try:
        factory = getattr(importlib.import_module(module), func)
    except (ImportError, AttributeError) as exc:
        raise SimInputError(f"vehicle {name!r} is not available in this installation ({exc})") from None
    return factory(personality, seed), product_id
