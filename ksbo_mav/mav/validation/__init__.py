"""Validation flights: the manoeuvres pilots fly (position steps, the autopilot's position hold, a waypoint mission
flown by its own navigation), flown and measured on one gain set; none is given to the optimiser.

``fly_manoeuvre(vehicle, ManoeuvreSpec.from_dict(kind, table), monitor, gains_label=..., tlog_path=...)`` ->
:class:`ManoeuvreFlight` (outcome, figures, tlog). The figures' definitions: :mod:`ksbo_task.manoeuvre_metrics`;
their names: :meth:`ManoeuvreRecorder.metrics`; re-computed from a tlog by :func:`recorders_from_tlog`.
"""

from ksbo_mav.mav.validation.manoeuvre_flight import ManoeuvreFlight, fly_manoeuvre
from ksbo_mav.mav.validation.manoeuvre_recorder import ManoeuvreRecorder, recorders_from_tlog
from ksbo_mav.mav.validation.manoeuvre_spec import HEADLINE, KINDS, ManoeuvreSpec

__all__ = ["HEADLINE", "KINDS", "ManoeuvreFlight", "ManoeuvreRecorder", "ManoeuvreSpec", "fly_manoeuvre",
           "recorders_from_tlog"]
