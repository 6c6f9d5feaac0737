r"""The Laplace (Gauss–Newton) covariance of a fit's identified values.

Around the optimum of the least-squares objective, with :math:`J` the sensitivity of the free-run
outputs at the samples in the objective to the free parameters and to the initial states of each
record (forward differences of :func:`duffsym.simulate.simulate` with a fixed substep count, see
:data:`FD_STEP`),
:math:`\Sigma = \sigma^2 (J^\top W J)^{-1}`, :math:`\sigma^2 = \mathrm{SSR}/(N - p)`, ``p`` counting
the free parameters and the initial states; the parameter block of :math:`\Sigma` is reported (the
initial states are marginalised). :func:`duffsym.identify.fit` reports its square roots as standard errors.
"""

from __future__ import annotations

import warnings

import numpy as np

from duffsym.errors import ConvergenceWarning

#: The forward-difference step, relative to a parameter's size (or to its typical scale when smaller). Forward
#: differences take one free run per column where central ones took two: on the Dyke record's base model (12
#: free parameters, 5 states; stiff, so each run is an implicit one of ~0.08 s) the standard errors took 2.8 s and
#: were the largest part of a converged candidate's 5-6 s. With a fixed discretisation the runs are smooth in the
#: parameters, so the truncation error is of the order of the step (1e-6 relative), far below what a standard
#: error means: on four shipped and real records the standard errors agreed with the central ones to 1e-5 relative
#: (2.6e-3 on a UTFSM test; benchmarks/bench_covariance.py)
FD_STEP = 1e-6


def laplace_covariance(problem, rec_params, x0s, U_list, y_sims) -> np.ndarray:
    """Gauss–Newton covariance of the identified values (slots), initial states marginalised (see the module).

    ``rec_params``: each record's parameters by name; ``x0s``: each record's initial state; ``U_list``:
    each record's input matrix; ``y_sims``: each record's free-run output (not used: the reference run is
    repeated with the fixed substep count of the differences). All NaN when a free run fails or there are
    fewer samples than unknowns; a direction the records do not determine has infinite variance (a
    :class:`~duffsym.errors.ConvergenceWarning` says so).
    """
    model = problem.model
    n_slots = len(problem.slots)
    nx = model.n_states
    n_cols = n_slots + nx * len(problem.records)
    blocks, resid, weights = [], [], []
    for i, (rec, U, x0, params) in enumerate(zip(problem.records, U_list, x0s, rec_params)):
        block = _record_sensitivity(problem, i, rec, U, x0, params, n_cols)
        if block is None:
            return np.full((n_slots, n_slots), np.nan)
        Jb, base_y = block
        blocks.append(Jb)
        resid.append(np.asarray(rec.y) - base_y)
        weights.append(problem.sample_weights(i))
    J = np.vstack(blocks)
    # an initial state the output never sees (the carrier state of a static law) is not estimated: no column
    J = J[:, np.concatenate([np.ones(n_slots, dtype=bool), np.any(J[:, n_slots:] != 0, axis=0)])]
    return _gauss_newton(J, np.concatenate(resid), np.concatenate(weights), n_slots)


def _record_sensitivity(problem, i, rec, U, x0, params, n_cols):
    """``(J_i, y_i)``: record ``i``'s output sensitivity to the slots and to its initial state (its
    columns ``n_slots + nx * i ...``), and its free-run output; None if the free run fails."""
    from duffsym.simulate import simulate

    model, slots = problem.model, problem.slots
    n_slots, nx = len(slots), model.n_states
    chans = {c.name: U[:, j] for j, c in enumerate(model.inputs)}
    t = np.asarray(rec.t)
    # a fixed substep count keeps the discretisation the same while differencing
    ref = simulate(model, params, t, chans, x0=x0, on_failure="return")
    if not ref.success:
        return None
    n_sub = int(min(max(int(ref.substeps.max()), 1) * 2, 200))
    # ... and the same integrator (the implicit one when the explicit run fell back to it)
    how = {"substeps": n_sub, "method": ref.method, "on_failure": "return"}
    x0v = np.asarray(x0, dtype=float)
    cols, sets = [], []  # (column, step) and the (params, x0) of each column's run
    for j in sorted(set(problem.slot_index(i))):
        n = slots[j][0]
        step = FD_STEP * max(abs(params[n]), model.param(n).typical_scale)
        cols.append((j, step))
        sets.append(({**params, n: params[n] + step}, x0v))
    for s in range(nx):
        step = FD_STEP * max(abs(x0v[s]), 1e-3 * max(1.0, float(np.max(np.abs(x0v)))))
        cols.append((n_slots + nx * i + s, step))
        sets.append((params, x0v + step * np.eye(nx)[s]))
    ys = _runs(model, t, chans, [(params, x0v), *sets], how)
    Jb = np.zeros((rec.n_times, n_cols))
    for k, (col, step) in enumerate(cols):
        Jb[:, col] = (ys[1 + k] - ys[0]) / step
    return Jb, ys[0]


def _runs(model, t, chans, sets, how) -> np.ndarray:
    """Outputs of the runs ``sets`` (``(params by name, x0)`` each), one row each: one parallel batch of the
    explicit integrator (:func:`~duffsym.simulate.simulate_batch`, the same arithmetic as :func:`simulate`
    with the same settings), or one implicit run after another."""
    from duffsym.simulate import simulate, simulate_batch

    if how["method"] != "rk4":
        return np.array([simulate(model, p, t, chans, x0=x, **how).y for p, x in sets])
    P = np.array([model.param_vector(p) for p, _ in sets])
    X0 = np.array([x for _, x in sets])
    return simulate_batch(model, P, t, chans, x0=X0, substeps=how["substeps"], method="rk4").y


def _gauss_newton(J: np.ndarray, r: np.ndarray, wv: np.ndarray, n_slots: int) -> np.ndarray:
    """The slot block of :math:`\\sigma^2 (J^\\top W J)^{-1}` (pseudo-inverse, with inf for the directions
    the data do not determine, when the Hessian is singular)."""
    n_cols = J.shape[1]
    used = wv > 0
    if not np.all(np.isfinite(J[used])):
        return np.full((n_slots, n_slots), np.nan)
    dof = int(np.count_nonzero(used)) - n_cols
    if dof <= 0:
        return np.full((n_slots, n_slots), np.nan)
    sigma2 = float(np.sum(wv * r**2)) / dof
    H = J[used].T @ (wv[used, None] * J[used])
    # column scaling keeps the inversion well conditioned when parameters differ by decades
    d = np.sqrt(np.diag(H))
    d = np.where(d > 0, d, 1.0)
    Hs = H / np.outer(d, d)
    cond = np.linalg.cond(Hs)
    if np.isfinite(cond) and cond <= 1e14:
        return (sigma2 * np.linalg.inv(Hs) / np.outer(d, d))[:n_slots, :n_slots]
    warnings.warn(
        f"the Gauss-Newton Hessian is singular (condition number {cond:.3g}): some free parameters are "
        "not identifiable from these records; their standard errors are set to inf",
        ConvergenceWarning,
        stacklevel=4,
    )
    out = (sigma2 * np.linalg.pinv(Hs) / np.outer(d, d))[:n_slots, :n_slots]
    w_eig, v_eig = np.linalg.eigh(Hs)
    weak = np.abs(v_eig[:n_slots, np.abs(w_eig) < 1e-14 * np.max(np.abs(w_eig))]).sum(axis=1) > 1e-6
    out[weak, :] = np.inf
    out[:, weak] = np.inf
    return out
