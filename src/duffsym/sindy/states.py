"""The unmeasured state of a mechanical model rebuilt from a record, for sparse regression.

For models whose output is a gain times the velocity (the MR damper, Eq. 14: :math:`y = A_f\\dot x`)
the velocity is measured up to the gain, :math:`\\dot x = y/A_f`, and the position is its running
integral with a least-squares line removed. The integration constant and any drift (an offset of
the measured force integrates to a ramp) are unknown; the regression carries one constant and one
ramp per record as nuisance columns, so what the line removal gets wrong is absorbed exactly by
the terms linear in x. No model equation is used: the cross-check must not borrow its derivatives
from the model it checks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from duffsym.errors import ModelError


@dataclass(frozen=True)
class ReconstructedStates:
    """States and inputs of one record, time first.

    t : (n_times,) s. states : (n_times, n_states) in the model's state order.
    inputs : (n_times, n_inputs) in the model's input order. velocity : (n_times,) the measured
    velocity state (a view of one column of ``states``). gain : the output gain used.
    """

    t: np.ndarray
    states: np.ndarray
    inputs: np.ndarray
    velocity: np.ndarray
    gain: float

    def decimated(self, q: int) -> ReconstructedStates:
        """Every q-th sample (states re-integrated by the caller when needed; see :func:`reconstruct_states`)."""
        return ReconstructedStates(self.t[::q], self.states[::q], self.inputs[::q], self.velocity[::q], self.gain)


def output_split(model) -> tuple[sp.Expr, sp.Expr]:
    """``(gain, offset)`` of a model whose output is ``gain * velocity + offset``.

    ``gain`` depends on parameters only (``A_f`` for Eq. 14); ``offset`` on parameters and inputs
    only (0 for Eq. 14; ``off_y0`` with force-offset, ``off_y0 + gas_k d`` with gas-accumulator,
    ``inertia_m d''`` with inertia), so that the velocity is ``(y - offset) / gain``.

    Raises
    ------
    ModelError
        If the model has no velocity state, or its output depends on a state otherwise.
    """
    if model.position is None or model.velocity is None:
        raise ModelError(
            f"the SINDy cross-check needs a mechanical model (position and velocity states); "
            f"model {model.name} has none"
        )
    out = sp.expand(model.output)
    v = model.velocity
    gain = sp.simplify(out.coeff(v, 1))
    offset = sp.simplify(out - gain * v)
    states = set(model.states)
    if gain == 0 or gain.free_symbols & (states | set(model.input_symbols)) or offset.free_symbols & states:
        raise ModelError(
            f"the SINDy cross-check rebuilds the velocity from an output gain * x' + offset(inputs) (y = A_f x'); "
            f"model {model.name} has output {model.output_name} = {model.output}, which depends on the states "
            "otherwise; check the model without that effect (e.g. without output-lag or asymmetry)"
        )
    return gain, offset


def output_gain(model) -> sp.Expr:
    """The gain ``g`` of a model whose output is ``g * velocity + offset(inputs)`` (see :func:`output_split`)."""
    return output_split(model)[0]


def reconstruct_states(record, model, gain: float, params=None) -> ReconstructedStates:
    """States ``(x, x')`` and the model's inputs from a record, for output ``y = gain * x' + offset``.

    Parameters
    ----------
    record : a :class:`~duffsym.data.Record` with uniform sampling.
    model : a mechanical model with ``output = gain * velocity`` (see :func:`output_gain`).
    gain : the value of the gain (``A_f``).
    params : parameter values by name, needed when the output has an offset (force-offset, ...).

    Raises
    ------
    ModelError, DataError
        For a model without a velocity output, a non-positive gain, or non-uniform sampling.
    """
    _, offset = output_split(model)
    if not (np.isfinite(gain) and gain != 0):
        raise ModelError(f"the output gain must be finite and non-zero; got {gain}")
    if model.n_states != 2:
        raise ModelError(
            f"the SINDy cross-check rebuilds two states (x, x'); model {model.name} has "
            f"{model.n_states} ({', '.join(model.state_names)})"
        )
    record.require_uniform("the SINDy cross-check")
    t = np.asarray(record.t, dtype=float)
    inputs = record.inputs_for(model)
    U = np.column_stack([np.asarray(inputs[c.name], dtype=float) for c in model.inputs])
    y = np.asarray(record.y, dtype=float)
    if offset != 0:
        known = {p.symbol: params[p.name] for p in model.params if params is not None and p.name in params}
        missing = sorted(str(s) for s in offset.free_symbols - set(model.input_symbols) - set(known))
        if missing:
            raise ModelError(
                f"the output of model {model.name} has an offset {offset}; give values for {missing} "
                "(a fit or params) to rebuild the velocity"
            )
        fn = sp.lambdify(model.input_symbols, offset.xreplace(known), modules="numpy")
        y = y - np.broadcast_to(np.asarray(fn(*U.T), dtype=float), y.shape)
    v = y / float(gain)
    x = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))
    tc = t - t.mean()
    x = x - x.mean() - tc * (tc @ x) / (tc @ tc)
    X = np.empty((t.size, 2))
    X[:, model.states.index(model.position)] = x
    X[:, model.states.index(model.velocity)] = v
    return ReconstructedStates(t, X, U, X[:, model.states.index(model.velocity)], float(gain))
