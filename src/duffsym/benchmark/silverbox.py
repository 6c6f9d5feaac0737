r"""The Silverbox benchmark (Wigren & Schoukens 2013) by its own protocol: three scores in mV.

Data (``external_data_dir()/silverbox/SNLS80mV.csv``, SOURCE.md there). Official split
(:data:`duffsym.data.SILVERBOX_PARTS`, after the ``nonlinear_benchmarks`` loader): the model is
estimated on ``multisine_train`` only; the scores are the free-run RMSE in mV on ``multisine_test``,
``arrow_full`` and ``arrow_no_extrapolation``, each skipping its first ``N_SKIP = 50`` samples, which
may be used to set the initial state (here: the position and velocity fitted by least squares to
those 50 samples; the effects' states start from their data-based guess).

Model: ``duffing-gain`` (Eq. 1 with an input gain) with the effects ``effects`` added in order — by
default those the ladder of study ``s10`` chose on the estimation data (force-offset, input-curvature,
quadratic-stiffness, cubic-damping). Estimation: base fit on a segment of the estimation data, each
effect added by :func:`duffsym.identify.fit_with_effects` from the previous step's parameters, then a
refit on ``refit_len`` samples. The input derivative the effects see is the band-limited one
(:func:`duffsym.identify.structure.bandlimited_derivative`), computed on the whole part before slicing.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from duffsym.benchmark.result import BenchmarkResult, Published

if TYPE_CHECKING:
    from duffsym.model.core import SymbolicModel

N_SKIP = 50
N_NO_EXTRAPOLATION = 32000
#: Published RMSE [mV] (sources: ``shared/data/external/README.md``).
PUBLISHED = (
    Published(
        "SUBNET nx=4 (Beintema et al. 2021)",
        {"arrow_full": 1.406, "arrow_no_extrapolation": 0.316},
        "arXiv:2012.07697; printed output of GerbenBeintema/SS-encoder-WH-Silver @6b531a1 notebook",
    ),
    Published("SUBNET nx=8 (Beintema et al. 2021)", {"arrow_full": 2.001, "arrow_no_extrapolation": 0.307}, "same"),
)
#: The effects the ladder of study s10 chose on the estimation data (in order).
LADDER_EFFECTS = ("force-offset", "input-curvature", "quadratic-stiffness", "cubic-damping")


@dataclass(frozen=True)
class SilverboxOptions:
    """Every option of the Silverbox run (the defaults are what ``duffsym benchmark silverbox`` uses)."""

    effects: tuple = LADDER_EFFECTS
    seg_start: int = 500  # first estimation sample of the stepwise fit
    seg_len: int = 4000  # samples of the stepwise fit
    refit_len: int = 16000  # samples of the final refit (0: none)
    max_iter: int = 300
    substeps: int = 16  # RK4 substeps per sample of the scored free runs

    @classmethod
    def smoke(cls) -> SilverboxOptions:
        return cls(effects=("force-offset",), seg_len=1200, refit_len=0)


def with_bandlimited_rate(rec):
    """``rec`` with the input rate ``d_dot`` from the band-limited differentiator."""
    from duffsym.identify.structure import bandlimited_derivative

    return rec.replace(d_dot=bandlimited_derivative(rec.d, rec.dt))


def build(effects):
    """``duffing-gain`` with the catalogued effects in order."""
    from duffsym.effects import CATALOGUE, apply_effects
    from duffsym.model.library import get_model

    return apply_effects(get_model("duffing-gain"), [CATALOGUE[e] for e in effects])


def initial_state(model, params: dict, rec, n_init: int = N_SKIP) -> np.ndarray:
    """Initial state for a free run of ``rec``: the data-based guess, with the position and velocity
    fitted by least squares to the first ``n_init`` output samples."""
    from scipy.optimize import least_squares

    from duffsym.identify.states import initial_states
    from duffsym.simulate import simulate_record

    p = model.param_vector(params)
    x0 = np.array(initial_states(model, rec, p)[0], dtype=float)
    head = rec.slice(0, n_init)
    ip, iv = model.states.index(model.position), model.states.index(model.velocity)

    def res(z):
        x = x0.copy()
        x[ip], x[iv] = z
        tr = simulate_record(model, p, head, x0=x, on_failure="return")
        return (np.asarray(tr.y) - head.y) if tr.success else np.full(head.n_times, 1.0)

    sol = least_squares(res, [x0[ip], x0[iv]], x_scale=[max(abs(x0[ip]), 1e-3), max(abs(x0[iv]), 1e-1)])
    x0[ip], x0[iv] = sol.x
    return x0


def free_run(model, params: dict, rec, *, substeps="auto", info: dict | None = None) -> np.ndarray:
    """The benchmark's scored free run: :func:`duffsym.simulate.simulate_record` of ``model`` on ``rec`` from
    :func:`initial_state` (the position and velocity fitted to the first ``N_SKIP`` samples), its output with
    NaN where it fails; ``info`` receives whether it succeeded and the most substeps it used."""
    from duffsym.simulate import simulate_record

    tr = simulate_record(
        model,
        model.param_vector(params),
        rec,
        x0=initial_state(model, params, rec),
        substeps=substeps,
        on_failure="return",
    )
    y = np.asarray(tr.y, dtype=float)
    if info is not None:
        sub = np.asarray(tr.substeps)
        info.update(success=bool(tr.success), max_substeps=int(sub.max()) if sub.size else None)
    if not tr.success:
        y = np.where(np.isfinite(y), y, np.nan)
    return y


def rmse_mv(y, yhat) -> float:
    """The benchmark's score: RMSE in mV skipping the first ``N_SKIP`` samples."""
    e = (np.asarray(y) - np.asarray(yhat))[N_SKIP:]
    return float(1e3 * np.sqrt(np.mean(e**2)))


def scores(y, yhat) -> tuple[float, float]:
    """RMSE in mV on the full arrow and on its no-extrapolation part (first 50 samples skipped)."""
    e = (np.asarray(y) - np.asarray(yhat))[N_SKIP:]
    full = float(1e3 * np.sqrt(np.mean(e**2)))
    part = float(1e3 * np.sqrt(np.mean(e[: N_NO_EXTRAPOLATION - N_SKIP] ** 2)))
    return full, part


def estimate(train, options: SilverboxOptions = SilverboxOptions(), progress=None) -> tuple[SymbolicModel, dict, dict]:
    """``(model, params, details)``: the stepwise fit on the estimation segment, then the refit."""
    from duffsym.effects import CATALOGUE
    from duffsym.identify import Problem, fit, fit_with_effects
    from duffsym.simulate import simulate

    say = progress or (lambda m: None)
    seg = train.slice(options.seg_start, options.seg_start + options.seg_len)
    effects: tuple = ()
    model = build(effects)
    say(f"base fit (duffing-gain) on {seg.n_times} samples")
    r = fit(Problem(model, seg), max_iter=options.max_iter)
    params, steps = dict(r.params), [{"effects": [], "nrmse": float(r.nrmse), "success": bool(r.success)}]
    for name in options.effects:
        y_prev = simulate(model, params, np.asarray(seg.t), seg.inputs_for(model), x0=r.x0[0], on_failure="return").y
        effects += (name,)
        model = build(effects)
        say(f"+ {name}")
        r = fit_with_effects(Problem(model, seg), [CATALOGUE[name]], params, y_prev, max_iter=options.max_iter)
        if r.success:
            params = dict(r.params)
        steps.append({"effects": list(effects), "nrmse": float(r.nrmse), "success": bool(r.success)})
    details: dict[str, Any] = {"steps": steps}
    if options.refit_len:
        rec = train.slice(options.seg_start, options.seg_start + options.refit_len)
        say(f"refit on {rec.n_times} samples")
        r = fit(Problem(model, rec), params, max_iter=options.max_iter, compute_stderr=False)
        details.update(refit_success=bool(r.success), refit_nrmse=float(r.nrmse), refit_status=r.status)
        if r.success:
            params = dict(r.params)
    return model, params, details


def score_silverbox(path, model, params, *, substeps=16, predictions: dict | None = None) -> dict:
    """The three official scores [mV] of ``model`` with ``params`` (``path``: SNLS80mV.csv); ``predictions``
    receives each test set's free run (volts)."""
    from duffsym.data.loaders import load_silverbox

    out = {}
    for part in ("multisine_test", "arrow_full", "arrow_no_extrapolation"):
        test = with_bandlimited_rate(load_silverbox(path, part=part))
        y_hat = free_run(model, params, test, substeps=substeps)
        key = part.replace("multisine_test", "multisine")
        out[key] = rmse_mv(test.y, y_hat)
        if predictions is not None:
            predictions[key] = (np.asarray(test.y), y_hat)
    return out


def run_silverbox(folder=None, options: SilverboxOptions = SilverboxOptions(), progress=None) -> BenchmarkResult:
    """Estimate on ``multisine_train`` and score the three official test sets (module docstring)."""
    from duffsym.data.loaders import external_data_dir, load_silverbox

    t0 = time.perf_counter()
    path = external_data_dir() / "silverbox" if folder is None else folder
    path = path / "SNLS80mV.csv"
    train = with_bandlimited_rate(load_silverbox(path, part="multisine_train"))
    model, params, details = estimate(train, options, progress)
    out = score_silverbox(path, model, params, substeps=options.substeps)
    notes = []
    for p in PUBLISHED[:1]:
        worse = [k for k, v in p.scores.items() if not out[k] < v]
        if worse:
            notes.append(f"not better than {p.name} on {', '.join(worse)}")
    protocol = {
        **asdict(options),
        "estimation": "multisine_train (rows 40650..105712) only",
        "skip": f"first {N_SKIP} samples of each test set (used to fit the initial position and velocity)",
        "score": "RMSE of the free run in mV",
        "input_rate": "band-limited differentiator (31 taps)",
        "effects_choice": "the ladder of study s10 on the estimation data (default effects)",
    }
    return BenchmarkResult(
        benchmark="silverbox",
        unit="mV",
        scores=out,
        model="duffing-gain",
        effects=tuple(model.effects),
        n_params=model.n_params,
        seconds=time.perf_counter() - t0,
        protocol=protocol,
        params={k: float(v) for k, v in params.items()},
        published=PUBLISHED,
        notes=tuple(notes),
        details=details,
    )
