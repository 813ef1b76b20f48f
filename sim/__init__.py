"""ksbo_sim: the planar quadrotor of Safe Control Gym (SCG) and its PID controller flying the figure-8 task
(the reference, limits and starts are the task package's, ``ksbo_task``).

Installed under the import name ``ksbo_sim`` (source directory ``sim/``). Everything is vectorised over a
leading batch axis so many gain vectors and initial conditions fly at once.
"""

from ksbo_sim.constants import QuadConstants, SCG_CRAZYFLIE
from ksbo_sim.episode import EpisodeConfig, Rollout, simulate

__all__ = [
    "QuadConstants",
    "SCG_CRAZYFLIE",
    "EpisodeConfig",
    "Rollout",
    "simulate",
]
