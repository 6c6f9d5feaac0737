"""Exceptions and warnings raised by duffsym.

Every error message says what is wrong, where, and what to do about it.
"""
from __future__ import annotations


class DuffsymError(Exception):
    """Base class of every error duffsym raises on purpose."""


class ModelError(DuffsymError, ValueError):
    """A model is ill-defined: unknown symbol, wrong structural integer, bad parameter."""


class DataError(DuffsymError, ValueError):
    """Input data (a record, an excitation, a file) is unusable as given."""


class SimulationError(DuffsymError, RuntimeError):
    """A simulation could not be completed (blow-up, excessive stiffness).

    Attributes
    ----------
    trajectory : the partial :class:`~duffsym.simulate.Trajectory`, or None
    """

    def __init__(self, message: str, trajectory=None):
        super().__init__(message)
        self.trajectory = trajectory


class ConvergenceWarning(UserWarning):
    """Suspicious but usable numerical situation."""
