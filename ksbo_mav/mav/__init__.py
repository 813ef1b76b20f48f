"""MAVLink client: one module per MAVLink service, wire details hidden behind small typed classes.

* :mod:`~ksbo_mav.mav.link` — connection (UDP listen/connect, TCP, serial), own ids, heartbeats, message pump;
* :mod:`~ksbo_mav.mav.tlog` — two-way .tlog writing and strict reading;
* :mod:`~ksbo_mav.mav.params` — parameters: complete download (PARAM protocol, MAVLink FTP, a cached set),
  set-and-verify, INT32 encodings, and the on-disk snapshots (.param, .params, .json) a restore reads;
* :mod:`~ksbo_mav.mav.commands` — COMMAND_LONG with acknowledgement, modes, arming, takeoff, landing;
* :mod:`~ksbo_mav.mav.stacks` — autopilot identity, parameter name generations, scale factors;
* :mod:`~ksbo_mav.mav.trajectory` — telemetry + logged setpoints -> :class:`ksbo_task.flight.Trajectory`;
* :mod:`~ksbo_mav.mav.monitor` — in-flight safety monitor;
* :mod:`~ksbo_mav.mav.mission` — figure-8 setpoint streaming (one trial);
* :mod:`~ksbo_mav.mav.vehicle` — preflight, whitelisted writes, restore: the vehicle as the tuner sees it;
* :mod:`~ksbo_mav.mav.trial_flight` — flying one trial and restoring the baseline (:class:`TrialFlight`);
* :mod:`~ksbo_mav.mav.trial_record` — scoring a flown trial and writing its record;
* :mod:`~ksbo_mav.mav.objective` — :class:`MavlinkObjective`, the vehicle behind the objective interface.

Their error types live in :mod:`ksbo_mav.errors`.
"""
