"""One step of a derivation report (:class:`ReportItem`), shared by :mod:`duffsym.derive.report` and the
coupled derivations of :mod:`duffsym.derive.coupled`, which the report collects."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class ReportItem:
    """One step of the derivation.

    Attributes
    ----------
    key : machine name (``"lyapunov_energy"``).
    title : heading for people.
    equation : the paper's equation number(s) it reproduces (``"Eq. 8"``), or ``""``.
    text : the result as plain text (``sp.sstr``), one statement per line.
    latex : the result as LaTeX display math, lines separated by ``\\\\``.
    note : what it means, in words.
    data : JSON-able content (expressions as strings).
    """

    key: str
    title: str
    equation: str
    text: str
    latex: str
    note: str = ""
    data: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "key": self.key,
            "title": self.title,
            "equation": self.equation,
            "text": self.text,
            "latex": self.latex,
            "note": self.note,
            "data": self.data,
        }
