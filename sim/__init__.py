"""ksbo_sim: the planar quadrotor of Safe Control Gym (SCG), its PID controller and the figure-8 task.

Installed under the import name ``ksbo_sim`` (source directory ``sim/``). Everything is vectorised over a
leading batch axis so many gain vectors and initial conditions fly at once.
"""

from ksbo_sim.constants import QuadConstants, SCG_CRAZYFLIE
from ksbo_sim.episode import EpisodeConfig, Rollout, fixed_initial_states, random_initial_states, simulate
from ksbo_sim.figure8 import Figure8

__all__ = [
    "QuadConstants",
    "SCG_CRAZYFLIE",
    "EpisodeConfig",
    "Rollout",
    "Figure8",
    "simulate",
    "random_initial_states",
    "fixed_initial_states",
]
