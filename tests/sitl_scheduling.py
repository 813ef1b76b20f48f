"""pytest-xdist scheduling of this suite: never two real autopilots flying at once.

A SITL flight and the tuner that keeps up with it are the run's deadline-bound work (PX4 leaves OFFBOARD when the
setpoint stream pauses for COM_OF_LOSS_T of *its* time: 0.5 s of wall time at 5x); a second SITL flight beside it
doubles that load on a 2-core machine. ``tests/conftest.py`` names the xdist group of every test that flies one
with :data:`SITL_GROUP` first; :class:`OneSitlAtATime` hands a worker that asks for work while the other worker
still has such a group to run the first group that flies none instead (so both stay busy), and the next SITL group
once the other is done with its own.
"""

from __future__ import annotations

from xdist.scheduler import LoadGroupScheduling

#: The start of the xdist group name of a test that flies a SITL.
SITL_GROUP = "sitl:"


def _flies(scope: str) -> bool:
    return scope.startswith(SITL_GROUP)


class OneSitlAtATime(LoadGroupScheduling):
    """``--dist loadgroup`` (the queue order and groups as given), but a SITL group is not started on one worker
    while another worker has one unfinished, as long as a group that flies none is waiting."""

    def _assign_work_unit(self, node) -> None:
        elsewhere = any(_flies(scope) and not all(done.values())
                        for other, units in self.assigned_work.items() if other is not node
                        for scope, done in units.items())
        if elsewhere and _flies(next(iter(self.workqueue))):
            ground = next((scope for scope in self.workqueue if not _flies(scope)), None)
            if ground is not None:
                self.workqueue.move_to_end(ground, last=False)
        super()._assign_work_unit(node)
