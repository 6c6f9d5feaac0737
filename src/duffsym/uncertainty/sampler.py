"""Posterior sampling of a fit with emcee, and the chains it produces.

:func:`sample` starts the walkers around the IPOPT optimum (from its Laplace covariance), samples
the free parameters of the fit (its fixed parameters and mask are kept) and checks convergence:
integrated autocorrelation time :math:`\\tau`, effective sample size, acceptance fraction, the
chain length against :math:`50\\tau` (warning, or :class:`ChainTooShort` on request), the walkers'
failed simulations, and, after sampling, that the fixed substep schedule still resolves the
dynamics at posterior draws.

References
----------
Foreman-Mackey, Hogg, Lang & Goodman (2013), emcee: the MCMC hammer, PASP 125, 306,
doi:10.1086/670067. Goodman & Weare (2010), doi:10.2140/camcos.2010.5.65.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from duffsym._json import jsonable
from duffsym.errors import ConvergenceWarning, DataError, DuffsymError, ModelError
from duffsym.options import resolve
from duffsym.status import Status
from duffsym.uncertainty.options import SampleOptions
from duffsym.uncertainty.posterior import PHI_NAME, LogPosterior, Prior, _CountingPool, _Serial, _Vectorized

#: Chains shorter than this many autocorrelation times are flagged (emcee's recommendation).
MIN_TAUS = 50
#: Acceptance fractions outside this range are flagged (0.2-0.5 is healthy for the stretch move,
#: Foreman-Mackey et al. 2013; the differential-evolution moves used by default run at ~0.1-0.3).
ACCEPTANCE_RANGE = (0.08, 0.7)


def default_moves():
    """Differential evolution (80 %) + DE snooker (20 %), emcee's moves for correlated posteriors.

    Measured on the Table 2 record (32 walkers, 4000 steps): tau of k1/k2 (correlated +0.99) 88 steps
    against 137 with the stretch move (acceptance 0.13 vs 0.44) -- fewer steps for 50 tau."""
    import emcee

    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


class ChainTooShort(DuffsymError):
    """The chain is shorter than ``MIN_TAUS`` autocorrelation times; ``tau`` and ``chains`` carry what was computed."""

    def __init__(self, message: str, tau=None, chains=None):
        super().__init__(message)
        self.tau = tau
        self.chains = chains


@dataclass(frozen=True, eq=False)
class Chains:
    """Samples of the posterior of a fit's free parameters (natural units) with their diagnostics.

    Attributes
    ----------
    names : sampled quantities (the fit's free parameters, plus ``ar1_phi`` with AR(1) noise).
    chain : (n_steps, n_walkers, n_dim) every step of every walker; ``log_prob`` (n_steps, n_walkers).
    burn, thin : default discard and thinning of :meth:`get_samples`.
    tau : (n_dim,) integrated autocorrelation time (steps) after ``burn``; ``acceptance`` per walker.
    optimum : the fit's values; ``laplace_stderr``, ``laplace_cov`` its Laplace approximation.
    priors : the prior of each quantity. ``counts``: log-posterior evaluations by outcome (ok,
        blow-up, too stiff, outside prior). ``sigma`` (n_draws, n_records): draws of the noise level.
    recheck : the substep schedule re-checked at posterior draws. ``setup``: records, schedules,
        initial states. ``warnings``: what a person should know. ``settings``, ``timings``.
    """

    names: tuple
    chain: np.ndarray
    log_prob: np.ndarray
    acceptance: np.ndarray
    tau: np.ndarray
    burn: int
    thin: int
    optimum: np.ndarray
    laplace_stderr: np.ndarray
    laplace_cov: np.ndarray
    priors: tuple = ()
    counts: dict = field(default_factory=dict)
    sigma: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    recheck: dict = field(default_factory=dict)
    setup: list = field(default_factory=list)
    warnings: tuple = ()
    settings: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)
    fit: dict = field(default_factory=dict)

    # ------------------------------------------------------------ samples
    @property
    def n_steps(self) -> int:
        return int(self.chain.shape[0])

    @property
    def n_walkers(self) -> int:
        return int(self.chain.shape[1])

    def get_samples(self, discard: int | None = None, thin: int | None = None, flat: bool = True) -> np.ndarray:
        """Samples after ``discard`` steps (default ``burn``), every ``thin``-th (default ``thin``);
        flat ``(n, n_dim)`` or ``(n_steps', n_walkers, n_dim)``."""
        d = self.burn if discard is None else int(discard)
        th = self.thin if thin is None else int(thin)
        if not 0 <= d < self.n_steps or th < 1:
            raise DataError(f"discard must be in [0, {self.n_steps}) and thin >= 1; got {d}, {th}")
        c = self.chain[d::th]
        return c.reshape(-1, c.shape[-1]) if flat else c

    @property
    def ess(self) -> np.ndarray:
        """Effective sample size per quantity: walkers x kept steps / tau."""
        return self.n_walkers * (self.n_steps - self.burn) / self.tau

    @property
    def converged(self) -> bool:
        """Kept chain >= 50 tau of every quantity and a healthy mean acceptance."""
        a = float(np.mean(self.acceptance))
        return bool(
            np.all(self.n_steps - self.burn >= MIN_TAUS * self.tau) and ACCEPTANCE_RANGE[0] <= a <= ACCEPTANCE_RANGE[1]
        )

    def quantiles(self, q=(0.05, 0.16, 0.5, 0.84, 0.95)) -> dict[str, dict[float, float]]:
        s = self.get_samples(thin=1)
        return {n: dict(zip(q, np.quantile(s[:, j], q).tolist())) for j, n in enumerate(self.names)}

    def interval(self, level: float = 0.9) -> dict[str, tuple[float, float]]:
        """Central credible interval of each quantity."""
        a = (1 - level) / 2
        s = self.get_samples(thin=1)
        return {n: tuple(np.quantile(s[:, j], [a, 1 - a]).tolist()) for j, n in enumerate(self.names)}

    def correlation(self) -> np.ndarray:
        """Posterior correlation matrix (in the sampling coordinates: log for log-uniform priors)."""
        s = self.get_samples(thin=1)
        z = (
            np.column_stack(
                [
                    Prior(**p).to_coord(s[:, j]) if isinstance(p, dict) else p.to_coord(s[:, j])
                    for j, p in enumerate(self.priors)
                ]
            )
            if self.priors
            else s
        )
        return np.corrcoef(z, rowvar=False)

    # ------------------------------------------------------------ comparison and report
    def laplace_comparison(self, width_ratio: float = 1.5, shift: float = 1.0) -> dict[str, dict]:
        """Posterior vs the fit's Laplace approximation per parameter.

        ``ratio`` = posterior half-width of the central 68 % interval / Laplace standard error;
        ``shift`` = (posterior median - optimum) / posterior half-width. Flagged when the ratio is
        above ``width_ratio`` or below its inverse, or ``|shift|`` above ``shift``.
        """
        q = self.quantiles((0.16, 0.5, 0.84))
        out = {}
        fit_free = set(self.fit.get("free", self.names))
        for j, n in enumerate(self.names):
            if n == PHI_NAME or n not in fit_free:
                continue
            half = 0.5 * (q[n][0.84] - q[n][0.16])
            se = float(self.laplace_stderr[j])
            ratio = half / se if se > 0 and math.isfinite(se) else math.nan
            sh = (q[n][0.5] - float(self.optimum[j])) / half if half > 0 else math.nan
            why = []
            if not math.isfinite(ratio):
                why.append("no finite Laplace standard error")
            elif ratio > width_ratio:
                why.append(f"posterior {ratio:.2g}x wider than Laplace")
            elif ratio < 1 / width_ratio:
                why.append(f"posterior {1 / ratio:.2g}x narrower than Laplace")
            if math.isfinite(sh) and abs(sh) > shift:
                why.append(f"median shifted by {sh:+.2g} posterior half-widths from the optimum")
            out[n] = {
                "optimum": float(self.optimum[j]),
                "laplace_stderr": se,
                "median": q[n][0.5],
                "posterior_halfwidth68": half,
                "width_ratio": ratio,
                "shift": sh,
                "disagree": bool(why),
                "reason": "; ".join(why),
            }
        return out

    def to_dict(self) -> dict:
        """The JSON of ``duffsym sample`` (``docs/contract.md``: median, q05, q95, tau; and more)."""
        q = self.quantiles()
        tau = dict(zip(self.names, self.tau.tolist()))
        sig = self.sigma
        return {
            "median": {n: q[n][0.5] for n in self.names},
            "q05": {n: q[n][0.05] for n in self.names},
            "q95": {n: q[n][0.95] for n in self.names},
            "q16": {n: q[n][0.16] for n in self.names},
            "q84": {n: q[n][0.84] for n in self.names},
            "tau": tau,
            "ess": dict(zip(self.names, self.ess.tolist())),
            "acceptance": float(np.mean(self.acceptance)),
            "acceptance_range": [float(np.min(self.acceptance)), float(np.max(self.acceptance))],
            "converged": self.converged,
            "n_walkers": self.n_walkers,
            "n_steps": self.n_steps,
            "burn": self.burn,
            "thin": self.thin,
            "chain_over_tau": float((self.n_steps - self.burn) / np.max(self.tau)),
            "sigma": {
                "median": np.median(sig, axis=0).tolist(),
                "q05": np.quantile(sig, 0.05, axis=0).tolist(),
                "q95": np.quantile(sig, 0.95, axis=0).tolist(),
            }
            if sig.size
            else {},
            "evaluations": dict(self.counts),
            "laplace": self.laplace_comparison(),
            "correlation": {"names": list(self.names), "matrix": self.correlation().tolist()},
            "priors": [p if isinstance(p, dict) else p.to_dict() for p in self.priors],
            "recheck": self.recheck,
            "records": self.setup,
            "warnings": list(self.warnings),
            "settings": self.settings,
            "timings": self.timings,
            "fit": self.fit,
        }

    def summary(self) -> str:
        q = self.quantiles((0.025, 0.05, 0.16, 0.5, 0.84, 0.95, 0.975))
        lines = [
            f"posterior of {self.fit.get('model', '?')}: {self.n_walkers} walkers x {self.n_steps} steps "
            f"(burn {self.burn}), acceptance {np.mean(self.acceptance):.2f}, "
            f"{'converged' if self.converged else 'NOT converged'}"
        ]
        lines.append(f"  {'':>8} {'median':>11} {'68% interval':>25} {'95% interval':>25} {'tau':>6} {'ESS':>7}")
        for j, n in enumerate(self.names):
            a = q[n]
            lines.append(
                f"  {n:>8} {a[0.5]:11.5g} [{a[0.16]:11.5g}, {a[0.84]:11.5g}] "
                f"[{a[0.025]:11.5g}, {a[0.975]:11.5g}] {self.tau[j]:6.1f} {self.ess[j]:7.0f}"
            )
        c = self.counts
        total = sum(c.values())
        if total:
            lines.append("  evaluations: " + ", ".join(f"{k} {v}" for k, v in c.items()) + f" (of {total})")
        for w in self.warnings:
            lines.append(f"  warning: {w}")
        for n, d in self.laplace_comparison().items():
            if d["disagree"]:
                lines.append(f"  Laplace vs posterior, {n}: {d['reason']}")
        return "\n".join(lines)

    # ------------------------------------------------------------ files
    def save(self, path) -> Path:
        """Write the chains as ``.npz`` (arrays + a JSON header); :func:`load_chains` reads it back."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(path.suffix + ".npz") if path.suffix else path.with_suffix(".npz")
        meta = {
            "names": list(self.names),
            "burn": self.burn,
            "thin": self.thin,
            "priors": [p if isinstance(p, dict) else p.to_dict() for p in self.priors],
            "counts": self.counts,
            "recheck": self.recheck,
            "setup": self.setup,
            "warnings": list(self.warnings),
            "settings": self.settings,
            "timings": self.timings,
            "fit": self.fit,
            "format": "duffsym-chains-1",
        }
        from duffsym._io import atomic_path

        with atomic_path(path) as tmp:
            with open(tmp, "wb") as fh:  # a file object: np.savez would append ".npz" to the temporary name
                np.savez_compressed(
                    fh,
                    chain=self.chain,
                    log_prob=self.log_prob,
                    acceptance=self.acceptance,
                    tau=self.tau,
                    optimum=self.optimum,
                    laplace_stderr=self.laplace_stderr,
                    laplace_cov=self.laplace_cov,
                    sigma=self.sigma,
                    meta=np.array(json.dumps(jsonable(meta))),
                )
        return path


PARTIAL_FORMAT = "duffsym-chains-partial-1"


def _run_with_checkpoints(sampler, p0, n_steps: int, progress, post, checkpoint, every: float, result) -> None:
    """``sampler.run_mcmc`` that writes the chain so far to ``checkpoint`` periodically and on interrupt."""
    if checkpoint is None:
        sampler.run_mcmc(p0, n_steps, progress=progress)
        return
    last = time.perf_counter()
    try:
        for _ in sampler.sample(p0, iterations=n_steps, progress=progress):
            if time.perf_counter() - last >= every:
                save_partial_chain(checkpoint, sampler, post, n_steps, result)
                last = time.perf_counter()
    except KeyboardInterrupt:
        if sampler.iteration:
            save_partial_chain(checkpoint, sampler, post, n_steps, result)
        raise


def save_partial_chain(path, sampler, post, n_planned: int, result) -> Path:
    """Write the steps an emcee sampler has run so far (natural parameters) to ``path`` atomically."""
    from duffsym._io import atomic_path

    path = Path(path)
    z = sampler.get_chain()
    chain = np.stack([post.natural(z[i]) for i in range(z.shape[0])])
    meta = {
        "format": PARTIAL_FORMAT,
        "names": [p.name for p in post.priors],
        "steps_done": int(z.shape[0]),
        "steps_planned": int(n_planned),
        "model": result.model,
        "effects": list(result.effects),
        "free": list(result.free),
    }
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, chain=chain, log_prob=sampler.get_log_prob(), meta=np.array(json.dumps(meta)))
    return path


def load_partial_chain(path) -> dict:
    """Read a chain saved by :func:`save_partial_chain`: ``{"chain": (steps, walkers, dim), "log_prob",
    "names", "steps_done", "steps_planned", ...}``."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as f:
            meta = json.loads(str(f["meta"]))
            if meta.get("format") != PARTIAL_FORMAT:
                raise ValueError("not a partial chain")
            return {**meta, "chain": f["chain"], "log_prob": f["log_prob"]}
    except (OSError, ValueError, KeyError) as exc:
        raise DataError(f"{path}: not a partial chain file ({exc})") from None


def load_chains(path) -> Chains:
    """Read chains written by :meth:`Chains.save`."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file; write chains with Chains.save or duffsym sample --chains")
    try:
        with np.load(path, allow_pickle=False) as f:
            arrays = {k: f[k] for k in f.files}
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: not a chains file ({exc})") from None
    if "meta" not in arrays or "chain" not in arrays:
        raise DataError(f"{path}: not a duffsym chains file (no chain/meta); write it with Chains.save")
    meta = json.loads(str(arrays["meta"]))
    return Chains(
        names=tuple(meta["names"]),
        chain=arrays["chain"],
        log_prob=arrays["log_prob"],
        acceptance=arrays["acceptance"],
        tau=arrays["tau"],
        burn=int(meta["burn"]),
        thin=int(meta["thin"]),
        optimum=arrays["optimum"],
        laplace_stderr=arrays["laplace_stderr"],
        laplace_cov=arrays["laplace_cov"],
        priors=tuple(Prior(**p) for p in meta["priors"]),
        counts=dict(meta["counts"]),
        sigma=arrays["sigma"],
        recheck=meta["recheck"],
        setup=meta["setup"],
        warnings=tuple(meta["warnings"]),
        settings=meta["settings"],
        timings=meta["timings"],
        fit=meta["fit"],
    )


# ---------------------------------------------------------------------------------------- tau
def autocorr_time(chain: np.ndarray) -> np.ndarray:
    """Integrated autocorrelation time per quantity of a (n_steps, n_walkers, n_dim) chain (emcee's
    estimator, walkers averaged, automatic window; no error when the chain is short)."""
    import emcee

    return np.asarray(emcee.autocorr.integrated_time(chain, c=5, tol=0, quiet=True), dtype=float)


# ---------------------------------------------------------------------------------------- sampling
def _initial_walkers(post: LogPosterior, result, n_walkers: int, spread: float, rng, phi0: float):
    """Walkers drawn from N(optimum, spread^2 * Laplace covariance) in the sampling coordinates (initial
    states and the AR(1) coefficient in a small ball), redrawn until each has a finite log-posterior (a small
    ball around the optimum when the covariance is unusable)."""
    names = list(result.free)
    theta = np.array([float(result.params[n]) for n in names])
    cov = np.asarray(result.covariance, dtype=float)
    values = list(theta)
    if post.x0_free:
        for sim in post.simulators:
            values += list(sim.x0)
    if post.noise == "ar1":
        values.append(phi0)
    z0 = post.coords(np.array(values))[0]
    n_free = len(names)
    D = np.array([1 / theta[j] if post.priors[j].kind == "log-uniform" else 1.0 for j in range(n_free)])
    ok_cov = bool(cov.shape == (n_free, n_free) and np.all(np.isfinite(cov)))
    if ok_cov:
        cz = cov * np.outer(D, D)
        w, V = np.linalg.eigh(0.5 * (cz + cz.T))
        ok_cov = bool(np.all(w > 0))
    L = None
    if ok_cov:
        L = V * np.sqrt(np.maximum(w, 0))
    scale_fallback = np.array(
        [1e-3 if p.kind == "log-uniform" else 1e-3 * max(abs(th), 1.0) for p, th in zip(post.priors[:n_free], theta)]
    )
    extra = np.array([1e-3 * (p.upper - p.lower) for p in post.priors[n_free:]])
    walkers = np.empty((n_walkers, post.n_dim))
    filled = 0
    for attempt in range(200):
        need = n_walkers - filled
        e = rng.standard_normal((need, n_free))
        dz = spread * (e @ L.T) if L is not None else e * scale_fallback
        cand = np.tile(z0, (need, 1))
        cand[:, :n_free] += dz
        if extra.size:
            cand[:, n_free:] += rng.standard_normal((need, extra.size)) * extra
        lp, _ = post.evaluate(cand)
        good = cand[np.isfinite(lp)]
        take = good[:need]
        walkers[filled : filled + take.shape[0]] = take
        filled += take.shape[0]
        if filled == n_walkers:
            return walkers, z0
        if attempt in (20, 60):  # the covariance may be far too wide (a ridge): shrink the ball
            spread *= 0.3
    raise ModelError(
        f"could not start {n_walkers} walkers with finite posterior around the optimum "
        f"({filled} found); is the fit converged and are its bounds wide enough?"
    )


def sample(result, records, model=None, options: SampleOptions | None = None, **settings) -> Chains:
    r"""Sample the posterior of a fit's free parameters with emcee.

    The settings are the fields of :class:`~duffsym.uncertainty.options.SampleOptions`, given as an ``options``
    object, by keyword (``sample(result, record, n_steps=2000)``), or both (the keywords win); an unknown setting
    raises :class:`TypeError`.

    Parameters
    ----------
    result : an :class:`~duffsym.identify.IdentificationResult` (from ``fit`` or ``load_result``); its
        free parameters are sampled, its fixed ones held, its mask and initial states kept; the model
        (with effects) is rebuilt by :func:`~duffsym.identify.model_from_result` unless ``model`` is given.
    records : the record(s) the fit was made on.
    n_walkers, n_steps : ensemble size (at least twice the dimension) and steps.
    burn : steps discarded (default: 3 tau, at most a third of the chain); ``thin`` default 1.
    noise : ``"gaussian"`` (white, sigma integrated out) or ``"ar1"`` (see :mod:`.posterior`).
    bounds : prior bounds by name (default the model's ``ParamSpec`` bounds).
    mask : per-record samples to leave out (default: the fit's mask when it has one).
    rng : seed or ``numpy.random.Generator`` of the walker starts and of emcee's moves.
    pool : an object with ``map`` (e.g. ``multiprocessing.Pool``) to evaluate walkers in processes;
        then the walkers are evaluated one by one. Without a pool all walkers are simulated in one
        call to the compiled batch kernel (numba threads), which is faster on one machine.
    vectorize : default ``pool is None``.
    progress : emcee's progress bar (tqdm), on stderr.
    init_spread : walkers start from N(optimum, init_spread^2 * Laplace covariance).
    h_rho : stiffness target h*rho(J) of the fixed substep schedule at the optimum; ``hrho_max`` the
        h*rho above which a walker's simulation is stopped as too stiff (log-posterior -inf).
    on_short : ``"warn"`` (:class:`~duffsym.errors.ConvergenceWarning`) or ``"raise"``
        (:class:`ChainTooShort`) when the kept chain is shorter than 50 tau.
    recheck_draws : posterior draws at which the schedule is compared with an accurate adaptive run.
    sigma_draws : draws of the noise level.
    moves : emcee moves (default :func:`default_moves`: DE + DE snooker; ``"stretch"`` for emcee's default).
    sample_x0 : sample each record's initial state too (uniform around the fit's, half the state's range
        each way). The fit estimated it; holding it at the optimum penalises every other parameter set
        (on the synthetic Table 2 record: ~4 in chi^2 at the truth) and narrows the intervals.
    checkpoint : a ``.npz`` path: the chain so far is written there (atomically) every
        ``checkpoint_every`` seconds and when the run is interrupted (KeyboardInterrupt, which is then
        re-raised), so an interrupt keeps what ran; see :func:`load_partial_chain`. The file is left
        in place after a complete run (the caller removes it once the full chains are saved).
    threads : numba threads of the batch kernel (None: numba's default). One batch of walkers is a
        short piece of work; on a shared machine waking a second thread can cost more than it saves,
        hence the default 1.

    Returns
    -------
    Chains
    """
    o = resolve(SampleOptions, options, settings, "sample")
    _check_counts(o)
    rng = np.random.default_rng(o.rng)
    t_start = time.perf_counter()
    post, model, records, setup = _build(result, records, model, o)
    p0, z_opt = _initial_walkers(post, result, int(o.n_walkers), float(o.init_spread), rng, _phi0(post, o.noise))
    t_setup = time.perf_counter() - t_start
    sampler, vectorize, move_label = _sampler(post, o, rng)
    t_run, cpu_run = _run_sampler(sampler, p0, post, result, o)
    zchain = sampler.get_chain()
    burn, thin, tau = _burn_thin_tau(zchain, o)
    acc = np.asarray(sampler.acceptance_fraction, dtype=float)
    counts = dict(post.counts)
    flat_z = zchain[burn :: max(thin, 1)].reshape(-1, post.n_dim)
    recheck = _recheck(post, model, flat_z, o.recheck_draws, rng)
    recheck["posterior_max_hrho"] = _posterior_hrho(post, flat_z)
    recheck["hrho_max"] = o.hrho_max
    warn = _chain_warnings(post, o, tau, burn, acc, counts, recheck)
    se = np.array(
        [float(result.stderr.get(n, math.nan)) for n in result.free] + [math.nan] * (post.n_dim - len(result.free))
    )
    chains = Chains(
        names=tuple(p.name for p in post.priors),
        chain=np.stack([post.natural(z) for z in zchain]),
        log_prob=sampler.get_log_prob(),
        acceptance=acc,
        tau=tau,
        burn=int(burn),
        thin=thin,
        optimum=post.natural(z_opt)[0],
        laplace_stderr=se,
        laplace_cov=np.asarray(result.covariance, dtype=float),
        priors=tuple(post.priors),
        counts=counts,
        sigma=_sigma_draws(post, flat_z, o.sigma_draws, rng),
        recheck=recheck,
        setup=setup,
        warnings=tuple(warn),
        settings=_settings_record(o, vectorize, move_label),
        timings={
            "setup": t_setup,
            "sampling": t_run,
            "sampling_cpu": cpu_run,
            "per_step": t_run / o.n_steps,
            "per_walker_step": t_run / (o.n_steps * o.n_walkers),
            "total": time.perf_counter() - t_start,
        },
        fit={
            "model": result.model,
            "effects": list(result.effects),
            "params": dict(result.params),
            "free": list(result.free),
            "fixed": dict(result.fixed),
            "nrmse": float(result.nrmse),
        },
    )
    if warn and o.n_steps - burn < MIN_TAUS * np.max(tau) and o.on_short == "raise":
        raise ChainTooShort(warn[0], tau=dict(zip(chains.names, tau.tolist())), chains=chains)
    for w in warn:
        warnings.warn(w, ConvergenceWarning, stacklevel=2)
    return chains


def _check_counts(o: SampleOptions) -> None:
    if o.on_short not in ("warn", "raise"):
        raise ModelError(f"on_short must be 'warn' or 'raise'; got {o.on_short!r}")
    for label, v, least in (
        ("n_steps", o.n_steps, 2),
        ("recheck_draws", o.recheck_draws, 0),
        ("sigma_draws", o.sigma_draws, 0),
    ):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
            raise ModelError(f"{label} must be an integer >= {least}; got {v!r}")


def _build(result, records, model, o: SampleOptions):
    """(posterior, model, records, setup) of :func:`~duffsym.uncertainty._setup.build_posterior`, with the walker
    count checked against its dimension."""
    from duffsym.uncertainty._setup import build_posterior

    post, model, records, setup = build_posterior(
        result,
        records,
        model=model,
        bounds=o.bounds,
        noise=o.noise,
        mask=o.mask,
        h_rho=o.h_rho,
        hrho_max=o.hrho_max,
        sample_x0=o.sample_x0,
    )
    n_walkers = o.n_walkers
    if isinstance(n_walkers, bool) or not isinstance(n_walkers, (int, np.integer)) or n_walkers < 2 * post.n_dim:
        raise ModelError(f"n_walkers must be an integer >= 2 x {post.n_dim} (the dimension); got {n_walkers!r}")
    return post, model, records, setup


def _phi0(post: LogPosterior, noise: str) -> float:
    """The AR(1) coefficient's start: the lag-1 correlation of the optimum's residuals (0 with white noise)."""
    if noise != "ar1":
        return 0.0
    P = np.atleast_2d(post.base)
    rs = [(sim.run(P)[0][0] - y)[k] for sim, y, k in zip(post.simulators, post.ys, post.keep)]
    r = np.concatenate(rs)
    return float(np.clip(np.sum(r[1:] * r[:-1]) / np.sum(r * r), -0.9, 0.9)) if r.size > 2 else 0.0


def _sampler(post: LogPosterior, o: SampleOptions, rng):
    """(emcee's ensemble sampler, whether it is vectorized, the moves' label), its random state from ``rng``."""
    import emcee

    vectorize = o.pool is None if o.vectorize is None else bool(o.vectorize)
    fn: _Vectorized | _Serial
    if vectorize:
        fn, pool_arg = _Vectorized(post), None
    else:
        fn, pool_arg = (
            _Serial(post),
            (_CountingPool(o.pool, post) if o.pool is not None else _CountingPool(_Map(), post)),
        )
    moves = o.moves
    move_label = "de+snooker" if moves is None else ("stretch" if moves == "stretch" else str(moves))
    moves = default_moves() if moves is None else (None if moves == "stretch" else moves)
    sampler = emcee.EnsembleSampler(int(o.n_walkers), post.n_dim, fn, vectorize=vectorize, pool=pool_arg, moves=moves)
    if not getattr(sampler.log_prob_fn, "args", ()) and not getattr(sampler.log_prob_fn, "kwargs", {}):
        # emcee's wrapper prints a traceback for any exception, Ctrl-C included; our function needs no wrapper
        sampler.log_prob_fn = getattr(sampler.log_prob_fn, "f", sampler.log_prob_fn)
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31 - 1))).get_state()
    return sampler, vectorize, move_label


def _run_sampler(sampler, p0, post, result, o: SampleOptions) -> tuple[float, float]:
    """Run the chain (``o.threads`` numba threads, checkpoints); (wall, CPU) seconds."""
    import numba

    old_threads = numba.get_num_threads()
    t0 = time.perf_counter()
    c0 = time.process_time()
    try:
        if o.threads is not None:
            # numba.config sets NUMBA_NUM_THREADS when numba is imported: an attribute mypy cannot see
            most = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
            numba.set_num_threads(max(1, min(int(o.threads), most)))
        _run_with_checkpoints(sampler, p0, int(o.n_steps), o.progress, post, o.checkpoint, o.checkpoint_every, result)
    finally:
        numba.set_num_threads(old_threads)
    return time.perf_counter() - t0, time.process_time() - c0


def _burn_thin_tau(zchain: np.ndarray, o: SampleOptions) -> tuple[int, int, np.ndarray]:
    """(burn, thin, tau after the burn): burn by default 3 tau of the whole chain, at most a third of it."""
    n_steps, burn = o.n_steps, o.burn
    tau_full = autocorr_time(zchain)
    if burn is None:
        tau_max = float(np.max(tau_full)) if np.all(np.isfinite(tau_full)) else math.inf  # too short to estimate
        burn = int(min(n_steps // 3, math.ceil(3 * tau_max))) if math.isfinite(tau_max) else n_steps // 3
    if not 0 <= burn < n_steps - 1:
        raise ModelError(f"burn must be in [0, {n_steps - 1}); got {burn}")
    thin = 1 if o.thin is None else int(o.thin)
    return burn, thin, autocorr_time(zchain[burn:])


def _chain_warnings(post, o: SampleOptions, tau, burn: int, acc, counts: dict, recheck: dict) -> list[str]:
    """What a person should know about the chain: too short, acceptance, failed proposals near the stiffness
    limit, a substep schedule off at posterior draws."""
    warn = []
    kept = o.n_steps - burn
    if kept < MIN_TAUS * np.max(tau):
        worst = post.priors[int(np.argmax(tau))].name
        warn.append(
            f"chain of {kept} kept steps is shorter than {MIN_TAUS} tau (tau = {np.max(tau):.0f} steps for "
            f"{worst}): run at least {int(math.ceil(MIN_TAUS * np.max(tau) + burn))} steps"
        )
    if not ACCEPTANCE_RANGE[0] <= float(np.mean(acc)) <= ACCEPTANCE_RANGE[1]:
        warn.append(f"mean acceptance fraction {np.mean(acc):.2f} is outside {ACCEPTANCE_RANGE}")
    n_eval = sum(counts.values())
    n_fail = counts[Status.BLOW_UP.value] + counts[Status.TOO_STIFF.value]
    if n_fail and recheck["posterior_max_hrho"] > 0.75 * o.hrho_max:
        warn.append(
            f"{n_fail} of {n_eval} proposals failed to simulate ({counts[Status.BLOW_UP.value]} blow-up, "
            f"{counts[Status.TOO_STIFF.value]} too stiff for the fixed substep schedule) and the posterior "
            f"reaches h*rho = {recheck['posterior_max_hrho']:.2g} (stop at {o.hrho_max:g}): the stiffness "
            "limit may cut the posterior; rerun with a smaller h_rho"
        )
    if recheck.get("max_bias", 0.0) > 0.1:
        warn.append(
            f"the fixed substep schedule is off at some posterior draws (bias statistic "
            f"{recheck['max_bias']:.2g} > 0.1 noise sd / sqrt(N)): rerun with a smaller h_rho"
        )
    return warn


def _settings_record(o: SampleOptions, vectorize: bool, move_label: str) -> dict:
    """The settings a chain records (``Chains.settings``)."""
    import emcee

    return {
        "n_walkers": int(o.n_walkers),
        "n_steps": int(o.n_steps),
        "noise": o.noise,
        "h_rho": o.h_rho,
        "sample_x0": bool(o.sample_x0),
        "hrho_max": o.hrho_max,
        "init_spread": o.init_spread,
        "vectorize": vectorize,
        "pool": type(o.pool).__name__ if o.pool is not None else None,
        "moves": move_label,
        "emcee": emcee.__version__,
        "threads": o.threads,
    }


class _Map:
    """The built-in map as a pool (serial evaluation with status counts)."""

    def map(self, fn, iterable):
        return list(map(fn, iterable))


def _pick(rng, n_total: int, n: int) -> np.ndarray:
    return rng.choice(n_total, size=min(n, n_total), replace=False) if n_total else np.zeros(0, dtype=int)


def _recheck(post: LogPosterior, model, flat_z: np.ndarray, n: int, rng) -> dict:
    """Compare the fixed-schedule output with an accurate adaptive run (h*rho <= 0.1) at posterior draws.

    The statistic ``sqrt(N) * rms(dy) / sigma`` bounds the shift of a parameter, in posterior standard
    deviations, that the discretisation error can cause; below ~0.1 it is negligible."""
    from duffsym.simulate import simulate

    if n == 0:
        return {}
    idx = _pick(rng, flat_z.shape[0], n)
    P = post.params(flat_z[idx])
    worst, worst_rel, n_fail = 0.0, 0.0, 0
    for r, (sim, y, keep) in enumerate(zip(post.simulators, post.ys, post.keep)):
        X0 = post.initial_states(flat_z[idx], r)
        X0 = np.tile(sim.x0, (P.shape[0], 1)) if X0 is None else X0
        Y, status, _, _ = sim.run(P, X0)
        for i in range(P.shape[0]):
            ref = simulate(model, P[i], sim.t, sim.U, x0=X0[i], h_lambda=0.1, on_failure="return")
            if status[i] != 0 or not ref.success:
                n_fail += 1
                continue
            dy = (Y[i] - ref.y)[keep]
            sigma = np.sqrt(np.mean((ref.y - y)[keep] ** 2))
            stat = math.sqrt(keep.sum()) * float(np.sqrt(np.mean(dy**2))) / max(sigma, 1e-300)
            worst = max(worst, stat)
            worst_rel = max(worst_rel, float(np.max(np.abs(dy)) / max(np.max(np.abs(ref.y)), 1e-300)))
    return {"draws": int(P.shape[0]), "max_bias": worst, "max_rel_error": worst_rel, "failed": n_fail}


def _posterior_hrho(post: LogPosterior, flat_z: np.ndarray, n: int = 2000) -> float:
    """Largest h*rho(J) the fixed schedule meets at (up to n evenly spread) posterior samples. The schedule
    is built for h*rho <= h_rho (1) at the optimum; well below the stop value (2), the failed proposals were
    far-out ones and did not truncate the posterior (a warning above 0.75 x the stop value)."""
    if flat_z.shape[0] == 0:
        return float("nan")
    step = max(1, flat_z.shape[0] // n)
    z = flat_z[::step]
    P = post.params(z)
    return float(max(np.max(sim.run(P, post.initial_states(z, r))[3]) for r, sim in enumerate(post.simulators)))


def _sigma_draws(post: LogPosterior, flat_z: np.ndarray, n: int, rng) -> np.ndarray:
    """Noise level per record at posterior draws: sigma^2 = SSR / chi2_N (the conditional posterior under 1/sigma)."""
    if n == 0:
        return np.zeros((0, len(post.simulators)))
    idx = _pick(rng, flat_z.shape[0], n)
    ssrs, code = post.ssr(flat_z[idx])
    out = np.column_stack([np.sqrt(s / rng.chisquare(n_obs, size=s.size)) for s, n_obs in zip(ssrs, post.n_obs)])
    return out[code == 0]
