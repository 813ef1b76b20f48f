"""The conditions each flight flew in, kept with its journal entry: the wind the autopilot estimates and streams
(``WIND`` on ArduPilot, ``WIND_COV`` on PX4), or, when its parameters say it estimates none
(:func:`~ksbo_mav.mav.wind_source.wind_estimated`: an ArduCopter without drag fusion streams a 0 whatever blows),
``wind_estimated`` false, no wind figure, and the wind inferred from the flight's own telemetry where it can be
(:mod:`ksbo_mav.flightlog.wind_fit`, labelled as inferred); the battery voltage; the flight index."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ksbo_mav.mav.vehicle import Vehicle


class ConditionWatch:
    """Listens for the autopilot's wind estimate on ``v``'s link; :meth:`take` ends one trial's record. A vehicle
    whose parameters say it does not estimate the wind (:func:`~ksbo_mav.mav.wind_source.wind_estimated`) gets
    ``wind_estimated`` false and no wind figure: its streamed zero is not a measurement."""

    def __init__(self, v: Vehicle) -> None:
        from ksbo_mav.mav.wind_source import wind_estimated

        self.v = v
        self._speeds: list[float] = []
        self.estimated = wind_estimated(v.stack.name, {n: p.value for n, p in v.params.table.items()})
        self.drag: tuple[float, float] | None = None  # drag coefficients of the last flight that fitted them
        v.link.handlers.append(self._on_message)

    def _on_message(self, msg: Any) -> None:
        if not self.v.link.is_vehicle(msg):
            return
        kind = msg.get_type()
        if kind == "WIND":
            speed = float(msg.speed)
        elif kind == "WIND_COV":
            speed = math.hypot(float(msg.wind_x), float(msg.wind_y))
        else:
            return
        if math.isfinite(speed):
            self._speeds.append(speed)

    def start(self) -> None:
        """A trial begins: the wind heard before it is not its wind."""
        self._speeds = []

    def take(self, flight_index: int, tlog: Path | None = None) -> dict[str, Any]:
        """This trial's conditions: mean and largest wind (m/s), battery voltage (V) now, the flight index; for a
        vehicle that does not estimate the wind, the wind inferred from the flight's ``tlog`` where it can be
        (:func:`infer_wind`)."""
        s = self._speeds if self.estimated is not False else []
        self._speeds = []
        cond: dict[str, Any] = {"flight": int(flight_index),
                                "wind_mps": round(sum(s) / len(s), 3) if s else None,
                                "wind_max_mps": round(max(s), 3) if s else None,
                                **({} if self.estimated is None else {"wind_estimated": self.estimated}),
                                "voltage_v": self.v.power.reading().voltage_v}
        if self.estimated is False and tlog is not None:
            cond.update(self.infer_wind(tlog))
        return cond

    def infer_wind(self, tlog: Path) -> dict[str, Any]:
        """The wind inferred from a flight's telemetry (:mod:`ksbo_mav.flightlog.wind_fit`): the drag fit where the
        ground velocity varied (its coefficients kept), else the lean angle that held the vehicle in place with the
        last coefficients; nothing when neither can tell."""
        from ksbo_mav.flightlog.wind_fit import fit_wind, tlog_series, wind_from_lean

        try:
            t, vel, att = tlog_series(tlog)
        except Exception:  # noqa: BLE001 - a log that cannot be read infers nothing; the flight's record stands
            return {}
        fit = fit_wind(t, vel, att) if t.size else None
        how = "drag fit of the lean angle against the ground velocity"
        if fit is not None:
            self.drag = (fit.c_lin, fit.c_quad)
        elif self.drag is not None and t.size:
            fit = wind_from_lean(t, vel, att, *self.drag)
            how = "lean angle holding position, drag fitted on an earlier flight"
        if fit is None:
            return {}
        return {"wind_inferred_mps": round(fit.speed, 2), "wind_inferred_from_deg": round(fit.from_deg),
                "wind_inferred_how": how}
