"""Exception types of the simulator package. ``ksbo_sim`` never imports ``ksbo_mav``; the tuner's CLI prints these
as one line, like its own errors."""


class SimError(Exception):
    """Base class of every error the user can cause or fix when running a simulator."""


class SimInputError(SimError, ValueError):
    """Malformed or out-of-range simulator input: options, parameter files, ``--set`` values."""


class SimStartError(SimError):
    """A simulator process did not start (no ready line), or stopped before it was ready."""
