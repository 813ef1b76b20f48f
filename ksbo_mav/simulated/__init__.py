"""Objectives flown in process on the built-in simulators (``ksbo_sim``): the planar task (``planar_objective``)
and the JSBSim 3-D copter (``copter_objective``).

The only part of the tuner, with the commands that start a simulator, that imports ``ksbo_sim``: the MAVLink client
and the campaign never load a simulator, except where a campaign computes its simulated prior (a deferred import
in ``ksbo_mav.campaign.prior``).
"""
