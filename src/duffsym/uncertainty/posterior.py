r"""The log-posterior of a fitted model's free parameters, from the compiled free-run simulator.

Likelihood
----------
Each record is simulated from the fit's initial state (held fixed) on a fixed RK4 substep schedule
(:mod:`duffsym.uncertainty._kernel`); the residuals :math:`r = y - \hat y(\theta)` of the samples in
the objective (the fit's mask removes the others) are Gaussian. The noise level :math:`\sigma` is
*estimated*: it is integrated out analytically under the scale-invariant prior
:math:`p(\sigma)\propto 1/\sigma`, which leaves

.. math:: \log p(y\mid\theta) = -\tfrac{N}{2}\log \mathrm{SSR}(\theta) + \text{const}

(one :math:`\sigma` per record). Its posterior given :math:`\theta` is
:math:`\sigma^2 = \mathrm{SSR}/\chi^2_N`, drawn after sampling. With ``noise="ar1"`` the residuals
follow :math:`r_t = \phi r_{t-1} + e_t`, :math:`e_t\sim N(0,\sigma^2)` (exact likelihood, stationary
start of each unmasked stretch), :math:`\phi` is sampled (uniform on (-0.99, 0.99)) and
:math:`\mathrm{SSR}_\phi = (1-\phi^2) r_0^2 + \sum (r_t-\phi r_{t-1})^2` with the Jacobian term
:math:`\tfrac{n_\mathrm{seg}}{2}\log(1-\phi^2)`.

Priors
------
From the parameter bounds (the model's ``ParamSpec`` unless overridden): **log-uniform** for scale
parameters -- positive ones whose bounds span at least two decades (lower bound 0 is read as a tiny
positive value) -- and uniform otherwise. The sampler works in the coordinates in which the prior is
flat (:math:`\log\theta` for log-uniform ones), so the prior is the box of those coordinates.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from duffsym.errors import DataError, ModelError
from duffsym.status import Status

#: Bounds spanning at least this ratio make a positive parameter a scale parameter (log-uniform prior).
DECADES_RATIO = 100.0
#: A zero lower bound of a log-uniform prior is read as ``upper * TINY``.
TINY = 1e-12
PHI_NAME = "ar1_phi"
PHI_BOUND = 0.99
#: the kernel's status codes; the counts of a posterior are keyed by their values ("ok", "blow-up", ...)
CODES = {0: Status.OK, 1: Status.BLOW_UP, 2: Status.TOO_STIFF, 3: Status.OUTSIDE_PRIOR}


@dataclass(frozen=True)
class Prior:
    """Prior of one sampled quantity: ``kind`` ``"log-uniform"`` or ``"uniform"`` on [lower, upper]."""

    name: str
    kind: str
    lower: float
    upper: float

    def to_coord(self, value):
        return np.log(value) if self.kind == "log-uniform" else np.asarray(value, dtype=float)

    def from_coord(self, z):
        return np.exp(z) if self.kind == "log-uniform" else np.asarray(z, dtype=float)

    @property
    def coord_bounds(self) -> tuple[float, float]:
        if self.kind == "log-uniform":
            return math.log(self.lower), math.log(self.upper)
        return self.lower, self.upper

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "lower": self.lower, "upper": self.upper}


def make_prior(name: str, lower: float, upper: float, value: float) -> Prior:
    """The prior of a parameter from its bounds: log-uniform for a positive scale parameter."""
    lower, upper = float(lower), float(upper)
    if not lower < upper:
        raise ModelError(f"bounds of {name} must satisfy lower < upper; got ({lower}, {upper})")
    if not (lower <= value <= upper):
        raise ModelError(f"{name} = {value:g} lies outside its prior bounds [{lower:g}, {upper:g}]; widen them")
    if lower >= 0 and value > 0 and math.isfinite(upper) and (lower == 0 or upper / lower >= DECADES_RATIO):
        lo = lower if lower > 0 else upper * TINY
        return Prior(name, "log-uniform", min(lo, value), upper)
    if not (math.isfinite(lower) and math.isfinite(upper)):
        raise ModelError(f"the prior of {name} needs finite bounds; got ({lower}, {upper}); pass bounds=")
    return Prior(name, "uniform", lower, upper)


class LogPosterior:
    """Log-posterior in the sampling coordinates ``z`` (one row per walker when vectorized).

    With ``x0_free`` the initial state of each record is sampled as well (its priors follow the
    parameters' in ``priors``): the fit's initial state is a nuisance parameter, and holding it at
    the optimum penalises every other parameter set.

    Calling it with ``z`` of shape ``(n_walkers, n_dim)`` returns ``(n_walkers, 2)``: the
    log-posterior and a status code (0 ok, 1 blow-up, 2 too stiff, 3 outside the prior); with
    ``(n_dim,)`` a pair. Failed simulations give ``-inf``.

    Parameters
    ----------
    model : the model; ``base`` (n_params,) every parameter (the fixed ones are used as they are).
    free : names of the sampled parameters; ``priors`` their :class:`Prior` (plus ``ar1_phi``).
    simulators : one :class:`~duffsym.uncertainty._kernel.ScheduleSimulator` per record.
    ys : measured outputs per record; ``weights`` per record, 0 where a sample is masked.
    noise : ``"gaussian"`` or ``"ar1"``.
    """

    def __init__(
        self,
        model,
        base,
        free: Sequence[str],
        priors: Sequence[Prior],
        simulators,
        ys,
        weights,
        *,
        noise: str = "gaussian",
        x0_free: bool = False,
    ):
        if noise not in ("gaussian", "ar1"):
            raise ModelError(f"noise must be one of {{'gaussian', 'ar1'}}; got {noise!r}")
        self.model = model
        self.base = np.asarray(base, dtype=float)
        self.free = tuple(free)
        self.priors = tuple(priors)
        self.noise = noise
        self.index = np.array([model.param_names.index(n) for n in self.free], dtype=np.int64)
        self.simulators = list(simulators)
        # initial states sampled too: coordinates n_free + i * n_states ... (one block per record)
        self.x0_free = bool(x0_free)
        self.n_free = len(self.free)
        self.ys = [np.asarray(y, dtype=float) for y in ys]
        self.keep = [np.asarray(w) > 0 for w in weights]
        self.n_obs = [int(k.sum()) for k in self.keep]
        for i, n in enumerate(self.n_obs):
            if n < 2:
                raise DataError(f"record {i} has {n} sample(s) in the objective; the likelihood needs more")
        # AR(1): consecutive kept pairs and stretch starts per record
        self.pairs = [np.flatnonzero(k[1:] & k[:-1]) + 1 for k in self.keep]
        self.starts = [np.flatnonzero(k & ~np.concatenate([[False], k[:-1]])) for k in self.keep]
        lo, hi = zip(*(p.coord_bounds for p in self.priors))
        self.lo, self.hi = np.array(lo), np.array(hi)
        self.n_dim = len(self.priors)
        self.counts = {c.value: 0 for c in CODES.values()}

    # ---------------------------------------------------------------- coordinates
    def params(self, z: np.ndarray) -> np.ndarray:
        """Full parameter vectors (n, n_params) from sampling coordinates (n, n_dim)."""
        z = np.atleast_2d(z)
        P = np.tile(self.base, (z.shape[0], 1))
        for j, (i, pr) in enumerate(zip(self.index, self.priors)):
            P[:, i] = pr.from_coord(z[:, j])
        return P

    def initial_states(self, z: np.ndarray, r: int) -> np.ndarray | None:
        """Initial states (n, n_states) of record ``r`` from coordinates, or None when they are not sampled."""
        if not self.x0_free:
            return None
        ns = self.model.n_states
        z = np.atleast_2d(z)
        return z[:, self.n_free + r * ns : self.n_free + (r + 1) * ns]

    def natural(self, z: np.ndarray) -> np.ndarray:
        """Sampled quantities in natural units (n, n_dim) from coordinates."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        return np.column_stack([pr.from_coord(z[:, j]) for j, pr in enumerate(self.priors)])

    def coords(self, values: np.ndarray) -> np.ndarray:
        values = np.atleast_2d(np.asarray(values, dtype=float))
        return np.column_stack([pr.to_coord(values[:, j]) for j, pr in enumerate(self.priors)])

    # ---------------------------------------------------------------- likelihood
    def ssr(self, z: np.ndarray):
        """Per record: (n, ) weighted SSR (AR(1)-whitened), and the status code per row."""
        z = np.atleast_2d(z)
        n = z.shape[0]
        code = np.zeros(n, dtype=np.int64)
        inside = np.all((z >= self.lo) & (z <= self.hi), axis=1)
        code[~inside] = 3
        out = [np.full(n, np.inf) for _ in self.simulators]
        rows = np.flatnonzero(inside)
        if rows.size == 0:
            return out, code
        P = self.params(z[rows])
        phi = z[rows, self.n_dim - 1] if self.noise == "ar1" else None
        for r, (sim, y, keep) in enumerate(zip(self.simulators, self.ys, self.keep)):
            Y, status, _, _ = sim.run(P, self.initial_states(z[rows], r))
            bad = status != 0
            code[rows[bad]] = np.maximum(code[rows[bad]], status[bad])
            res = Y - y
            if phi is None:
                s = np.sum(np.where(keep, res, 0.0) ** 2, axis=1)
            else:
                pr, st = self.pairs[r], self.starts[r]
                e = res[:, pr] - phi[:, None] * res[:, pr - 1]
                s = np.sum(e**2, axis=1) + (1 - phi**2) * np.sum(res[:, st] ** 2, axis=1)
            s[bad] = np.inf
            out[r][rows] = s
        return out, code

    def evaluate(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Log-posterior (n,) and status code (n,) of coordinates (n, n_dim)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        ssrs, code = self.ssr(z)
        lp = np.zeros(z.shape[0])
        for s, n_obs, st in zip(ssrs, self.n_obs, self.starts):
            with np.errstate(divide="ignore", invalid="ignore"):
                lp += -0.5 * n_obs * np.log(s)
            if self.noise == "ar1":
                phi = z[:, self.n_dim - 1]
                with np.errstate(divide="ignore", invalid="ignore"):
                    lp += 0.5 * st.size * np.log1p(-(phi**2))
        lp[code != 0] = -np.inf
        lp[~np.isfinite(lp)] = -np.inf
        return lp, code

    def __call__(self, z):
        z = np.asarray(z, dtype=float)
        lp, code = self.evaluate(z)
        if z.ndim == 1:
            return float(lp[0]), int(code[0])
        return np.column_stack([lp, code])

    def count(self, codes) -> None:
        for c in np.asarray(codes, dtype=np.int64).ravel():
            self.counts[CODES[int(c)].value] += 1


class _Vectorized:
    """emcee's vectorized log-probability: counts the status codes, returns the log-posteriors."""

    def __init__(self, post: LogPosterior):
        self.post = post

    def __call__(self, z):
        lp, code = self.post.evaluate(z)
        self.post.count(code)
        return lp


class _CountingPool:
    """A pool whose ``map`` keeps the status codes of a per-walker log-posterior and hands emcee the values."""

    def __init__(self, pool, post: LogPosterior):
        self.pool = pool
        self.post = post

    def map(self, fn, iterable):
        results = list(self.pool.map(fn, iterable))
        self.post.count([c for _, c in results])
        return [lp for lp, _ in results]


class _Serial:
    def __init__(self, post):
        self.post = post

    def __call__(self, z):
        return self.post(z)
