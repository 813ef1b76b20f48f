"""Exception types that the CLI turns into one-line messages and a non-zero exit code."""


class KsboError(Exception):
    """Base class of every error the user can cause or fix (bad input, unreachable vehicle, ...)."""


class InputError(KsboError, ValueError):
    """Malformed or out-of-range input: gains, files, arguments."""


class VehicleError(KsboError):
    """The vehicle did not answer, refused a command, or behaved unexpectedly."""
