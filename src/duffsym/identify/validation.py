"""Free-run validation of a fitted parameter set on another record (the paper's Fig. 9)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from duffsym._json import finite_or_none
from duffsym.data.record import Record
from duffsym.identify.problem import check_command
from duffsym.identify.result import IdentificationResult, nrmse
from duffsym.identify.states import driven_states, initial_states
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


def start_state(model, p, record: Record) -> tuple[np.ndarray, str]:
    """The initial state of a free run of ``model`` with parameters ``p`` on ``record`` and a note ("" when
    none): started from the data as in the fit and refined over the first input period (see :func:`validate`)."""
    X = initial_states(model, record, p)
    return _bounded_x0(_estimate_x0(model, p, record, X[0]), X)


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
    tr = simulate_record(model, p, record, x0=x0, on_failure="return")
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


#: The estimated initial state may lie this many times the range of the data-based states beyond that range.
X0_RANGE = 2.0


def _bounded_x0(x0, X) -> tuple[np.ndarray, str]:
    """``x0`` if every state lies within :data:`X0_RANGE` times the range of its data-based trajectory ``X``
    around it; else the data-based start ``X[0]`` and a note (an initial state far outside what the record's
    states span fits a level difference, not a start-up: measured, -5.7e6 made the prediction the flat mean)."""
    x0 = np.asarray(x0, dtype=float)
    lo, hi = np.min(X, axis=0), np.max(X, axis=0)
    span = hi - lo  # a state the data say nothing about (started at 0) is not bounded
    out = (span > 0) & ((x0 < lo - X0_RANGE * span) | (x0 > hi + X0_RANGE * span))
    if not np.any(out):
        return x0, ""
    return np.asarray(X[0], dtype=float), (
        f"the initial state estimated from the first period ({', '.join(f'{v:.3g}' for v in x0[out])}) lay far outside "
        "the range of the record's states (it would absorb a level difference): the free run starts from the data"
    )


def _estimate_x0(model, p, record, guess):
    """Initial state minimising the output error over the first input period."""
    from scipy.optimize import least_squares

    from duffsym.simulate import simulate

    try:
        period = record.period
    except (IndexError, ZeroDivisionError, ValueError):
        period = record.duration
    n = int(min(record.n_times, max(50, np.searchsorted(record.t, record.t[0] + period)), 1000))
    t = np.asarray(record.t[:n])
    U = record.input_matrix(model)
    chans = {c.name: U[:n, j] for j, c in enumerate(model.inputs)}
    y = np.asarray(record.y[:n])
    ref = simulate(model, p, t, chans, x0=guess, on_failure="return")
    if not ref.success:
        return np.asarray(guess, dtype=float)
    # fixed substeps: the discretisation must not change while differencing
    sub = int(min(max(int(ref.substeps.max()), 1) * 2, 200))
    scale = np.maximum(np.abs(guess), 1e-3 * max(1.0, float(np.max(np.abs(guess)))))

    def resid(z):
        tr = simulate(model, p, t, chans, x0=z * scale, substeps=sub, method=ref.method, on_failure="return")
        r = tr.y - y
        return np.where(np.isfinite(r), r, 1e6)

    keep = sorted(driven_states(model, record, p))  # input-driven states (the field) start at their equilibrium
    free = np.array([j for j in range(len(guess)) if j not in keep], dtype=int)
    z0 = np.asarray(guess, dtype=float) / scale

    def full(zf):
        z = z0.copy()
        z[free] = zf
        return z

    sol = least_squares(lambda zf: resid(full(zf)), z0[free], method="lm", max_nfev=200)
    sol.x = full(sol.x)
    x0 = sol.x * scale
    return x0 if np.sum(resid(sol.x) ** 2) <= np.sum(resid(np.asarray(guess) / scale) ** 2) else np.asarray(guess)
