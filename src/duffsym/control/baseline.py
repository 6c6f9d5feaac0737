"""The on/off baseline: the clipped-optimal law of Dyke, Spencer, Sain & Carlson (Smart Mater. Struct. 5, 1996).

At each sample the damper's measured force f is compared with the desired force f_c: the command is
switched to its upper limit when the damper should push harder in the same direction,
((f_c - f) f > 0), and to its lower limit otherwise, and held until the next sample. It needs only
the measured force (closed loop), no model.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np


@dataclass(frozen=True, eq=False)
class OnOffRun:
    """A closed-loop run of the clipped on/off law: command (held over each interval) and force."""

    t: np.ndarray
    command: np.ndarray
    force: np.ndarray
    success: bool
    message: str


def clipped_on_off(model, params, t, inputs: np.ndarray, force_desired, *, limits=(0.0, 1.0), x0=None) -> OnOffRun:
    """Run ``model`` (the damper) in closed loop with the clipped on/off law tracking ``force_desired``.

    ``inputs`` (n_times, n_inputs) gives the motion; its command column is overwritten. The command
    decided at sample k is held (zero-order) over [t_k, t_k+1]; the motion is linear between samples.
    """
    from duffsym.control.inverse import command_index
    from duffsym.simulate import simulate

    jc = command_index(model)
    lo, hi = (float(v) for v in limits)
    t = np.asarray(t, dtype=float)
    U = np.array(inputs, dtype=float, copy=True)
    f_c = np.asarray(force_desired, dtype=float)
    p = model.param_vector(params)
    x = np.zeros(model.n_states) if x0 is None else np.asarray(x0, dtype=float).copy()
    from duffsym.codegen.numpy_rhs import numpy_model

    output = numpy_model(model).output
    cmd = np.empty(t.size)
    y = np.full(t.size, np.nan)
    for k in range(t.size):
        U[k, jc] = lo
        y[k] = float(np.asarray(output(x[None, :], U[k : k + 1], p)).ravel()[0])
        cmd[k] = hi if (f_c[k] - y[k]) * y[k] > 0 else lo
        if k == t.size - 1:
            break
        seg = U[k : k + 2].copy()
        seg[:, jc] = cmd[k]
        x_k = cast("Sequence[float]", x)  # simulate takes an array too
        tr = simulate(model, p, t[k : k + 2], seg, x0=x_k, on_failure="return")
        if not tr.success:
            return OnOffRun(t, cmd, y, False, tr.message)
        x = tr.x[-1]
    return OnOffRun(t, cmd, y, True, "ok")
