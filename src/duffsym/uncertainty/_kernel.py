"""The sampler's simulator: compiled batch RK4 on a fixed substep schedule (generated per model).

The likelihood surface must be smooth in the parameters, so the number of RK4 substeps of each
sample interval is chosen once, from the stiffness along the trajectory at the optimum
(``h rho(J) <= h_rho`` over the interval and its neighbours, see ``_setup.stiffness_schedule``),
and then held for every walker and every step. A walker whose state becomes stiffer than
that schedule resolves (``h rho(J) > hrho_max``) is stopped and reported as *too stiff* instead of
returning a silently wrong trajectory; a non-finite state is a *blow-up*.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from types import ModuleType

import numpy as np

from duffsym.errors import ModelError
from duffsym.simulate import frozen_array

_TEMPLATE = Path(__file__).with_name("_kernel_template.py")
_VERSION = "1"

#: A walker is stopped (too stiff) above this h*rho; RK4's real-axis stability limit is 2.785, and
#: well before it the error grows, so 2.0 stops a trajectory before it is silently wrong.
HRHO_MAX = 2.0
BLOWUP = 1e8
STATUS = {0: "ok", 1: "blow-up", 2: "too stiff"}


@lru_cache(maxsize=32)
def kernel_module(model) -> ModuleType:
    """Import (generating on first use) the model's compiled module with the schedule kernel."""
    from duffsym.codegen.compiled import GENERATOR_VERSION, generate_source, load_generated

    source = generate_source(model) + "\n\n" + _TEMPLATE.read_text()
    return load_generated(f"duffsym_unc_{model.key}_v{GENERATOR_VERSION}_{_VERSION}", source)


class ScheduleSimulator:
    """Simulate one record for many parameter sets on a fixed substep schedule.

    Parameters
    ----------
    model : the model.
    t : (n_times,) sample times; ``U`` (n_times, n_inputs) inputs; ``x0`` (n_states,) initial state.
    schedule : (n_times - 1,) RK4 substeps per sample interval.
    hold : zero-order hold of the input between samples (default: linear).
    hrho_max, blowup : limits beyond which a set is stopped (status 2, 1).
    """

    def __init__(
        self, model, t, U, x0, schedule, *, hold: bool = False, hrho_max: float = HRHO_MAX, blowup: float = BLOWUP
    ):
        self.model = model
        self.t = np.ascontiguousarray(t, dtype=float)
        self.U = np.ascontiguousarray(U, dtype=float)
        self.x0 = np.ascontiguousarray(x0, dtype=float).reshape(-1)
        self.schedule = np.ascontiguousarray(schedule, dtype=np.int64)
        if self.schedule.shape != (self.t.size - 1,) or np.any(self.schedule < 1):
            raise ModelError(
                f"schedule must hold {self.t.size - 1} positive substep counts; got shape {self.schedule.shape}"
            )
        self.hold = bool(hold)
        self.hrho_max = float(hrho_max)
        self.blowup = float(blowup)
        self._mod: ModuleType | None = None

    def __getstate__(self):  # the compiled module is not picklable (pools): rebuilt on first use
        state = dict(self.__dict__)
        state["_mod"] = None
        return state

    @property
    def total_substeps(self) -> int:
        return int(self.schedule.sum())

    def run(self, P: np.ndarray, X0: np.ndarray | None = None):
        """Outputs ``Y`` (n_sets, n_times; NaN after a failure), ``status``, ``failed_at``, ``worst_hrho``
        for the parameter sets ``P`` from initial states ``X0`` (n_sets, n_states; default the record's)."""
        if self._mod is None:
            self._mod = kernel_module(self.model)
        P = np.ascontiguousarray(np.atleast_2d(P), dtype=float)
        n = P.shape[0]
        X0 = np.ascontiguousarray(np.broadcast_to(self.x0 if X0 is None else X0, (n, self.x0.size)), dtype=float)
        Y = np.empty((n, self.t.size))
        status = np.zeros(n, dtype=np.int64)
        fail = np.zeros(n, dtype=np.int64)
        worst = np.zeros(n)
        self._mod.integrate_schedule_batch(
            *map(frozen_array, (self.t, self.U, X0, P)),
            self.schedule,
            self.hold,
            self.blowup,
            self.hrho_max,
            Y,
            status,
            fail,
            worst,
        )
        return Y, status, fail, worst
