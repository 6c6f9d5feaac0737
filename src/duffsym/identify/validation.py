"""Free-run validation of a fitted parameter set on another record (the paper's Fig. 9)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from duffsym._json import finite_or_none
from duffsym.data.record import Record
from duffsym.identify.problem import check_command
from duffsym.identify.result import IdentificationResult, nrmse
from duffsym.identify.states import start_state
from duffsym.simulate import simulate_record


@dataclass(frozen=True, eq=False)
class ValidationResult:
    """Free-run error of a fit on a record.

    Attributes
    ----------
    nrmse : RMS(y - yhat) / RMS(y - mean y). ``rmse`` in the output's units; ``r2 = 1 - nrmse**2``.
    y_sim : (n_times,) the simulated output. ``x0`` the initial state used.
    success, message : judged as :func:`~duffsym.identify.fit` judges a fit: the free run completed and
        predicts better than the record's mean (R² >= 0); the message says why not, or notes an initial
        state that had to be kept in range.
    effects : the effects added to the base ``model``.
    """

    record: str
    model: str
    nrmse: float
    rmse: float
    r2: float
    success: bool
    message: str
    x0: tuple = ()
    y_sim: np.ndarray = field(default_factory=lambda: np.zeros(0))
    integrator: dict = field(default_factory=dict)
    effects: tuple = ()

    def to_dict(self) -> dict:
        return {
            "record": self.record,
            "model": self.model,
            "effects": list(self.effects),
            "nrmse": finite_or_none(self.nrmse),
            "rmse": finite_or_none(self.rmse),
            "r2": finite_or_none(self.r2),
            "success": bool(self.success),
            "message": self.message,
            "x0": [float(v) for v in self.x0],
            "integrator": dict(self.integrator),
        }

    def summary(self) -> str:
        name = self.model + "".join(f" + {e}" for e in self.effects)
        head = f"validation of {name} on {self.record}: "
        scores = f"free-run NRMSE {self.nrmse:.4g}, RMSE {self.rmse:.4g}, R2 {self.r2:.5g}"
        if not self.success:
            return head + f"FAILED: {self.message}" + (f" ({scores})" if math.isfinite(self.nrmse) else "")
        how = self.integrator.get("method", "rk4")
        note = "" if how == "rk4" else f" (integrated by {how}: {self.integrator.get('reason', '')})"
        extra = "" if self.message == "ok" else f"; {self.message}"
        return head + scores + note + extra


def model_from_result(result: IdentificationResult):
    """The model of a fit: the object it ran with, or rebuilt from its saved ``model_spec`` (any model), or, for
    a file written before ``model_spec``, from its name, structural powers and effects
    (:attr:`IdentificationResult.model_obj`)."""
    return result.model_obj


def validate(result: IdentificationResult, record: Record, model=None, *, group: str | None = None) -> ValidationResult:
    """Simulate the fitted model on ``record``'s input and compare with its output.

    The initial state is not measured: it is started from the data as in the fit
    (:func:`~duffsym.identify.initial_states`) and refined by least squares on the output over the
    first input period (at most 1000 samples), so no start-up transient pollutes the error.

    Parameters
    ----------
    result : a fit (from :func:`~duffsym.identify.fit` or :func:`~duffsym.identify.load_result`).
    record : the record to validate on.
    model : the fitted model; rebuilt from ``result`` when None.
    group : for a fit with groups, the group whose parameters to use; by default the record's
        current (``"0.5A"``) or voltage (``"0.4V"``) label.
    """
    model = model if model is not None else model_from_result(result)
    check_command(model, [record])
    if group is None:
        group = result.group_for(record)
    p = model.param_vector(result.params_for(group))
    x0, note = start_state(model, p, record)
    # simulate_record's signature does not list ndarray (which it takes) yet
    tr = simulate_record(model, p, record, x0=cast("Sequence[float]", x0), on_failure="return")
    y_sim = np.asarray(tr.y, dtype=float)
    effects = tuple(model.effects)
    if not tr.success:
        return ValidationResult(
            record.name,
            model.name,
            math.inf,
            math.inf,
            -math.inf,
            False,
            f"the free run failed: {tr.message}",
            tuple(map(float, x0)),
            y_sim,
            tr.integrator,
            effects,
        )
    rmse = float(np.sqrt(np.mean((np.asarray(record.y) - y_sim) ** 2)))
    err = nrmse(record.y, y_sim)
    r2 = 1 - err**2
    ok = r2 >= 0
    message = note or "ok"
    if not ok:
        message = (
            f"the prediction is worse than the record's mean (R2 {r2:.3g} < 0): the fit does not describe "
            "this record (another operating point, a level or unit difference, or a missing effect)"
            + (f"; {note}" if note else "")
        )
    return ValidationResult(
        record.name, model.name, err, rmse, r2, ok, message, tuple(map(float, x0)), y_sim, tr.integrator, effects
    )
