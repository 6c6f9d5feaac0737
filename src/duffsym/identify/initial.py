"""Initial parameter values (the paper's tuning procedure) and the automatic deadzone mask."""
from __future__ import annotations

from typing import Mapping

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError

#: The paper's tuning order (Fig. 4): step 1 fixes A_f (and n, structural), then pairs of parameters.
TUNING_STEPS: dict[str, tuple[tuple[str, ...], ...]] = {
    "mr-damper": (("A_f",), ("c1", "k1"), ("c2", "c3"), ("k2", "k3")),          # Fig. 4b
    "mr-damper-physical": (("A_f",), ("c1", "k1"), ("c2", "c3"), ("k2", "k3")),
    "duffing-like": (("A_f",), ("k1", "c1"), ("gamma", "delta"), ("alpha", "beta")),  # Fig. 4a
    # the command-driven models: the constant parts as for mr-damper (the field terms start at 0)
    **{name: (("A_f",), ("c1", "k1"), ("c2", "c3"), ("k2", "k3"))
       for name in ("mr-damper-current", "mr-damper-current-saturating", "mr-damper-current-quadratic")},
}
COARSE = (0.1, 0.3, 1.0, 3.0, 10.0)
FINE = (0.5, 0.7, 1.0, 1.4, 2.0)


def _cost(model, P, t, chans, x0, y):
    from duffsym.simulate import simulate_batch

    res = simulate_batch(model, P, t, chans, x0=x0)
    err = np.sqrt(np.mean((res.y - y[None, :]) ** 2, axis=1))
    return np.where(res.success & np.all(np.isfinite(res.y), axis=1), err, np.inf)


def initial_guess(record: Record, model, *, fixed: Mapping[str, float] | None = None,
                  max_samples: int = 2000) -> dict[str, float]:
    """Starting values by the paper's tuning procedure (Fig. 4), as a small grid search.

    Step 1 sets ``A_f = max|y|`` (unless fixed; ``n`` is structural and kept). Each later step
    scans its pair of parameters over factors (0.1, 0.3, 1, 3, 10) of the current values — both
    at once, by a batch of simulations — and keeps the pair with the smallest RMS output error;
    a second pass refines with factors (0.5 ... 2). The first ``max_samples`` samples are used.
    Parameters that are fixed, or equal to 0, are not scanned. Models without a tuning order
    return their defaults (with the fixed values).

    Returns
    -------
    dict
        Every parameter by name.
    """
    from duffsym.identify.collocation import _input_matrix, initial_states

    fixed = dict(fixed or {})
    if getattr(model, "composition", ()):
        from duffsym.identify.structure import equation_error_start

        start = equation_error_start(record, model, fixed=fixed)
        start.pop("_equation_nrmse")
        return start
    values = {**model.defaults(), **fixed}
    steps = TUNING_STEPS.get(model.name)
    if steps is None:
        return {k: float(v) for k, v in values.items()}
    if "A_f" not in fixed and "A_f" in values:
        values["A_f"] = float(np.max(np.abs(record.y)))
    n = min(record.n_times, max_samples)
    t = np.asarray(record.t[:n])
    U = _input_matrix(model, record)[:n]
    chans = {c.name: U[:, j] for j, c in enumerate(model.inputs)}
    y = np.asarray(record.y[:n])
    names = list(model.param_names)
    for factors in (COARSE, FINE):
        for step in steps[1:]:
            scan = [p for p in step if p in values and p not in fixed and values[p] != 0.0]
            if not scan:
                continue
            grids = np.meshgrid(*[np.asarray(factors)] * len(scan), indexing="ij")
            combos = np.column_stack([g.reshape(-1) for g in grids])
            base = np.array([values[k] for k in names])
            P = np.repeat(base[None, :], combos.shape[0], axis=0)
            for j, p in enumerate(scan):
                spec = model.param(p)
                P[:, names.index(p)] = np.clip(values[p] * combos[:, j], spec.lower, spec.upper)
            x0 = initial_states(model, record, base)[0]
            cost = _cost(model, P, t, chans, x0, y)
            best = int(np.argmin(cost))
            if np.isfinite(cost[best]):
                for p in scan:
                    values[p] = float(P[best, names.index(p)])
    return {k: float(v) for k, v in values.items()}


def auto_mask(record: Record, *, force_band: float = 0.5) -> tuple[np.ndarray, dict]:
    r"""Mask of the deadzone: the low-force stretch after each input velocity reversal (paper Fig. 8).

    Rule. A joint backlash lets the piston reverse and travel through the gap while the damper
    force stays near zero, so the force changes sign late. For every reversal of the input
    velocity (a sign change of :math:`\dot d`), the masked stretch starts at the reversal and
    ends at the first later sample where the force has taken the sign of the new velocity *and*
    left the low-force band :math:`|y| \ge` ``force_band`` :math:`\cdot\max|y|`. Its length is
    therefore read from the data: the lag of the force behind each reversal. A healthy damper
    also lags a little (its hysteresis), so a few samples per reversal are masked even without a
    deadzone; masked samples still obey the dynamics in the fit, so this costs information, not
    bias. The default band 0.5 (mask until the force has regained half its peak) also covers the
    recovery transient after the gap: on Table 2 0.4 V data (2 Hz, unit amplitude) with an input
    backlash of half-width 0.02 the RMS relative parameter error fell from 0.84 unmasked to 0.24,
    against 0.56 with a band of 0.1 (half-width 0.05: 0.90 -> 0.56). The extent is reported: the
    median lag (samples and seconds), the median over stretches of the largest :math:`|\dot d|/\max|\dot d|` inside (the velocity band of Fig. 8), the median
    displacement width, and the masked fraction.

    Parameters
    ----------
    record : the record.
    force_band : the low-force threshold as a fraction of ``max|y|`` (0 < force_band < 1).

    Returns
    -------
    mask : (n_times,) bool, True where a sample should leave the objective.
    info : the rule and the extent found (JSON-serialisable).
    """
    if not (0 < force_band < 1):
        raise DataError(f"force_band must lie in (0, 1) (a fraction of max|y|); got {force_band}")
    y = np.asarray(record.y)
    v = np.asarray(record.velocity())
    d = np.asarray(record.d)
    y_max = float(np.max(np.abs(y)))
    v_max = float(np.max(np.abs(v)))
    threshold = force_band * y_max
    nz = np.flatnonzero(v != 0)
    sv = np.sign(v[nz])
    reversals = nz[1:][sv[1:] != sv[:-1]]
    mask = np.zeros(y.size, dtype=bool)
    stretches = []
    for k, r in enumerate(reversals):
        new_sign = np.sign(v[r])
        stop = reversals[k + 1] if k + 1 < reversals.size else y.size
        after = np.flatnonzero((np.sign(y[r:stop]) == new_sign) & (np.abs(y[r:stop]) >= threshold))
        if after.size == 0:
            continue  # the force never followed before the next reversal: leave it to the fit
        end = r + int(after[0])
        if end > r:
            mask[r:end] = True
            stretches.append((int(r), int(end)))
    if stretches:
        lag = float(np.median([b - a for a, b in stretches]))
        v_band = float(np.median([np.max(np.abs(v[a:b])) / v_max for a, b in stretches]))
        width = float(np.median([np.ptp(d[a:b]) if b - a > 1 else 0.0 for a, b in stretches]))
    else:
        lag = v_band = width = 0.0
    info = {
        "rule": "auto: from each input velocity reversal until |y| >= force_band*max|y| with the new sign",
        "force_band": float(force_band), "force_threshold": threshold,
        "median_lag_samples": lag, "median_lag_s": lag * record.dt,
        "velocity_band": v_band, "velocity_threshold": v_band * v_max, "median_displacement_width": width,
        "n_stretches": len(stretches), "n_masked": int(mask.sum()), "fraction_masked": float(mask.mean()),
    }
    return mask, info
