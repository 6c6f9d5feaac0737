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


def show_notes(stream=None) -> None:
    """Print duffsym's own warnings as one line each, ``note: <message>``, on stderr.

    Python's default shows a warning as two lines with the file, line number and source line of the
    ``warnings.warn`` call: noise for a user, for whom a :class:`ConvergenceWarning` is an expected
    numerical condition the package reports. Other packages' warnings keep the default form. Called
    when ``duffsym`` is imported (so API users see the same notes), by the command line and the
    studies; idempotent.
    """
    import sys
    import warnings

    if getattr(warnings.showwarning, "_duffsym_notes", False):
        return
    default = warnings.showwarning

    def showwarning(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, ConvergenceWarning) or (
            issubclass(category, UserWarning) and "duffsym" in str(filename).replace("\\", "/")
        ):
            out = file or stream or sys.stderr
            try:
                out.write(f"note: {' '.join(str(message).split())}\n")
            except (OSError, ValueError):
                pass
            return
        default(message, category, filename, lineno, file, line)

    showwarning._duffsym_notes = True  # type: ignore[attr-defined]  # the mark show_notes() looks for
    warnings.showwarning = showwarning
