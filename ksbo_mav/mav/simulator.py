"""Which simulator a vehicle is, told by its parameters, and the setting that makes a simulated pack last.

A simulator announces itself in its parameter set: PX4 SITL has ``SIM_BAT_DRAIN`` (its battery simulator),
ArduPilot SITL ``SIM_BATT_CAP_AH`` (and the rest of its ``SIM_*`` table), our own simulator ``SIM_LOCKSTEP``.
Their packs are models with their own rules, and a campaign stopped "swap the battery" on one of them needs the
model's setting, not a battery: PX4 SITL drains 100 % per ``SIM_BAT_DRAIN`` seconds (60) down to
``SIM_BAT_MIN_PCT`` (50 %) while armed and is full again once disarmed, so its first trial already uses about
40 % of the pack; ArduPilot SITL counts the milliamp-hours drawn against ``BATT_CAPACITY`` (3300 mAh in its
``copter.parm``: about five trials above the reserve) until it is restarted.
"""

from __future__ import annotations

from collections.abc import Mapping


def simulator_of(params: Mapping[str, float]) -> str | None:
    """"PX4 SITL", "ArduPilot SITL", "ksbo-mav sim" or None (a real vehicle, as far as its parameters tell)."""
    if "SIM_LOCKSTEP" in params:
        return "ksbo-mav sim"
    if "SIM_BAT_DRAIN" in params:
        return "PX4 SITL"
    if "SIM_BATT_CAP_AH" in params:
        return "ArduPilot SITL"
    return None


def lasting_pack_hint(params: Mapping[str, float]) -> str | None:
    """For a simulated vehicle, one clause naming its pack's model and the setting that makes it last a campaign;
    None for a real vehicle."""
    sim = simulator_of(params)
    if sim == "PX4 SITL":
        drain, floor = params["SIM_BAT_DRAIN"], params.get("SIM_BAT_MIN_PCT", 50.0)
        return (f"this is PX4 SITL's simulated pack (it drains 100 % per SIM_BAT_DRAIN = {drain:g} s down to "
                f"SIM_BAT_MIN_PCT = {floor:g} %, full again once disarmed): set SIM_BAT_DRAIN to 3600 (PX4's "
                "client beside the SITL: `px4-param set SIM_BAT_DRAIN 3600`) and it lasts a campaign (docs/sitl.md)")
    if sim == "ArduPilot SITL":
        cap = params.get("BATT_CAPACITY")
        counted = f" against BATT_CAPACITY = {cap:g} mAh" if cap is not None else ""
        return (f"this is ArduPilot SITL's simulated pack (the mAh drawn are counted{counted} until it restarts): "
                "set BATT_CAPACITY to 33000 (and SIM_BATT_CAP_AH to 33 where it is set) and it lasts a campaign "
                "(docs/sitl.md)")
    if sim == "ksbo-mav sim":
        return ("this is ksbo-mav sim's simulated pack (`--battery MAH`): start the simulator with a larger MAH, or "
                "without --battery, and it lasts a campaign")
    return None
