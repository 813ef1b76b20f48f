"""Why a cell did not give a record. A cell that ends with the vehicle crashed or a trial aborted is a result, not
an error: its kind returns it as a record."""


class InfraError(RuntimeError):
    """The infrastructure failed, not the gains: a SITL that did not boot, a simulator process that died, a port
    taken, a node lost. The runner runs the cell again (``--retries``)."""


class CellError(RuntimeError):
    """The cell's own code failed (a bug, a bad option): said once with the cell's key, not retried, not stored,
    so the next run tries it again."""


class SweepError(ValueError):
    """A sweep file that cannot be read or declares something the runner cannot run (one line, no traceback)."""


class NotYet(SweepError):
    """A cell's input is another cell's record that is not in its store yet (a warm start's earlier campaign, a
    reference campaign): the driver runs the cells that can run first, then tries again; said if none can."""
