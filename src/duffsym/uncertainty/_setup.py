"""Building the log-posterior of a fit: records, initial states, masks, substep schedules, priors."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError, ModelError
from duffsym.uncertainty import _kernel
from duffsym.uncertainty.posterior import PHI_BOUND, PHI_NAME, LogPosterior, Prior, make_prior


def as_records(records) -> tuple[Record, ...]:
    if isinstance(records, Record):
        return (records,)
    out = tuple(records)
    if not out or not all(isinstance(r, Record) for r in out):
        raise DataError("records must be a duffsym.data.Record or a non-empty sequence of them (read_csv loads one)")
    return out


def check_result(result) -> None:
    if getattr(result, "group_params", None):
        raise ModelError("sampling a fit with per-group parameters is not supported; fit each group separately")
    if not result.free:
        raise ModelError("the fit has no free parameters to sample")
    bad = [n for n in result.free if not math.isfinite(float(result.params[n]))]
    if bad:
        raise ModelError(f"the fit's value of {bad} is not finite; refit before sampling")


def spectral_bound(model, J: np.ndarray) -> np.ndarray:
    """rho(J) for a stack of Jacobians (..., n, n), measured by the kernel's own compiled
    ``spectral_radius`` (exact for n <= 2, the Gershgorin bound above). The schedule must use the
    kernel's measure: with exact eigenvalues a 3-state model (an output lag, A_f = 1.6) got a
    schedule the kernel then judged 2.6x too coarse, and no walker could start."""
    from duffsym.codegen.compiled import compiled_module

    J = np.asarray(J, dtype=float)
    n = J.shape[-1]
    flat = np.ascontiguousarray(J.reshape(-1, n, n))
    radius = compiled_module(model).spectral_radius
    return np.array([radius(Jk) for Jk in flat]).reshape(J.shape[:-2])


def stiffness_schedule(model, p, t, U, x0, *, h_rho: float, margin_neighbours: bool = True):
    """Substeps per sample interval so that h*rho(J) <= ``h_rho`` along the trajectory at ``p``
    (computed from an accurate adaptive run), taking the max over each interval's neighbours."""
    from duffsym.codegen.numpy_rhs import numpy_model
    from duffsym.simulate import simulate

    ref = simulate(model, p, t, U, x0=x0, h_lambda=0.1, on_failure="return")
    if not ref.success:
        raise DataError(
            f"the fitted parameters do not simulate on this record ({ref.message}); "
            "check that the fit belongs to this record"
        )
    J = numpy_model(model).jac_states(ref.x, U, p)
    rho = spectral_bound(model, J)
    dt = np.diff(t)
    r = np.maximum(rho[:-1], rho[1:])
    if margin_neighbours:
        rr = np.concatenate([r[:1], r, r[-1:]])
        r = np.maximum(np.maximum(rr[:-2], rr[1:-1]), rr[2:])
    return np.maximum(1, np.ceil(dt * r / h_rho)).astype(np.int64), ref


def record_x0(model, result, i, record, p):
    if len(result.x0) > i and len(result.x0[i]) == model.n_states:
        return np.asarray(result.x0[i], dtype=float)
    from duffsym.identify import initial_states

    return np.asarray(initial_states(model, record, p)[0], dtype=float)


def record_mask(result, i, record, mask):
    """Mask of record ``i``: the ``mask`` argument (one array, or one per record), else the fit's."""
    if mask is not None:
        arrays = [mask] if np.ndim(mask) == 1 and np.size(mask) == record.n_times and i == 0 else list(mask)
        m = np.asarray(arrays[i], dtype=bool).reshape(-1)
    elif len(result.mask) > i and np.size(result.mask[i]) == record.n_times:
        m = np.asarray(result.mask[i], dtype=bool).reshape(-1)
    else:
        m = np.zeros(record.n_times, dtype=bool)
    if m.size != record.n_times:
        raise DataError(f"mask of record {i} has {m.size} values for {record.n_times} samples; give one per sample")
    return m


def build_posterior(
    result,
    records,
    *,
    model=None,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    noise: str = "gaussian",
    mask=None,
    h_rho: float = 1.0,
    hrho_max: float = _kernel.HRHO_MAX,
    reconstruction: str = "linear",
    sample_x0: bool = False,
):
    """The :class:`LogPosterior` of ``result``'s free parameters on ``records`` plus setup details."""
    from duffsym.identify import model_from_result
    from duffsym.simulate import input_matrix

    check_result(result)
    records = as_records(records)
    if result.records and len(result.records) != len(records):
        raise DataError(
            f"the fit was made on {len(result.records)} record(s) {list(result.records)}; "
            f"give the same records (got {len(records)})"
        )
    model = model if model is not None else model_from_result(result)
    base = model.param_vector(result.params)
    free = tuple(result.free)
    priors: list[Prior] = []
    for n in free:
        spec = model.param(n)
        lo, hi = (bounds or {}).get(n, (spec.lower, spec.upper))
        priors.append(make_prior(n, lo, hi, float(result.params[n])))
    sims, ys, weights, info = [], [], [], []
    x0_priors = []
    for i, rec in enumerate(records):
        t = np.asarray(rec.t, dtype=float)
        U = input_matrix(model, t, rec.inputs_for(model))
        x0 = record_x0(model, result, i, rec, base)
        m = record_mask(result, i, rec, mask)
        sched, ref = stiffness_schedule(model, base, t, U, x0, h_rho=h_rho)
        if sample_x0:
            # uniform around the fit's value, half the state's range along the optimum's trajectory each way
            span = 0.5 * np.max(np.abs(ref.x), axis=0)
            for j, sname in enumerate(model.state_names):
                w = max(float(span[j]), 1e-6)
                label = f"x0_{sname}" if len(records) == 1 else f"x0[{i}]_{sname}"
                x0_priors.append(Prior(label, "uniform", float(x0[j]) - w, float(x0[j]) + w))
        sims.append(_kernel.ScheduleSimulator(model, t, U, x0, sched, hold=reconstruction == "hold", hrho_max=hrho_max))
        ys.append(np.asarray(rec.y, dtype=float))
        weights.append((~m).astype(float))
        info.append(
            {
                "record": rec.name,
                "n_times": int(t.size),
                "n_obs": int((~m).sum()),
                "n_masked": int(m.sum()),
                "x0": x0.tolist(),
                "schedule_total_substeps": int(sched.sum()),
                "schedule_max_substeps": int(sched.max()),
                "adaptive_total_substeps": int(ref.substeps.sum()),
            }
        )
    priors += x0_priors
    if noise == "ar1":
        priors.append(Prior(PHI_NAME, "uniform", -PHI_BOUND, PHI_BOUND))
    post = LogPosterior(model, base, free, priors, sims, ys, weights, noise=noise, x0_free=sample_x0)
    return post, model, records, info
