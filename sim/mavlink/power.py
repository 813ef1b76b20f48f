"""The endpoint's battery and changing conditions on the wire: SYS_STATUS battery fields, BATTERY_STATUS, WIND,
the battery parameters and the low-battery failsafe (ArduPilot-like: a CRITICAL "Battery 1 is low" STATUSTEXT, the
failsafe action ``BATT_FS_LOW_ACT`` 1 LAND / 2 RTL, HEARTBEAT system_status CRITICAL, arming refused after it).

Stepped once per control period after the vehicle (:meth:`Power.step`): the battery draws the current of the
thrust the model produced, and :class:`~ksbo_sim.conditions.Conditions` set the model's authority and push it with
the wind. Without ``--battery`` the SYS_STATUS battery fields stay the fixed full pack they always were.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from ksbo_sim.battery import Battery
from ksbo_sim.conditions import Conditions
from ksbo_sim.mavlink.flight import SEV_CRITICAL, Flight
from ksbo_sim.mavlink.personality import Mode
from ksbo_sim.vehicle import ParamSpec

BATTERY_STATUS, WIND = 147, 168
#: BATT_FS_LOW_ACT values (ArduCopter): 0 warn only, 1 LAND, 2 RTL.
FS_ACTIONS = {1: Mode.LAND, 2: Mode.RTL}


def battery_specs(b: Battery) -> list[ParamSpec]:
    """The battery's parameters (ArduPilot names where ArduPilot has one)."""
    return [
        ParamSpec("BATT_CAPACITY", b.capacity_mah, 1.0, 1e6, "INT32", "pack capacity [mAh]"),
        ParamSpec("BATT_LOW_VOLT", b.low_volt, 0.0, 100.0, description="low-battery failsafe voltage [V]; 0 off"),
        ParamSpec("BATT_LOW_MAH", b.low_mah, 0.0, 1e6, "INT32", "low-battery reserve [mAh]; 0 off"),
        ParamSpec("BATT_LOW_TIMER", b.low_timer_s, 0.0, 120.0, "INT32", "seconds below BATT_LOW_VOLT [s]"),
        ParamSpec("BATT_FS_LOW_ACT", 2, 0, 2, "INT32", "low-battery action: 0 warn, 1 land, 2 RTL"),
        ParamSpec("SIM_BATT_CURR", b.hover_current_a, 0.0, 500.0, description="hover current [A]"),
    ]


_PARAM_FIELDS = {"BATT_CAPACITY": "capacity_mah", "BATT_LOW_VOLT": "low_volt", "BATT_LOW_MAH": "low_mah",
                 "BATT_LOW_TIMER": "low_timer_s", "SIM_BATT_CURR": "hover_current_a"}


class Power:
    """Battery and conditions of one endpoint (either may be None)."""

    def __init__(self, flight: Flight, battery: Battery | None, conditions: Conditions | None,
                 notify: Callable[[int, str], None]) -> None:
        self.flight, self.battery, self.conditions, self.notify = flight, battery, conditions, notify
        self.fs_action = 2
        model = flight.model
        c = getattr(getattr(model, "config", None), "constants", None)
        self.hover_thrust = float(getattr(c, "hover_thrust", 0.0) or 0.0)
        if battery is not None:
            flight.arm_check = self._arm_check

    @property
    def params(self) -> list[ParamSpec]:
        return battery_specs(self.battery) if self.battery is not None else []

    def set_param(self, name: str, value: float) -> bool:
        """Apply one of :attr:`params`; False if the name is not ours."""
        if name == "BATT_FS_LOW_ACT":
            self.fs_action = int(value)
        elif name in _PARAM_FIELDS and self.battery is not None:
            setattr(self.battery, _PARAM_FIELDS[name], float(value))
        else:
            return False
        return True

    def _arm_check(self) -> str | None:
        b = self.battery
        if b is not None and b.low:
            return f"PreArm: Battery 1 low voltage failsafe ({b.voltage:.2f}V)"
        return None

    def _load(self) -> float:
        thrust = np.asarray(self.flight.truth.thrust, dtype=float)
        if self.hover_thrust <= 0 or thrust.size == 0:
            return 1.0
        return float(np.mean(thrust)) / self.hover_thrust

    def step(self, dt: float) -> None:
        f = self.flight
        airborne = f.armed and not f.landed
        c, b = self.conditions, self.battery
        if c is not None:
            c.step(dt, airborne)
            used = 0.0 if b is None else 1.0 - b.soc
            if hasattr(f.model, "set_authority"):
                f.model.set_authority(c.authority(used))
            if hasattr(f.model, "set_drag_scale"):
                f.model.set_drag_scale(c.drag())
            if hasattr(f.model, "set_wind"):  # a model with its own air: the wind, not a force
                f.model.set_wind(c.wind() if airborne else 0.0)
            elif airborne and hasattr(f.model, "disturb"):
                f.model.disturb(c.wind_accel(f.truth.vel), dt)
        if b is not None and b.step(dt, f.armed, airborne, self._load()):
            self.notify(SEV_CRITICAL, f"Battery 1 is low {b.voltage:.2f}V used {b.consumed_mah:.0f} mAh")
            mode = FS_ACTIONS.get(self.fs_action)
            if airborne and mode is not None:
                f.failsafe = True
                f.set_mode(mode)

    # --- telemetry ---------------------------------------------------------------------------------------
    def sys_status(self) -> tuple[int, int, int]:
        """SYS_STATUS (voltage_battery mV, current_battery cA, battery_remaining %)."""
        b = self.battery
        if b is None:
            return 12600, 500, 100
        return int(b.voltage * 1000), int(b.current_a * 100), b.remaining_pct

    def send(self, mav: mavlink.MAVLink, msg_id: int, now_us: int) -> bool:
        b, c = self.battery, self.conditions
        if msg_id == BATTERY_STATUS and b is not None:
            cells = [int(b.voltage / b.cells * 1000)] * b.cells + [65535] * (10 - b.cells)
            mav.battery_status_send(0, 0, 1, 32767, cells, int(b.current_a * 100), int(b.consumed_mah),
                                    int(b.energy_wh * 360), b.remaining_pct, 0,
                                    2 if b.low else 0)  # charge_state 2: MAV_BATTERY_CHARGE_STATE_LOW
            return True
        if msg_id == WIND and c is not None:
            w = c.wind()
            # direction the wind comes FROM [deg]: blowing toward +north comes from the south (180)
            mav.wind_send(180.0 if w >= 0 else 0.0, abs(w), 0.0)
            return True
        return False

    def streams(self) -> dict[int, int]:
        """Extra telemetry streams and their default intervals [µs]."""
        out = {}
        if self.battery is not None:
            out[BATTERY_STATUS] = 1_000_000
        if self.conditions is not None and self.conditions.active:
            out[WIND] = 1_000_000
        return out

