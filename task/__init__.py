"""ksbo_task: the task a tuning flight flies, shared by a real flight and a simulated one.

Installed under the import name ``ksbo_task`` (source directory ``task/``); it needs numpy only and imports
neither the tuner (``ksbo_mav``) nor the simulators (``ksbo_sim``), so the MAVLink client loads no simulator and the
simulators fly exactly the reference, limits and starts the client flies. Modules: ``figure8`` (the planar x-z
figure-8), ``figure8_ne`` (the 3-D copter's horizontal figure-8), ``lead_in`` (starting a pattern from rest),
``monitor`` (abort limits, their checks and a flight's outcome), ``starts`` (the planar task's start draws),
``flight`` (the flown trajectory and the result of flying one gain vector).
"""
