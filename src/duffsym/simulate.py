"""Simulation of a model: compiled stiffness-aware RK4, and a Radau reference.

With the paper's Table 2 values (n = 5, c3 ~ 300) the local stiffness at peak velocity puts a
single RK4 step of dt = 0.005 s past its stability limit, so the number of RK4 substeps per
sample interval is chosen from the spectral radius of the state Jacobian (generated from the
model): :math:`h\\,\\rho(J) \\le` ``h_lambda`` at both ends of the interval. The count is
predicted from the stiffness at the start, extrapolated along its trend over the previous
interval; a step whose end state is stiffer than the count allows is redone with more substeps
(an under-resolved step under-estimates the stiffness, as at an impulsive start). Blow-up
(non-finite or huge states) and excessive stiffness stop the run and are reported.

The explicit runs of :func:`simulate` go through one integrator compiled once
(:mod:`duffsym.codegen.generic`), which calls the model's generated functions through pointers: a new
model (every candidate of a diagnosis is one) compiles only those, 3-8x faster than its own inlined
integrator, for a run 2-4x slower. :func:`simulate_batch` runs the same integrator over parameter sets in
parallel (a grid search of starts runs it for every new model; its own parallel kernel took 5-8 s to compile
per model), and the implicit ROS2 runs go through that module too; only the sampler keeps an inlined
integrator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from duffsym._checks import require_increasing
from duffsym._typing import Float1D, Float2D
from duffsym.errors import DataError, ModelError, SimulationError
from duffsym.excitation import Excitation
from duffsym.model.core import SymbolicModel
from duffsym.options import resolve
from duffsym.status import Status

#: Default stiffness target h*rho(J) per RK4 substep, at both ends of each sample interval (RK4's
#: real-axis stability limit is 2.785). 0.6 keeps the Table 2 trajectories (2 Hz, unit amplitude,
#: dt 0.005 s, from rest) within 4e-4 of the Radau reference, maximum relative — see benchmarks/.
H_LAMBDA = 0.6
MAX_SUBSTEPS = 5000
BLOWUP = 1e8
#: The compiled integrators' status codes as :class:`~duffsym.status.Status` members (the strings "ok",
#: "blow-up", "too stiff" of the JSON outputs).
STATUS_MESSAGES = {0: Status.OK, 1: Status.BLOW_UP, 2: Status.TOO_STIFF}
METHODS = ("auto", "rk4", "rosenbrock", "radau")
#: Error tolerances of the compiled implicit integrator (ROS2, second order): scaled RMS of the
#: embedded error per step. At these values the Dyke record's free run agrees with the Radau
#: reference to 3.5e-4 of the force's standard deviation (RK4 at h*rho <= 0.6 elsewhere: 1.5e-3);
#: it costs far more than an RK4 run (it runs only when RK4 stops); 1e-5 gives 3e-5 at a higher cost
#: (the costs: benchmarks/bench_stiff.py and its results).
IMPLICIT_RTOL = 1e-4
IMPLICIT_ATOL = 1e-7
#: Step attempts the implicit integrator may take within one sample interval (its own budget: it
#: is the fallback when the RK4 substep budget ``max_substeps`` is exceeded).
IMPLICIT_MAX_STEPS = 20000
RECONSTRUCTIONS = ("linear", "hold")


@dataclass(frozen=True)
class Trajectory:
    """Result of a simulation. Arrays are time-first.

    Attributes
    ----------
    t : (n_times,) s
    x : (n_times, n_states) states
    y : (n_times,) output
    u : (n_times, n_inputs) inputs as used
    params : parameter values by name
    success, status, message : outcome (status a :class:`~duffsym.status.Status`: ``"ok"``, ``"blow-up"`` or
        ``"too stiff"``)
    substeps : (n_times - 1,) RK4 substeps used per sample interval (empty for Radau)
    failed_at : index of the first failed sample, or -1
    input_names, state_names, output_name : the model's channel names (columns of u, x; y)
    """

    model: str
    t: Float1D
    x: Float2D
    y: Float1D
    u: Float2D
    params: dict
    success: bool
    status: Status
    message: str
    method: str
    substeps: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    failed_at: int = -1
    input_names: tuple[str, ...] = ()
    state_names: tuple[str, ...] = ()
    output_name: str = "y"
    fallback: str = ""

    @property
    def integrator(self) -> dict:
        """Which integrator produced the trajectory and why: ``{"method": str, "reason": str}``."""
        reason = self.fallback or (
            "requested"
            if self.method in ("rosenbrock", "radau")
            else "default explicit path (accurate at this stiffness)"
        )
        return {"method": self.method, "reason": reason}

    def raise_for_status(self) -> Trajectory:
        """Raise :class:`SimulationError` if the simulation failed; return self otherwise."""
        if not self.success:
            raise SimulationError(self.message, trajectory=self)
        return self

    def summary(self) -> str:
        sub = f", substeps {int(self.substeps.min())}..{int(self.substeps.max())}" if self.substeps.size else ""
        return (
            f"{self.model}: {self.t.size} samples over {self.t[-1] - self.t[0]:g} s, {self.method}{sub}; "
            f"{self.status}"
            + ("" if self.success else f": {self.message}")
            + (f" [{self.fallback}]" if self.fallback else "")
        )


def check_time(t) -> np.ndarray:
    """A validated time vector: 1-D, finite, strictly increasing, at least 2 samples."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise DataError(f"t must be a 1-D array of at least 2 sample times; got shape {t.shape}")
    # fast path: strictly increasing with finite ends implies every sample is finite (NaN fails >)
    if (t[1:] > t[:-1]).all() and math.isfinite(t[0]) and math.isfinite(t[-1]):
        return t
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise DataError(f"t has {bad.size} non-finite value(s), first at index {bad[0]}; remove or fill them")
    require_increasing(t, "t")
    return t


def input_matrix(
    model: SymbolicModel, t: np.ndarray, inputs: Excitation | Mapping[str, Sequence[float] | np.ndarray] | np.ndarray
) -> np.ndarray:
    """The model's input matrix ``(n_times, n_inputs)`` from an excitation, a mapping or an array."""
    if isinstance(inputs, Excitation):
        return _excitation_matrix(model, t, inputs)
    elif isinstance(inputs, Mapping):
        cols = []
        for ch in model.inputs:
            if ch.name not in inputs:
                raise DataError(
                    f"model {model.name} needs input {ch.name!r}; got {sorted(inputs)}; "
                    "give every channel or pass an Excitation"
                )
            col = np.asarray(inputs[ch.name], dtype=float)
            if col.shape != t.shape:
                raise DataError(f"input {ch.name!r} must have shape (n_times,) = ({t.size},) like t; got {col.shape}")
            cols.append(col)
        U = np.column_stack(cols)
    else:
        U = np.asarray(inputs, dtype=float)
        if U.ndim == 1 and model.n_inputs == 1:
            U = U[:, None]
    if U.shape != (t.size, model.n_inputs):
        raise DataError(
            f"inputs must have shape (n_times, n_inputs) = ({t.size}, {model.n_inputs}) for channels "
            f"{[c.name for c in model.inputs]}; got {U.shape}"
        )
    if not np.isfinite(U).all():
        i, j = np.argwhere(~np.isfinite(U))[0]
        raise DataError(f"input {model.inputs[j].name} is not finite at index {i} (t={t[i]:g} s); clean the input")
    return np.ascontiguousarray(U)


_EXCITATION_CACHE: dict = {}
_EXCITATION_CACHE_SIZE = 16


def _excitation_matrix(model: SymbolicModel, t: np.ndarray, exc: Excitation) -> np.ndarray:
    """``exc.channels(t, model)``, checked, remembered for repeated calls with the same excitation and
    times (fits and samplers simulate one input thousands of times, and evaluating the sines each time
    would repeat the same work)."""
    try:
        key = (exc, tuple(c.order for c in model.inputs), t.tobytes())
        hit = _EXCITATION_CACHE.get(key)
    except TypeError:  # an unhashable user-defined excitation
        key, hit = None, None
    if hit is not None:
        return hit.copy()
    U = np.ascontiguousarray(exc.channels(t, model), dtype=float)
    if U.shape != (t.size, model.n_inputs):
        raise DataError(
            f"excitation {type(exc).__name__} gave inputs of shape {U.shape}; "
            f"expected ({t.size}, {model.n_inputs}); fix its channels()"
        )
    if not np.isfinite(U).all():
        i, j = np.argwhere(~np.isfinite(U))[0]
        raise DataError(
            f"excitation {type(exc).__name__}: input {model.inputs[j].name} is not finite at "
            f"index {i} (t={t[i]:g} s); check its parameters"
        )
    if key is not None:
        if len(_EXCITATION_CACHE) >= _EXCITATION_CACHE_SIZE:
            _EXCITATION_CACHE.pop(next(iter(_EXCITATION_CACHE)))
        _EXCITATION_CACHE[key] = U.copy()
    return U


def _failure_message(model, status, k, t, h_lambda, max_substeps, blowup, method="rk4"):
    if method == "rosenbrock":
        if status == 1:
            return (
                f"model {model.name}: the simulation blew up at t={t[k]:.6g} s (sample {k} of {t.size}) with the "
                f"implicit integrator (ROS2, error-controlled): a state became non-finite or exceeded {blowup:g}, "
                "so the trajectory itself diverges; the parameter set is probably unstable "
                "(check duffsym.derive.stability_certificate) or the input too large"
            )
        return (
            f"model {model.name}: the implicit integrator's step size collapsed at t={t[k]:.6g} s (sample {k} of "
            f"{t.size}; more than {IMPLICIT_MAX_STEPS} steps in one sample interval) without the state growing: "
            "the right-hand side is too stiff or too rough for the error control (a near-discontinuous term?)"
        )
    if status == 1:
        return (
            f"model {model.name}: the simulation blew up at t={t[k]:.6g} s (sample {k} of {t.size}): "
            f"a state became non-finite or exceeded {blowup:g}; the parameter set is probably unstable "
            "(check duffsym.derive.stability_certificate) or the input too large"
        )
    return (
        f"model {model.name}: the simulation became too stiff at t={t[k]:.6g} s (sample {k} of {t.size}): "
        f"it needed more than max_substeps={max_substeps} RK4 substeps per sample to keep "
        f"h*rho(J) <= {h_lambda:g}; the trajectory is probably diverging, else raise max_substeps"
    )


@dataclass(frozen=True)
class SimulateOptions:
    """The settings of :func:`simulate` (every field has the default ``simulate`` uses; pass the object as
    ``simulate(model, params, t, inputs, options=opts)`` or any field as a keyword,
    ``simulate(model, params, t, inputs, method="rk4")``). The fields are described under :func:`simulate`."""

    method: str = "auto"
    substeps: int | str = "auto"
    h_lambda: float = H_LAMBDA
    max_substeps: int = MAX_SUBSTEPS
    reconstruction: str = "linear"
    blowup: float = BLOWUP
    rtol: float = 1e-10
    atol: float = 1e-12
    on_failure: str = "raise"


_DEFAULT_OPTIONS = SimulateOptions()


def simulate(
    model: SymbolicModel,
    params: Mapping[str, float] | Sequence[float] | np.ndarray,
    t,
    inputs: Excitation | Mapping[str, Sequence[float] | np.ndarray] | np.ndarray,
    *,
    x0: Sequence[float] | np.ndarray | None = None,
    options: SimulateOptions | None = None,
    **settings,
) -> Trajectory:
    """Simulate ``model`` with ``params`` at sample times ``t``.

    Parameters
    ----------
    model : the symbolic model (its compiled form is generated and cached on first use).
    params : values by name (all of them) or an ordered vector.
    t : (n_times,) sample times, s; need not be uniform.
    inputs : an :class:`~duffsym.excitation.Excitation` (exact derivatives), a mapping from
        channel name (``"d"``, ``"d_dot"``) to samples, or an array ``(n_times, n_inputs)``.
    x0 : initial state (default zeros).
    options : the integrator settings below, a :class:`SimulateOptions` (default: its defaults).
    **settings : any :class:`SimulateOptions` field by name, replacing that field of ``options``; an
        unknown name raises :class:`TypeError`:

    method : ``"auto"`` (default): the compiled stiffness-aware RK4, and if it stops (blow-up or too
        stiff) the run is redone with the compiled implicit ROS2 integrator and the trajectory's
        ``fallback`` says why; a failure of both is a divergence of the trajectory itself.
        ``"rk4"`` (explicit only), ``"rosenbrock"`` (implicit only: L-stable, error-controlled, or
        ``substeps`` equal steps per sample when fixed) or ``"radau"`` (scipy reference, slow, accurate).
    substeps : ``"auto"`` (from the local stiffness) or a fixed number of RK4 substeps per sample;
        keep it fixed while finite-differencing, so the discretisation does not change with θ.
    h_lambda : target :math:`h\\rho(J)` per substep in auto mode.
    reconstruction : how the sampled input is reconstructed between samples: ``"linear"`` or
        ``"hold"`` (zero-order hold).
    blowup : magnitude of a state taken as blow-up.
    rtol, atol : tolerances of the Radau reference (the implicit ROS2 uses IMPLICIT_RTOL/IMPLICIT_ATOL).
    on_failure : ``"raise"`` (:class:`SimulationError`) or ``"return"`` (a trajectory with
        ``success=False`` and NaN after the failure).

    Which method to ask for: a run whose answer is used (a free run, a fit's state trajectory,
    the choice between a handful of candidate starts) keeps ``"auto"``, so a stiff but bounded run
    is never reported as a blow-up. A loop that tries many trial parameter sets and merely discards
    the ones that fail (a grid or random multistart: :func:`duffsym.identify.initial_guess`, the
    structure's equation-error start) asks for ``"rk4"``: an implicit rerun of every rejected
    trial costs up to a few hundred times an explicit one and buys nothing there.
    """
    opts = (
        _DEFAULT_OPTIONS
        if options is None and not settings
        else resolve(SimulateOptions, options, settings, "simulate")
    )
    method, reconstruction, on_failure = opts.method, opts.reconstruction, opts.on_failure
    h_lambda, max_substeps, blowup = opts.h_lambda, opts.max_substeps, opts.blowup
    if method not in METHODS:
        raise ModelError(f"method must be one of {set(METHODS)}; got {method!r}")
    if reconstruction not in RECONSTRUCTIONS:
        raise ModelError(f"reconstruction must be one of {set(RECONSTRUCTIONS)}; got {reconstruction!r}")
    if on_failure not in ("raise", "return"):
        raise ModelError(f"on_failure must be 'raise' or 'return'; got {on_failure!r}")
    t = check_time(t)
    p = model.param_vector(params)
    U = input_matrix(model, t, inputs)
    x_start = _initial_state(model, x0)
    fixed = _substep_setting(opts.substeps)
    _check_integrator_options(h_lambda, max_substeps, blowup)
    fallback = ""
    if method == "radau":
        X, Y, st, idx = _radau(model, t, U, x_start, p, reconstruction == "hold", opts.rtol, opts.atol, blowup)
        subs, ran = np.zeros(0, dtype=np.int64), "radau"
    else:
        ran = "rosenbrock" if method == "rosenbrock" else "rk4"
        X, Y, st, idx, subs = _compiled_run(
            model, ran, t, U, x_start, p, fixed, h_lambda, max_substeps, reconstruction == "hold", blowup
        )
        if method == "auto" and st != 0:
            fallback = (
                f"explicit RK4 stopped ({STATUS_MESSAGES[st]} at t={t[idx]:.6g} s); rerun with the implicit "
                "ROS2 integrator"
            )
            first = _failure_message(model, st, idx, t, h_lambda, max_substeps, blowup)
            X, Y, st, idx, subs = _compiled_run(
                model, "rosenbrock", t, U, x_start, p, fixed, h_lambda, max_substeps, reconstruction == "hold", blowup
            )
            ran = "rosenbrock"
            if st != 0:
                fallback += f"; it failed too (the RK4 run: {first})"
    message = "ok" if st == 0 else _failure_message(model, st, idx, t, h_lambda, max_substeps, blowup, ran)
    traj = Trajectory(
        model=model.name,
        t=t,
        x=X,
        y=Y,
        u=U,
        params=dict(zip(model.param_names, p.tolist())),
        success=st == 0,
        status=STATUS_MESSAGES[st],
        message=message,
        method=ran,
        substeps=subs,
        failed_at=idx,
        input_names=tuple(c.name for c in model.inputs),
        state_names=model.state_names,
        output_name=model.output_name,
        fallback=fallback,
    )
    if on_failure == "raise":
        traj.raise_for_status()
    return traj


def simulate_record(
    model: SymbolicModel,
    params: Mapping[str, float] | Sequence[float] | np.ndarray,
    record,
    *,
    x0: Sequence[float] | np.ndarray | None = None,
    **options,
) -> Trajectory:
    """The free run of ``model`` with ``params`` on a measured ``record``: the one public way to run a model
    on a record.

    The record's input channels (its displacement, the Savitzky-Golay velocity and acceleration, the
    command, a drift signal: whatever ``model.inputs`` asks for) are built once per record and model
    inputs (:meth:`duffsym.data.Record.input_matrix`) and reused by every later call. ``x0`` is the
    initial state (default zeros; a fit's estimate: :meth:`duffsym.identify.IdentificationResult.simulate`);
    ``options`` are :func:`simulate`'s (``method``, ``substeps``, ``on_failure``, ...).
    """
    return simulate(model, params, record.t, record.input_matrix(model), x0=x0, **options)


def frozen_array(a) -> np.ndarray:
    """``a`` as a read-only C-contiguous float64 array (a view; a copy only when the layout or type differs).

    numba compiles a function once per argument type, and a read-only array is another type than a writeable
    one: a record's cached input matrix is read-only, a freshly built one is not, so without this each model's
    integrator was compiled two to four times (3-5 s each; 239 compiles for 125 models in a cold test run)."""
    a = np.ascontiguousarray(a, dtype=float)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def _compiled_run(model, method, t, U, x0, p, fixed, h_lambda, max_substeps, hold, blowup):
    """One compiled run, explicit (``"rk4"``) or implicit (``"rosenbrock"``): X, Y, status, index, steps."""
    from duffsym.codegen import generic
    from duffsym.codegen.compiled import compiled_module

    mod = compiled_module(model)
    t, U, x0, p = (frozen_array(a) for a in (t, U, x0, p))
    X = np.empty((t.size, model.n_states))
    Y = np.empty(t.size)
    M = np.zeros(t.size - 1, dtype=np.int64)
    if method == "rk4":  # the integrators compiled once, calling the model through pointers
        st, idx = generic.integrate(
            mod, t, U, x0, p, generic.Settings(fixed, h_lambda, max_substeps, hold, blowup), X, Y, M
        )
    else:
        settings = generic.ImplicitSettings(fixed, IMPLICIT_RTOL, IMPLICIT_ATOL, IMPLICIT_MAX_STEPS, hold, blowup)
        st, idx = generic.integrate_implicit(mod, t, U, x0, p, settings, X, Y, M)
    return X, Y, int(st), int(idx), M


def _initial_state(model, x0) -> np.ndarray:
    if x0 is None:
        return np.zeros(model.n_states)
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.size != model.n_states or not np.isfinite(x0).all():
        raise ModelError(f"x0 must hold {model.n_states} finite values (states {model.state_names}); got {x0}")
    return x0


def _check_integrator_options(h_lambda, max_substeps, blowup) -> None:
    if not (isinstance(h_lambda, (int, float, np.floating)) and 0 < h_lambda <= 2.5):
        raise ModelError(f"h_lambda must be in (0, 2.5] (RK4 is unstable beyond h*rho = 2.785); got {h_lambda!r}")
    if isinstance(max_substeps, bool) or not isinstance(max_substeps, (int, np.integer)) or max_substeps < 1:
        raise ModelError(f"max_substeps must be a positive integer; got {max_substeps!r}")
    if not (isinstance(blowup, (int, float, np.floating)) and blowup > 0):
        raise ModelError(f"blowup must be a positive number (a state magnitude); got {blowup!r}")


def _substep_setting(substeps) -> int:
    if substeps == "auto":
        return 0
    if isinstance(substeps, (int, np.integer)) and not isinstance(substeps, bool) and substeps >= 1:
        return int(substeps)
    raise ModelError(f"substeps must be 'auto' or a positive integer; got {substeps!r}")


def _radau(model, t, U, x0, p, hold, rtol, atol, blowup):
    """Reference: scipy's Radau restarted at each sample (the input is smooth within an interval,
    not across samples), each interval starting with the step size the previous one ended with."""
    from scipy.integrate import Radau

    from duffsym.codegen.numpy_rhs import scalar_model

    sm = scalar_model(model)
    X = np.full((t.size, model.n_states), np.nan)
    X[0] = x0
    x = x0.copy()
    status, fail = 0, -1
    first_step = None
    for k in range(t.size - 1):
        t0, t1 = t[k], t[k + 1]
        u0 = U[k]
        g = np.zeros_like(u0) if hold else (U[k + 1] - u0) / (t1 - t0)

        def fun(tt, xx, u0=u0, g=g, t0=t0):
            return sm.rhs(xx, u0 + (tt - t0) * g, p)

        def jac(tt, xx, u0=u0, g=g, t0=t0):
            return sm.jac_states(xx, u0 + (tt - t0) * g, p)

        step = None if first_step is None else min(first_step, t1 - t0)
        solver = Radau(fun, t0, x, t1, jac=jac, rtol=rtol, atol=atol, first_step=step)
        while solver.status == "running":
            solver.step()
        if solver.status != "finished" or not np.all(np.abs(solver.y) <= blowup):
            status, fail = 1, k + 1
            break
        first_step = solver.h_abs if np.isfinite(solver.h_abs) and solver.h_abs > 0 else None
        x = solver.y.copy()
        X[k + 1] = x
    from duffsym.codegen.numpy_rhs import numpy_model

    Y = np.asarray(numpy_model(model).output(X, U, p), dtype=float).copy()
    return X, Y, status, fail


@dataclass(frozen=True)
class BatchResult:
    """Outputs of :func:`simulate_batch`: ``y`` (n_sets, n_times), per-set status and failure index."""

    t: Float1D
    y: Float2D
    status: np.ndarray
    failed_at: np.ndarray
    total_substeps: np.ndarray

    @property
    def success(self) -> np.ndarray:
        return self.status == 0


def simulate_batch(
    model: SymbolicModel,
    params: np.ndarray,
    t,
    inputs,
    *,
    x0=None,
    substeps: int | str = "auto",
    h_lambda: float = H_LAMBDA,
    max_substeps: int = MAX_SUBSTEPS,
    reconstruction: str = "linear",
    blowup: float = BLOWUP,
    method: str = "rk4",
) -> BatchResult:
    """Simulate many parameter sets (rows of ``params``, ordered as ``model.params``) in parallel, with the
    explicit integrator compiled once for every model (:func:`duffsym.codegen.generic.integrate_batch`).

    Failures do not raise: they are reported per set in ``status`` (0 ok, 1 blow-up, 2 too stiff). With
    ``method="auto"`` a set whose explicit RK4 run stops is rerun with the implicit ROS2 integrator (as
    ``simulate``'s default); its status is then the implicit run's. The default ``"rk4"`` keeps the
    explicit run's verdict: a grid search (:func:`duffsym.identify.initial_guess`) drops a set too stiff
    for it rather than paying an implicit run for a start it does not need.
    """
    from duffsym.codegen import generic
    from duffsym.codegen.compiled import compiled_module

    t = check_time(t)
    if reconstruction not in RECONSTRUCTIONS:
        raise ModelError(f"reconstruction must be one of {set(RECONSTRUCTIONS)}; got {reconstruction!r}")
    P = np.atleast_2d(np.asarray(params, dtype=float))
    if P.ndim != 2 or P.shape[1] != model.n_params:
        raise ModelError(f"params must have shape (n_sets, {model.n_params}) for {model.param_names}; got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ModelError(f"params has non-finite entries in row(s) {np.flatnonzero(~np.isfinite(P).all(1))[:5]}")
    if method not in ("rk4", "auto"):
        raise ModelError(f"method must be 'rk4' or 'auto' for a batch; got {method!r}")
    U = input_matrix(model, t, inputs)
    _check_integrator_options(h_lambda, max_substeps, blowup)
    if x0 is None:
        X0 = np.zeros((P.shape[0], model.n_states))
    else:
        X0 = np.asarray(x0, dtype=float)
        if X0.shape not in ((model.n_states,), (P.shape[0], model.n_states)) or not np.isfinite(X0).all():
            raise ModelError(
                f"x0 must be finite with shape ({model.n_states},) or ({P.shape[0]}, {model.n_states}) "
                f"(states {model.state_names}); got shape {X0.shape}"
            )
        X0 = np.ascontiguousarray(np.broadcast_to(X0, (P.shape[0], model.n_states)))
    Y = np.empty((P.shape[0], t.size))
    status = np.zeros(P.shape[0], dtype=np.int64)
    fail = np.zeros(P.shape[0], dtype=np.int64)
    total = np.zeros(P.shape[0], dtype=np.int64)
    fixed = _substep_setting(substeps)
    settings = generic.Settings(fixed, float(h_lambda), int(max_substeps), reconstruction == "hold", float(blowup))
    U, X0, P = frozen_array(U), frozen_array(X0), frozen_array(P)
    generic.integrate_batch(compiled_module(model), frozen_array(t), U, X0, P, settings, Y, status, fail, total)
    for s in np.flatnonzero(status != 0) if method == "auto" else ():  # the implicit integrator decides
        _, Y[s], status[s], fail[s], M = _compiled_run(
            model, "rosenbrock", t, U, X0[s], P[s], fixed, h_lambda, max_substeps, reconstruction == "hold", blowup
        )
        total[s] = M.sum()
    return BatchResult(t=t, y=Y, status=status, failed_at=fail, total_substeps=total)


def steady_cycle(traj: Trajectory, period: float) -> slice:
    """Index slice of the last full period of a trajectory (for loop plots and loop areas)."""
    t = traj.t
    start = np.searchsorted(t, t[-1] - period - 1e-9 * period)
    return slice(int(start), t.size)
