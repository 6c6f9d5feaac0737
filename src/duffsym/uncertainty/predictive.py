"""Posterior predictive bands of the output: simulations at posterior draws, with and without noise."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from duffsym.errors import DataError
from duffsym.uncertainty.posterior import PHI_NAME

BAND_QUANTILES = (0.025, 0.16, 0.5, 0.84, 0.975)


@dataclass(frozen=True, eq=False)
class PredictiveBands:
    """Bands of one record's output at posterior draws.

    ``t`` (n_times,), ``u`` (n_times, n_inputs) inputs, ``y`` the data, ``mask`` samples out of the
    likelihood; ``model_bands`` (5, n_times): quantiles 2.5, 16, 50, 84, 97.5 % of the noise-free
    output; ``predictive_bands`` the same with the noise drawn (the band new data should fall in);
    ``coverage95``: fraction of the data inside the 95 % predictive band.
    """

    record: str
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    mask: np.ndarray
    model_bands: np.ndarray
    predictive_bands: np.ndarray
    n_draws: int
    input_names: tuple = ()

    @property
    def coverage95(self) -> float:
        lo, hi = self.predictive_bands[0], self.predictive_bands[-1]
        keep = ~self.mask
        return float(np.mean((self.y[keep] >= lo[keep]) & (self.y[keep] <= hi[keep])))


def posterior_predictive(chains, result, records, *, model=None, n_draws: int = 200, rng=None) -> list[PredictiveBands]:
    """Predictive bands on each record from ``n_draws`` posterior draws of ``chains``.

    Each draw is simulated (adaptive substeps: accuracy, not smoothness, matters here) from the
    record's initial state used in sampling; noise is drawn from the sampled noise level (white,
    or AR(1) with the draw's coefficient).
    """
    from duffsym.identify import model_from_result
    from duffsym.simulate import input_matrix, simulate_batch
    from duffsym.uncertainty._setup import as_records, record_mask

    rng = np.random.default_rng(rng)
    records = as_records(records)
    if len(chains.setup) != len(records):
        raise DataError(f"the chains were sampled on {len(chains.setup)} record(s); give the same records")
    model = model if model is not None else model_from_result(result)
    flat = chains.get_samples(thin=1)
    idx = rng.choice(flat.shape[0], size=min(n_draws, flat.shape[0]), replace=False)
    draws = flat[idx]
    base = model.param_vector(result.params)
    P = np.tile(base, (draws.shape[0], 1))
    for j, n in enumerate(chains.names):
        if n in model.param_names:
            P[:, model.param_names.index(n)] = draws[:, j]
    phi = draws[:, list(chains.names).index(PHI_NAME)] if PHI_NAME in chains.names else None
    sig = chains.sigma
    out = []
    for i, (rec, info) in enumerate(zip(records, chains.setup)):
        t = np.asarray(rec.t, dtype=float)
        U = input_matrix(model, t, rec.inputs_for(model))
        names = list(chains.names)
        cols = [
            names.index(f"x0_{s}" if len(records) == 1 else f"x0[{i}]_{s}")
            for s in model.state_names
            if (f"x0_{s}" if len(records) == 1 else f"x0[{i}]_{s}") in names
        ]
        x0 = draws[:, cols] if len(cols) == model.n_states else np.asarray(info["x0"], dtype=float)
        batch = simulate_batch(model, P, t, U, x0=x0)
        ok = batch.success
        Y = batch.y[ok]
        s = sig[rng.integers(sig.shape[0], size=Y.shape[0]), i] if sig.size else np.full(Y.shape[0], np.nan)
        e = rng.standard_normal(Y.shape) * s[:, None]
        if phi is not None:
            ph = phi[ok]
            noise = np.empty_like(e)
            noise[:, 0] = e[:, 0] / np.sqrt(1 - ph**2)
            for k in range(1, t.size):
                noise[:, k] = ph * noise[:, k - 1] + e[:, k]
            e = noise
        q = np.asarray(BAND_QUANTILES)
        m = record_mask(result, i, rec, None)
        out.append(
            PredictiveBands(
                record=rec.name,
                t=t,
                u=U,
                y=np.asarray(rec.y, dtype=float),
                mask=m,
                model_bands=np.quantile(Y, q, axis=0),
                predictive_bands=np.quantile(Y + e, q, axis=0),
                n_draws=int(ok.sum()),
                input_names=tuple(c.name for c in model.inputs),
            )
        )
    return out
