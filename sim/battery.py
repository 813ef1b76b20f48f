"""A flight battery: capacity, open-circuit voltage that falls with discharge, sag under load, and an
ArduPilot-like low-battery failsafe decision.

The pack is ``cells`` lithium-polymer cells in series. Current follows the load (1.0 = hover thrust) as
``hover_current_a * load ** 1.5`` while airborne, a small idle current while armed on the ground, nothing while
disarmed. The terminal voltage is the open-circuit voltage at the state of charge minus ``I * r_internal``. The
failsafe fires, as ArduPilot's ``BATT_LOW_VOLT`` / ``BATT_LOW_MAH`` do, when the voltage stays below the low
voltage for ``low_timer_s`` or when the remaining capacity drops below the low reserve; it latches.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Open-circuit voltage per cell against the state of charge (0 empty .. 1 full): a typical LiPo curve.
_SOC = np.array([0.0, 0.05, 0.1, 0.2, 0.5, 0.8, 0.95, 1.0])
_OCV = np.array([3.0, 3.3, 3.5, 3.62, 3.75, 3.95, 4.1, 4.2])
IDLE_CURRENT_A = 0.5


@dataclass
class Battery:
    capacity_mah: float
    cells: int = 3
    hover_current_a: float = 10.0
    r_internal_ohm: float = 0.03
    low_volt: float = 10.5  # pack volts (0 = off), ArduPilot BATT_LOW_VOLT
    low_mah: float = 0.0  # remaining reserve (0 = off), ArduPilot BATT_LOW_MAH
    low_timer_s: float = 10.0
    consumed_mah: float = 0.0
    current_a: float = 0.0
    energy_wh: float = 0.0
    low: bool = False  # the failsafe has fired (latched)
    _below_s: float = 0.0

    @property
    def soc(self) -> float:
        return float(max(0.0, 1.0 - self.consumed_mah / self.capacity_mah))

    @property
    def remaining_pct(self) -> int:
        return int(round(100.0 * self.soc))

    @property
    def open_voltage(self) -> float:
        return float(self.cells * np.interp(self.soc, _SOC, _OCV))

    @property
    def voltage(self) -> float:
        return max(0.0, self.open_voltage - self.current_a * self.r_internal_ohm)

    @property
    def full_voltage(self) -> float:
        return float(self.cells * _OCV[-1])

    def step(self, dt: float, armed: bool, airborne: bool, load: float) -> bool:
        """Draw current for ``dt`` seconds (``load``: thrust / hover thrust). Returns True when the failsafe fires
        in this step (once)."""
        if not armed:
            self.current_a = 0.0
        elif not airborne:
            self.current_a = IDLE_CURRENT_A
        else:
            self.current_a = self.hover_current_a * max(0.0, load) ** 1.5
        self.consumed_mah += self.current_a * dt / 3.6
        self.energy_wh += self.current_a * self.voltage * dt / 3600.0
        if self.low or not armed:
            return False
        v_low = self.low_volt > 0 and self.voltage < self.low_volt
        self._below_s = self._below_s + dt if v_low else 0.0
        reserve = self.low_mah > 0 and self.capacity_mah - self.consumed_mah < self.low_mah
        if self._below_s >= self.low_timer_s or reserve or self.soc <= 0.0:
            self.low = True
            return True
        return False
