"""The small typed pieces of a :class:`~duffsym.diagnose.Diagnosis` and of the search that makes it.

- :class:`Candidate`: one catalogued effect added to the model and refitted, as the diagnosis judged it
  (re-exported by :mod:`duffsym.diagnose.search`).
- :class:`Split`, :class:`BaseCheck`, :class:`SindyCheck`: what a diagnosis reports about its split, its
  base fit and the SINDy cross-check. Each ``to_dict()`` gives the JSON of ``duffsym diagnose --json``
  (``docs/contract.md``); each also reads like that dict (``dg.split["n_fit"]``), for code written against it.
- :class:`FitOutcome`: what one candidate's fit returns (from a worker process too: it pickles).
- :class:`CandidateRun`: one candidate on its way through screening, a second start and continuation; a
  screened-out candidate carries ``status=Status.SCREENED_OUT`` and no fit.
- :class:`BaseEvidence`: the base model's free run and its errors, against which every candidate is judged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from duffsym.status import Status


class _ReadsAsDict(Mapping):
    """Reads like the dict of :meth:`to_dict` (``x["key"]``, ``x.get("key")``, ``dict(x)``)."""

    def to_dict(self) -> dict:  # pragma: no cover - every subclass defines it
        raise NotImplementedError

    def __getitem__(self, key: str):
        return self.to_dict()[key]

    def __iter__(self):
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())


@dataclass(frozen=True, eq=False)
class Split(_ReadsAsDict):
    """The fitting part (the first ``n_fit`` samples) and the held-out tail (from ``t_split``)."""

    n_fit: int
    n_heldout: int
    t_split: float

    def to_dict(self) -> dict:
        return {"n_fit": self.n_fit, "n_heldout": self.n_heldout, "t_split": self.t_split}

    def summary(self) -> str:
        return f"fitted on the first {self.n_fit} samples; {self.n_heldout} held out from t = {self.t_split:.4g} s"


@dataclass(frozen=True, eq=False)
class BaseCheck(_ReadsAsDict):
    """The base fit against its reference (a plain fit of the record, or the given fit).

    ``nrmse_fit_part`` and ``reference_nrmse_fit_part``: their free-run errors on the fitting part;
    ``start``: which start won; ``as_good``: the base within 5 % of the reference; ``budget``: which fits
    stopped on their share of the time budget; ``stable``/``stability``: the derived stability certificate at
    the base fit (None: not derivable for the model) and its failed conditions."""

    reference: str
    nrmse_fit_part: float
    reference_nrmse_fit_part: float
    start: str
    as_good: bool
    budget: tuple[str, ...] = ()
    stable: bool | None = None
    stability: str = ""

    def to_dict(self) -> dict:
        return {
            "reference": self.reference,
            "nrmse_fit_part": self.nrmse_fit_part,
            "reference_nrmse_fit_part": self.reference_nrmse_fit_part,
            "start": self.start,
            "as_good": self.as_good,
            "budget": list(self.budget),
            "stable": self.stable,
            "stability": self.stability,
        }

    def summary(self) -> str:
        s = (
            f"base fit (from the {self.start}): free-run NRMSE {self.nrmse_fit_part:.3g} on the fitting part, "
            f"{self.reference} {self.reference_nrmse_fit_part:.3g}" + ("" if self.as_good else " (base worse)")
        )
        if self.budget:
            s += f"; stopped by the time budget: {', '.join(self.budget)}"
        return s + ("; outside the stability certificate: " + self.stability if self.stable is False else "")


@dataclass(frozen=True, eq=False)
class SindyCheck(_ReadsAsDict):
    """The SINDy cross-check's evidence (:func:`duffsym.sindy.sindy_evidence`), or why it could not run.

    ``missing_terms``: the terms the data support that the model lacks (each a dict: term, source, effect,
    inclusion, coefficient, supported); ``absent_model_terms`` and ``reasons`` are None when the check did
    not run; ``extra``: any further keys of the evidence, kept as they came."""

    verdict: str
    conclusive: bool
    missing_terms: tuple = ()
    message: str = ""
    absent_model_terms: tuple | None = None
    reasons: tuple | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def from_evidence(cls, evidence: Mapping[str, Any]) -> SindyCheck:
        known = ("verdict", "conclusive", "missing_terms", "message", "absent_model_terms", "reasons")
        absent, reasons = evidence.get("absent_model_terms"), evidence.get("reasons")
        return cls(
            verdict=cast(str, evidence.get("verdict")),  # the evidence always has both keys
            conclusive=cast(bool, evidence.get("conclusive")),
            missing_terms=tuple(evidence.get("missing_terms", ())),
            message=evidence.get("message", ""),
            absent_model_terms=None if absent is None else tuple(absent),
            reasons=None if reasons is None else tuple(reasons),
            extra={k: v for k, v in evidence.items() if k not in known},
        )

    @classmethod
    def not_applicable(cls, why: str) -> SindyCheck:
        return cls(verdict="not applicable", conclusive=False, missing_terms=(), message=why)

    @property
    def supported_terms(self) -> list[dict]:
        """The missing terms that are evidence (``supported``), not hints."""
        return [m for m in self.missing_terms if m.get("supported")]

    def summary(self) -> str:
        return f"SINDy cross-check: {self.verdict}: {self.message}"

    def to_dict(self) -> dict:
        out = {"verdict": self.verdict, "conclusive": self.conclusive, "missing_terms": list(self.missing_terms)}
        if self.absent_model_terms is not None:
            out["absent_model_terms"] = list(self.absent_model_terms)
        if self.reasons is not None:
            out["reasons"] = list(self.reasons)
        out["message"] = self.message
        out.update(self.extra)
        return out


@dataclass(frozen=True)
class Candidate:
    """One catalogued effect added to the model and refitted."""

    effect: str
    nrmse_after: float  # held-out free-run NRMSE with the effect
    nrmse_after_fit: float  # free-run NRMSE on the fitting part
    nrmse_after_all: float  # over the whole record
    delta_bic: float
    improvement: float  # 1 - rmse_after / rmse_before on the held-out part
    explained: float  # share of the base model's excess held-out MSE removed
    params: dict  # the effect's own parameters
    stderr: dict
    all_params: dict
    success: bool
    message: str
    seconds: float
    supported: bool = False
    needed: bool = False
    physics: str = ""
    diverged: bool = False  # its free run failed or left the data's range (> DIVERGED x max|y|)
    stable: bool | None = None  # the fitted set satisfies the derived stability certificate (None: not checked)
    stability: str = ""  # the certificate's failed conditions, when it fails
    start: int = 1  # 2 when the second start (from the base solution) won

    def to_dict(self) -> dict:
        return dict(
            effect=self.effect,
            nrmse_after=self.nrmse_after,
            delta_bic=self.delta_bic,
            params=self.params,
            stderr=self.stderr,
            nrmse_after_fit=self.nrmse_after_fit,
            nrmse_after_all=self.nrmse_after_all,
            improvement=self.improvement,
            explained=self.explained,
            supported=self.supported,
            needed=self.needed,
            success=self.success,
            message=self.message,
            seconds=self.seconds,
            all_params=self.all_params,
            physics=self.physics,
            diverged=self.diverged,
            stable=self.stable,
            stability=self.stability,
            start=self.start,
        )


@dataclass(frozen=True)
class FitOutcome:
    """One candidate fit: its free-run sum of squares on the fitting part (inf when the free run diverged),
    the fit, the free run over the whole record (None when diverged), the seconds; or ``error`` (the message of
    a fit that raised on bad input, or that was not tried: ``status`` says which)."""

    ss: float = math.inf
    fit: Any = None
    y: np.ndarray | None = None
    seconds: float = 0.0
    error: str = ""
    status: Status | None = None

    @property
    def ok(self) -> bool:
        return not self.error


@dataclass(eq=False)
class CandidateRun:
    """One candidate effect's fit while the search screens, restarts and continues it (edited in place).

    ``model`` is the base model with ``effect`` added. Without a fit (``fit`` None), ``status`` says why:
    :attr:`Status.SCREENED_OUT`, :attr:`Status.TIME_LIMIT` (not tried: the time budget ran out) or
    :attr:`Status.UNKNOWN` (its fit raised); ``message`` says it in words."""

    name: str
    effect: Any
    model: Any
    ss: float = math.inf
    fit: Any = None
    y: np.ndarray | None = None
    seconds: float = 0.0
    status: Status | None = None
    message: str = ""

    @classmethod
    def from_outcome(cls, name: str, effect, model, got: FitOutcome) -> CandidateRun:
        return cls(name=name, effect=effect, model=model, ss=got.ss, fit=got.fit, y=got.y, seconds=got.seconds)

    @property
    def fit_status(self) -> Status:
        """The fit's status (IPOPT's), or why there is no fit."""
        return Status.parse(self.fit.status) if self.fit is not None else (self.status or Status.UNKNOWN)

    @property
    def converged(self) -> bool:
        return self.fit is not None and bool(self.fit.success)

    def take(self, got: FitOutcome) -> None:
        """Replace the fit by ``got``'s (its seconds added)."""
        self.ss, self.fit, self.y = got.ss, got.fit, got.y
        self.seconds += got.seconds

    def drop(self, status: Status, message: str) -> None:
        """No fit for this candidate: ``status`` and ``message`` say why."""
        self.fit, self.y, self.status, self.message = None, None, status, message


@dataclass(frozen=True)
class BaseEvidence:
    """The base model's free run ``y_base`` over the whole record, its held-out mean square error, its sum of
    squares and BIC on the fitting part (the first ``k`` samples)."""

    y_base: np.ndarray
    k: int
    mse_held: float
    ss_fit: float
    bic: float
