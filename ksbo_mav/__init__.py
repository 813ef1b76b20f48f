"""ksbo-mav: safe Bayesian optimisation of multicopter PID gains with kernel selection, over MAVLink."""

__version__ = "0.1.0"

from ksbo_mav.optimize import optimize  # noqa: E402  (public API; imports numpy/scipy lazily enough)

__all__ = ["optimize", "__version__"]
