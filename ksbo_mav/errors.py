"""Exception types that the CLI turns into one-line messages and a non-zero exit code.

This module imports nothing of the package (every layer, the optimiser core included, raises these); the
simulator's own errors (``ksbo_sim.errors``) are turned into these by the commands that run a simulator.
"""

from typing import Any


class KsboError(Exception):
    """Base class of every error the user can cause or fix (bad input, unreachable vehicle, ...)."""


class InputError(KsboError, ValueError):
    """Malformed or out-of-range input: gains, files, arguments (a ValueError)."""


class CampaignPaused(KsboError):
    """A normal stop that the user resumes (a pack to swap, an autopilot failsafe): the vehicle is left safe, the
    report written; the message says why and how to go on. Exit code 3, not an error."""


class VehicleError(KsboError):
    """The vehicle did not answer, refused a command, or behaved unexpectedly."""


class VerifyError(VehicleError):
    """A parameter write was not confirmed by the vehicle (no echo, or a different value echoed)."""


class LinkLost(VehicleError):
    """No heartbeat / telemetry from the vehicle for longer than the profile's timeout."""


class ClockStalled(VehicleError):
    """The vehicle's clock did not advance for longer than the stall timeout (no timestamped telemetry)."""


class PreflightError(VehicleError):
    """Arming, takeoff or positioning failed: nothing to do with the gains being tuned."""


class PilotTookOver(VehicleError):
    """Between trials the vehicle went to a mode ksbo-mav did not set, or was disarmed (the pilot or a ground
    station): the campaign stops and leaves the vehicle alone."""


class TrialStopped(VehicleError):
    """A trial was aborted for a reason that must stop the campaign (pilot, link, crash of a real vehicle);
    ``flight`` is its recorded result (a :class:`ksbo_task.flight.Flight`). ``retry``: not the gains' doing and the
    vehicle is ready again (this computer fell behind, the link came back): the trial may be flown again instead."""

    def __init__(self, message: str, flight: Any, retry: bool = False) -> None:
        super().__init__(message)
        self.flight = flight
        self.retry = retry


class TrialInterrupted(KeyboardInterrupt):
    """Ctrl-C during a trial, raised once the trial is recorded (its baseline restored unless a second Ctrl-C
    stopped that); ``flight`` is its recorded result (a :class:`ksbo_task.flight.Flight`). A KeyboardInterrupt:
    whatever stops on Ctrl-C stops here."""

    def __init__(self, flight: Any) -> None:
        super().__init__("interrupted by the user")
        self.flight = flight


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
