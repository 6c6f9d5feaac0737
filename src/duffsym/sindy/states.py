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

    def decimated(self, q: int) -> "ReconstructedStates":
        """Every q-th sample (states re-integrated by the caller when needed; see :func:`reconstruct_states`)."""
        return ReconstructedStates(self.t[::q], self.states[::q], self.inputs[::q], self.velocity[::q], self.gain)


def output_gain(model) -> sp.Expr:
    """The gain ``g`` of a model whose output is ``g * velocity`` (``A_f`` for Eq. 14).

    Raises
    ------
    ModelError
        If the model has no velocity state or its output is not proportional to it.
    """
    if model.position is None or model.velocity is None:
        raise ModelError(f"the SINDy cross-check needs a mechanical model (position and velocity states); "
                         f"model {model.name} has none")
    gain = sp.simplify(model.output / model.velocity)
    if gain.free_symbols & (set(model.states) | set(model.input_symbols)) or gain == 0:
        raise ModelError(
            f"the SINDy cross-check rebuilds the states from an output proportional to the velocity "
            f"(y = A_f x'); model {model.name} has output {model.output_name} = {model.output}; "
            "fit such a model (e.g. mr-damper without output-lag) or give the states"
        )
    return gain


def reconstruct_states(record, model, gain: float) -> ReconstructedStates:
    """States ``(x, x')`` and the model's inputs from a record, for output ``y = gain * x'``.

    Parameters
    ----------
    record : a :class:`~duffsym.data.Record` with uniform sampling.
    model : a mechanical model with ``output = gain * velocity`` (see :func:`output_gain`).
    gain : the value of the gain (``A_f``).

    Raises
    ------
    ModelError, DataError
        For a model without a velocity output, a non-positive gain, or non-uniform sampling.
    """
    output_gain(model)
    if not (np.isfinite(gain) and gain != 0):
        raise ModelError(f"the output gain must be finite and non-zero; got {gain}")
    if model.n_states != 2:
        raise ModelError(f"the SINDy cross-check rebuilds two states (x, x'); model {model.name} has "
                         f"{model.n_states} ({', '.join(model.state_names)})")
    record.require_uniform("the SINDy cross-check")
    t = np.asarray(record.t, dtype=float)
    v = np.asarray(record.y, dtype=float) / float(gain)
    x = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))))
    tc = t - t.mean()
    x = x - x.mean() - tc * (tc @ x) / (tc @ tc)
    X = np.empty((t.size, 2))
    X[:, model.states.index(model.position)] = x
    X[:, model.states.index(model.velocity)] = v
    inputs = record.inputs_for(model)
    U = np.column_stack([np.asarray(inputs[c.name], dtype=float) for c in model.inputs])
    return ReconstructedStates(t, X, U, X[:, model.states.index(model.velocity)], float(gain))
