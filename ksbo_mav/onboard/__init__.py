"""Scripts that run on the vehicle: ``ksbo_guard.lua``, the onboard guard (ArduPilot Lua), shipped as package data
and rendered and uploaded by :mod:`ksbo_mav.mav.onboard_guard`."""
