"""Exception types that the CLI turns into one-line messages and a non-zero exit code."""

from ksbo_sim.errors import SimInputError


class KsboError(Exception):
    """Base class of every error the user can cause or fix (bad input, unreachable vehicle, ...)."""


class InputError(KsboError, SimInputError):
    """Malformed or out-of-range input: gains, files, arguments (a ValueError, and a
    :class:`ksbo_sim.errors.SimInputError` so one ``except`` covers the simulator's input errors too)."""


class VehicleError(KsboError):
    """The vehicle did not answer, refused a command, or behaved unexpectedly."""


class UnsafeStartError(InputError):
    """The start point x0 evaluated below the safety threshold: safe optimisation cannot start there.

    Attributes:
        value: what ``fun(x0)`` returned (None if the trial aborted or crashed); p_min: the threshold.
    """

    def __init__(self, message: str, value: float | None = None, p_min: float = 0.0) -> None:
        super().__init__(message)
        self.value = value
        self.p_min = p_min


class ObjectiveError(InputError):
    """The user's objective returned something that is not a trial result (NaN, None, an array) or raised."""
