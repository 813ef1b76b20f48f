"""Plain-data description of the autopilot identities the 3-D copter can wear over MAVLink.

For the endpoint (``ksbo_sim.mavlink``): ``PERSONALITIES[name]`` says what HEARTBEAT autopilot type to send,
which custom_mode numbers mean guided/offboard, hold and land, how INT32 parameters travel in the float field,
and which parameter name generation the vehicle model exposes (``Copter3D(personality=name)`` builds exactly
that table; see ``params.py``). Numbers: fact sheet sections 1.1-1.3 and 2. The endpoint's own
``ksbo_sim.mavlink.personality.Personality`` objects carry the same numbers; ``tests/test_copter3d_params.py``
checks that the two agree.

Keys of each entry:

* ``autopilot``: HEARTBEAT.autopilot (3 MAV_AUTOPILOT_ARDUPILOTMEGA, 12 MAV_AUTOPILOT_PX4).
* ``vehicle_type``: HEARTBEAT.type (2 MAV_TYPE_QUADROTOR).
* ``modes``: {"guided"|"hold"|"land"|"boot": custom_mode}; PX4 numbers are main<<16 | sub<<24.
* ``do_set_mode``: "custom" (ArduPilot: param2 = custom_mode) or "px4_main_sub" (param2 main, param3 sub).
* ``param_encoding``: "c_cast" ((float)int, ArduPilot) or "bytewise" (int bits in the float, PX4).
* ``param_echo_index``: False when PARAM_SET is echoed with param_index 65535 (ArduPilot), True otherwise.
* ``param_generation``: human label of the parameter names; ``gain_names``: the tunable position gains in
  profile order (NE pos P, NE vel P, I, D, D pos P, D vel P).
"""

from __future__ import annotations

from typing import Any

from ksbo_sim.copter3d.params import EQUIVALENT, TABLES

#: Internal fields of the tuned gain vector, in profile order.
TUNED_FIELDS = ("ne_pos_p", "ne_vel_p", "ne_vel_i", "ne_vel_d", "d_pos_p", "d_vel_p")

_ARDUCOPTER_MODES = {"boot": 0, "guided": 4, "hold": 5, "land": 9}  # STABILIZE, GUIDED, LOITER, LAND
_PX4_MODES = {"boot": 1 << 16, "guided": 6 << 16, "hold": (4 << 16) | (3 << 24), "land": (4 << 16) | (6 << 24)}

_ARDUPILOT: dict[str, Any] = {
    "autopilot": 3,
    "vehicle_type": 2,
    "modes": _ARDUCOPTER_MODES,
    "do_set_mode": "custom",
    "param_encoding": "c_cast",
    "param_echo_index": False,
}

PERSONALITIES: dict[str, dict[str, Any]] = {
    # The two ArduPilot personalities differ only in the PSC_* name generation (and its scaling).
    "ardupilot": {
        **_ARDUPILOT,
        "modes": dict(_ARDUCOPTER_MODES),
        "param_generation": "ArduPilot master (PR #31513): PSC_NE_*, PSC_D_*",
        "gain_names": tuple(EQUIVALENT[f]["ardupilot"] for f in TUNED_FIELDS),
    },
    "ardupilot-legacy": {
        **_ARDUPILOT,
        "modes": dict(_ARDUCOPTER_MODES),
        "param_generation": "ArduPilot <= 4.7.0-dev: PSC_POSXY_*, PSC_VELXY_*, PSC_POSZ_P, PSC_VELZ_*, PSC_ACCZ_*",
        "gain_names": tuple(EQUIVALENT[f]["ardupilot-legacy"] for f in TUNED_FIELDS),
    },
    "px4": {
        "autopilot": 12,
        "vehicle_type": 2,
        "modes": dict(_PX4_MODES),
        "do_set_mode": "px4_main_sub",
        "param_encoding": "bytewise",
        "param_echo_index": True,
        "param_generation": "PX4 mc_pos_control MPC_*, mc_att/rate_control MC_*",
        "gain_names": tuple(EQUIVALENT[f]["px4"] for f in TUNED_FIELDS),
    },
}


def int_param_names(personality: str) -> list[str]:
    """Names of the INT32 parameters of a personality (for encoding tests)."""
    return [r.spec.name for r in TABLES[personality] if r.spec.type == "INT32"]
