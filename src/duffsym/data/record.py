"""A measured (or synthetic) experiment: validated once, read-only afterwards.

A :class:`Record` holds one single-input single-output test: time ``t``, the input ``d`` (the
piston displacement for the MR damper models, the force ``F`` for the Duffing oscillator), an
optional input velocity ``d_dot`` and the output ``y`` (the damper force). Everything is checked
once, in the constructor; later code trusts the arrays, which are float copies marked
read-only.

When the velocity is absent it is derived from ``d`` by a Savitzky–Golay derivative (a centred
FIR filter: zero lag, and an amplitude bias that is measured in the tests, below 1e-4 at
2 Hz with dt = 0.005 s and the default window). It needs uniform sampling, which is checked there
and not in the constructor.

Time stamps printed with rounding (a 3004.8 Hz grid stamped to 0.1 ms steps by 0.0003 or 0.0004 s)
are recognised in the constructor and replaced by the uniform grid they round
(:func:`rebuild_rounded_grid`); ``metadata["sampling"]`` says what was done (rate, rule).
"""

from __future__ import annotations

import math
import types
import warnings
from collections.abc import Mapping
from dataclasses import InitVar, dataclass, field
from typing import Any

import numpy as np

from duffsym._checks import require_increasing
from duffsym._typing import Float1D
from duffsym.errors import DataError

#: Fewest samples a record may hold.
MIN_SAMPLES = 20
#: Slow signals a drifting parameter can follow (:meth:`Record.drift_signal`), usable as model inputs.
DRIFT_SIGNALS = ("time", "energy")

#: Names a command history may carry (the CSV columns of ``docs/contract.md``).
COMMAND_NAMES = ("current", "voltage", "pressure")
#: The unit each command is reported in (a pressure in the file's own unit).
COMMAND_UNITS = {"current": "A", "voltage": "V", "pressure": "(pressure units)"}
NAN_POLICIES = ("raise", "omit")
#: Relative spread of the sampling step tolerated as "uniform".
UNIFORM_RTOL = 1e-6


def _as_vector(name: str, values, where: str) -> np.ndarray:
    try:
        arr = np.array(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(
            f"{where}: {name} must be numeric; could not convert it to float ({exc}); clean the column"
        ) from exc
    if arr.ndim != 1:
        arr = arr.reshape(-1) if arr.ndim == 2 and 1 in arr.shape else arr
    if arr.ndim != 1:
        raise DataError(f"{where}: {name} must be 1-D (one value per sample); got shape {arr.shape}")
    return arr


#: Signals must lie within these magnitudes: squares and sums of squares of larger (smaller) values
#: overflow (underflow) double precision somewhere in the fit.
MAGNITUDE_RANGE = (1e-100, 1e100)


def _check_magnitude(name: str, a: np.ndarray, where: str) -> None:
    peak = float(np.max(np.abs(a))) if a.size else 0.0
    lo, hi = MAGNITUDE_RANGE
    if peak > hi:
        raise DataError(
            f"{where}: signal {name} is too large (max |{name}| = {peak:.3g} > {hi:g}); rescale it "
            "(e.g. change its units)"
        )
    if 0.0 < peak < lo:
        raise DataError(
            f"{where}: signal {name} is too small (max |{name}| = {peak:.3g} < {lo:g}); rescale it "
            "(e.g. change its units)"
        )


def zero_crossings(d: np.ndarray) -> np.ndarray:
    """Indices ``i`` where ``d - mean(d)`` changes sign between samples ``i`` and ``i + 1``.

    Samples within ``1e-9 max|d - mean|`` of the mean are skipped (they carry no sign).
    """
    v = np.asarray(d, dtype=float) - np.mean(d)
    tol = 1e-9 * max(np.max(np.abs(v)), 1e-300)
    idx = np.flatnonzero(np.abs(v) > tol)
    s = np.sign(v[idx])
    change = np.flatnonzero(s[1:] != s[:-1])
    return idx[change]


def savgol_derivative(values: np.ndarray, dt: float, window: int, polyorder: int = 3) -> np.ndarray:
    r"""First derivative by a Savitzky–Golay filter (least-squares polynomial of ``polyorder`` over
    ``window`` samples, differentiated at the centre).

    The filter is centred, so it has no lag; it is exact for polynomials up to ``polyorder``.
    For a sine of :math:`\theta = \omega\,dt` rad per sample its gain is
    :math:`1 - O((\theta\,w/2)^{4})` for ``polyorder`` 3.

    References
    ----------
    A. Savitzky and M. J. E. Golay, Anal. Chem. 36 (1964) 1627, doi:10.1021/ac60214a047.
    """
    from scipy.signal import savgol_filter

    return savgol_filter(values, window_length=window, polyorder=polyorder, deriv=1, delta=dt, mode="interp")


def printed_quantum(values: np.ndarray, max_digits: int = 15) -> np.ndarray:
    """Per value, the last printed digit's unit ``10**-d``: the smallest ``d`` (0..``max_digits``) for
    which the value is an integer multiple of ``10**-d`` (to double precision). ``24.6496`` -> 1e-4,
    ``0.0003328`` -> 1e-7; a value computed in double precision (``k / fs``) gets ``10**-max_digits``."""
    v = np.abs(np.asarray(values, dtype=float))
    q = np.full(v.shape, 10.0**-max_digits)
    todo = np.ones(v.shape, dtype=bool)
    for d in range(max_digits + 1):
        scaled = v[todo] * 10.0**d
        hit = np.abs(scaled - np.round(scaled)) <= 1e-9 * np.maximum(scaled, 1.0)
        idx = np.flatnonzero(todo)[hit]
        q[idx] = 10.0**-d
        todo[idx] = False
        if not todo.any():
            break
    return q


def _grid_precision(t: np.ndarray) -> np.ndarray:
    """The printed precision of each time stamp: the finest :func:`printed_quantum` among the stamps of
    the same decade (a value printed without its trailing zeros, ``24.65`` for ``24.6500``, shows
    fewer digits than it has; fixed-decimal and significant-digit printing both give one precision
    per decade). A zero constrains nothing (it is printed ``0`` at any precision)."""
    q = printed_quantum(t)
    nz = t != 0.0
    decade = np.zeros(t.shape, dtype=int)
    decade[nz] = np.floor(np.log10(np.abs(t[nz]))).astype(int)
    out = q.copy()
    for d in np.unique(decade[nz]):
        sel = nz & (decade == d)
        out[sel] = np.min(q[sel])
    out[~nz] = np.max(out[nz]) if nz.any() else 1.0
    return out


def _chebyshev_line(t: np.ndarray, weight: np.ndarray) -> tuple[float, float, float]:
    """``(t0, dt, r)`` minimising ``r = max_k |t_k - t0 - k dt| * weight_k`` (a small linear program)."""
    from scipy.optimize import linprog
    from scipy.sparse import csr_matrix, hstack, vstack

    k = np.arange(t.size, dtype=float)
    ones = np.ones(t.size)
    base = csr_matrix(np.column_stack([ones, k]))
    w = csr_matrix(1.0 / weight).T
    # t0 + k dt - r/w <= t  and  -(t0 + k dt) - r/w <= -t
    A = vstack([hstack([base, -w]), hstack([-base, -w])]).tocsr()
    b = np.concatenate([t, -t])
    res = linprog([0.0, 0.0, 1.0], A_ub=A, b_ub=b, bounds=[(None, None), (None, None), (0, None)], method="highs")
    if not res.success:
        return math.nan, math.nan, math.inf
    t0, dt, r = res.x
    return float(t0), float(dt), float(r)


#: A stamp rounded twice (first to a finer digit, e.g. 7 decimals, then printed to 4) lies up to half a
#: printed digit plus the first rounding (at most a twentieth of it) from its grid: measured on 30 random
#: grids (200-5000 Hz, 2000-80 000 samples) rounded to 7 then 4 decimals, 28 were refused at exactly 1/2.
DOUBLE_ROUNDING = 0.05

#: Steps that differ by no more than this many units in the last place of the largest stamp are equal:
#: float64 cannot hold them closer (t starting at 1e9 s: 1.2e-7 s apart).
ULP_STEPS = 4


def rebuild_rounded_grid(t: np.ndarray, rtol: float = UNIFORM_RTOL) -> tuple[np.ndarray, dict[str, Any]]:
    """Recognise a uniform time grid printed with rounding and rebuild it.

    Returns ``(t, sampling)``. When the steps are uniform within ``rtol`` the times are returned as
    given. Otherwise each stamp's printed precision ``q_k`` (:func:`printed_quantum`) is found and a
    line ``t0 + k dt`` is sought with every stamp within ``q_k / 2`` of it (weighted least squares,
    then the minimax line if needed): if it exists, and at least 3 steps (and 0.1 % of them) differ from the
    median, the stamps are a uniform grid rounded to their printed digits (or truncated) and the line
    replaces them. Otherwise the sampling is non-uniform and the
    times are returned as given. ``sampling`` holds ``rate_hz``, ``dt``, ``uniform`` (bool),
    ``rebuilt`` (bool) and ``rule`` (a sentence).
    """
    t = np.asarray(t, dtype=float)
    steps = np.diff(t)
    dt_med = float(np.median(steps))
    if np.all(np.abs(steps - dt_med) <= rtol * dt_med):
        dt = float((t[-1] - t[0]) / (t.size - 1))
        return t, {
            "rate_hz": 1.0 / dt,
            "dt": dt,
            "uniform": True,
            "rebuilt": False,
            "rule": "uniform as given (steps equal within 1e-6 relative)",
        }
    resolution = ULP_STEPS * float(np.spacing(np.max(np.abs(t))))
    if np.all(np.abs(steps - dt_med) <= resolution) and resolution < 0.01 * dt_med:
        dt = float((t[-1] - t[0]) / (t.size - 1))
        return t, {
            "rate_hz": 1.0 / dt,
            "dt": dt,
            "uniform": True,
            "rebuilt": False,
            "rule": f"uniform as given (steps equal within the float64 resolution of the stamps, "
            f"{resolution:.2g} s at t = {float(np.max(np.abs(t))):.6g} s)",
        }
    q = _grid_precision(t)
    k = np.arange(t.size, dtype=float)
    n_off = int(np.count_nonzero(np.abs(steps - dt_med) > rtol * dt_med))
    # rounding must be evident: a rounded grid whose step is not a whole number of printed digits
    # jumps often; one or two odd steps are more likely a glitch (a lost sample, a clock slip)
    feasible = bool(np.max(q) < dt_med) and n_off >= max(3, 0.001 * steps.size)
    if feasible:
        dt, t0 = np.polyfit(k, t, 1, w=1.0 / q)
        ratio = float(np.max(np.abs(t - t0 - k * dt) / q))
        if ratio > 0.5:
            t0, dt, ratio = _chebyshev_line(t, 1.0 / q)
        feasible = ratio <= (0.5 + DOUBLE_ROUNDING) * (1 + 1e-9)
    if not feasible:
        return t, {
            "rate_hz": 1.0 / dt_med,
            "dt": dt_med,
            "uniform": False,
            "rebuilt": False,
            "rule": "non-uniform: the steps vary by more than the printed digits explain "
            f"(from {steps.min():.6g} to {steps.max():.6g} s)",
        }
    digits = sorted({f"{v:g}" for v in np.unique(q)})
    rebuilt = t0 + k * dt
    finer = " (plus a first rounding to finer digits)" if ratio > 0.5 + 1e-9 else ""
    return rebuilt, {
        "rate_hz": 1.0 / float(dt),
        "dt": float(dt),
        "uniform": True,
        "rebuilt": True,
        "max_change_s": float(np.max(np.abs(rebuilt - t))),
        "rule": (
            f"rebuilt: time stamps printed to {', '.join(digits)} s (steps from {steps.min():.6g} to "
            f"{steps.max():.6g} s) are all within half a printed digit{finer} of t0 + k*dt; "
            f"t = {float(t0) + 0.0:.9g} + k * {float(dt):.9g} s ({1.0 / float(dt):.8g} Hz)"
        ),
    }


#: A sampling step at or above this (s) reads like a time column in milliseconds (mechanical tests are
#: sampled at 10 Hz - 10 kHz; 5 ms printed as 5 gives "dt 5 s, 0.2 Hz").
MS_LIKE_STEP = 0.5


def time_unit_note(t) -> str | None:
    """A note when the time column looks like milliseconds (a step of :data:`MS_LIKE_STEP` s or more),
    else None. The fitted rates (damping, stiffness per s^2, field rate) depend on the time unit."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return None
    dt = float(np.median(np.diff(t)))
    if not dt >= MS_LIKE_STEP:
        return None
    return (
        f"the sampling step is {dt:g} s ({1.0 / dt:.3g} Hz) over {float(t[-1] - t[0]):g} s: if the time column "
        f"is in milliseconds, divide it by 1000 (convert: --dt {dt / 1000:g} without the time column); rates and "
        "fitted parameters depend on the time unit"
    )


def _sampling(t: np.ndarray, previous: Mapping[str, Any] | None) -> tuple[np.ndarray, dict[str, Any]]:
    """The record's time base and its ``sampling`` metadata (:func:`rebuild_rounded_grid`); a grid
    rebuilt earlier (``previous``) keeps its rule when a slice or copy of it is validated again."""
    if previous and previous.get("keep_stamps"):  # read_csv(..., sampling="as-given"): never rebuild
        steps = np.diff(t)
        dt = float(np.median(steps))
        uniform = bool(np.all(np.abs(steps - dt) <= UNIFORM_RTOL * dt))
        return t, {
            "rate_hz": 1.0 / dt,
            "dt": dt,
            "uniform": uniform,
            "rebuilt": False,
            "keep_stamps": True,
            "rule": "as given (sampling='as-given'): "
            + ("uniform" if uniform else f"non-uniform, steps from {steps.min():.6g} to {steps.max():.6g} s"),
        }
    t, info = rebuild_rounded_grid(t)
    try:
        same = (
            previous is not None
            and bool(previous["uniform"]) == info["uniform"]
            and not info["rebuilt"]
            and abs(info["dt"] - float(previous["dt"])) <= 1e-9 * info["dt"]
            and isinstance(previous["rule"], str)
        )
    except (KeyError, TypeError, ValueError):
        same = False
    if same and previous is not None:
        info = dict(previous)
    return t, info


@dataclass(frozen=True, eq=False)
class Record:
    """One measured or synthetic experiment, validated once and read-only.

    Parameters
    ----------
    t : (n_times,) sample times, s; strictly increasing.
    d : (n_times,) input (piston displacement for the MR damper; force for ``duffing``).
    y : (n_times,) output (damper force; displacement for ``duffing``).
    d_dot : (n_times,) input velocity, or None to derive it from ``d`` (:meth:`velocity`).
    current, voltage : coil current (A) / voltage (V) of the test, if known and constant.
    units : unit of each signal by name (``{"t": "s", "d": "mm", "y": "N"}``); free text.
    metadata : anything else (source file, truth of a synthetic record, ...); stored read-only.
    source : where the record came from (a path or a description), used in messages.
    name : a short label (defaults to the source's last part).
    command : (n_times,) the command history (coil current or voltage) when it varies in time, else
        None; ``command_name`` says which (``"current"`` or ``"voltage"``). Models driven by the
        command (``mr-damper-current``) read it through :meth:`command_signal`, which falls back to
        the constant ``current``/``voltage``.
    nan_policy : ``"raise"`` (default) or ``"omit"``: drop every sample where any signal is
        NaN/inf, with a warning giving the count.

    Raises
    ------
    DataError
        Non-numeric or mismatched arrays, NaN/inf (with ``nan_policy="raise"``), fewer than 20
        samples, non-increasing time, a constant input or output, less than one excitation cycle
        (fewer than 2 sign changes of ``d - mean(d)``).
    """

    t: Float1D
    d: Float1D
    y: Float1D
    d_dot: Float1D | None = None
    current: float | None = None
    voltage: float | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    metadata: Mapping[str, Any] = field(default_factory=dict)
    source: str = ""
    name: str = ""
    command: Float1D | None = None
    command_name: str = ""
    nan_policy: InitVar[str] = "raise"

    def __post_init__(self, nan_policy: str) -> None:
        where = f"record {self.source or self.name or '(unnamed)'}"
        if nan_policy not in NAN_POLICIES:
            raise DataError(f"{where}: nan_policy must be one of {set(NAN_POLICIES)}; got {nan_policy!r}")
        cols = {"t": self.t, "d": self.d, "y": self.y}
        if self.d_dot is not None:
            cols["d_dot"] = self.d_dot
        if self.command is not None:
            if self.command_name not in COMMAND_NAMES:
                raise DataError(
                    f"{where}: command_name must be one of {COMMAND_NAMES} for a command history; "
                    f"got {self.command_name!r}"
                )
            cols["command"] = self.command
        arrays = {k: _as_vector(k, v, where) for k, v in cols.items()}
        sizes = {k: a.size for k, a in arrays.items()}
        if len(set(sizes.values())) > 1:
            text = ", ".join(f"{k}={n}" for k, n in sizes.items())
            raise DataError(f"{where}: signals have different lengths ({text}); give one value per sample in each")
        bad_rows = np.zeros(sizes["t"], dtype=bool)
        counts = {}
        for k, a in arrays.items():
            bad = ~np.isfinite(a)
            if bad.any():
                counts[k] = (int(bad.sum()), int(np.flatnonzero(bad)[0]))
                bad_rows |= bad
        if counts:
            text = "; ".join(f"{k}: {n} (first at index {i})" for k, (n, i) in counts.items())
            if nan_policy == "raise":
                raise DataError(
                    f"{where}: NaN/inf values in {text}; clean the data or pass nan_policy='omit' to drop those samples"
                )
            warnings.warn(
                f"{where}: dropped {int(bad_rows.sum())} of {bad_rows.size} samples with NaN/inf ({text})",
                UserWarning,
                stacklevel=3,
            )
            arrays = {k: a[~bad_rows] for k, a in arrays.items()}
        n = arrays["t"].size
        if n < MIN_SAMPLES:
            raise DataError(f"{where}: too few samples: {n} (need at least {MIN_SAMPLES}); record a longer test")
        require_increasing(arrays["t"], f"{where}: time")
        arrays["t"], sampling = _sampling(arrays["t"], self.metadata.get("sampling"))
        object.__setattr__(self, "metadata", {**dict(self.metadata), "sampling": sampling})
        for k in ("d", "y", "d_dot", "command"):
            if k in arrays:
                _check_magnitude(k, arrays[k], where)
        for k in ("d", "y"):
            if np.ptp(arrays[k]) == 0:
                raise DataError(
                    f"{where}: signal {k} is constant ({arrays[k][0]:g}); check the column mapping or the sensor"
                )
        n_cross = zero_crossings(arrays["d"]).size
        if n_cross < 2:
            raise DataError(
                f"{where}: less than one excitation cycle ({n_cross} sign change(s) of d - mean(d), need 2); "
                "record at least one full cycle of the input"
            )
        for k in ("current", "voltage"):
            v = getattr(self, k)
            if v is not None:
                v = float(v)
                if not math.isfinite(v):
                    raise DataError(f"{where}: {k} must be finite; got {v}")
                object.__setattr__(self, k, v)
        for k, a in arrays.items():
            a = np.ascontiguousarray(a)
            a.flags.writeable = False
            object.__setattr__(self, k, a)
        object.__setattr__(self, "units", types.MappingProxyType(dict(self.units)))
        object.__setattr__(self, "metadata", types.MappingProxyType(dict(self.metadata)))
        if not self.name and self.source:
            object.__setattr__(self, "name", str(self.source).replace("\\", "/").rstrip("/").split("/")[-1])

    # ------------------------------------------------------------------ facts
    @property
    def n_times(self) -> int:
        return int(self.t.size)

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def dt(self) -> float:
        """Median sampling step, s."""
        return float(np.median(np.diff(self.t)))

    def is_uniform(self, rtol: float = UNIFORM_RTOL) -> bool:
        """Whether every sampling step is within ``rtol`` of the median step (or within the float64
        resolution of the stamps, :data:`ULP_STEPS`, when that is coarser: t starting at 1e9 s)."""
        steps = np.diff(self.t)
        return bool(np.all(np.abs(steps - self.dt) <= self._step_tolerance(rtol)))

    def _step_tolerance(self, rtol: float) -> float:
        return max(rtol * self.dt, ULP_STEPS * float(np.spacing(np.max(np.abs(self.t)))))

    def require_uniform(self, operation: str, rtol: float = UNIFORM_RTOL) -> float:
        """The sampling step, or a :class:`DataError` naming ``operation`` if sampling is not uniform."""
        steps = np.diff(self.t)
        dt = self.dt
        off = np.flatnonzero(np.abs(steps - dt) > self._step_tolerance(rtol))
        if off.size:
            i = int(off[0])
            raise DataError(
                f"record {self.name or '(unnamed)'}: {operation} needs uniform sampling, but {off.size} step(s) "
                f"differ from the median dt={dt:g} s by more than {rtol:g} relative, first between index {i} and "
                f"{i + 1} (step {steps[i]:g} s); resample the record or give the velocity column"
            )
        return dt

    @property
    def n_cycles(self) -> float:
        """Number of input cycles, estimated from sign changes of ``d - mean(d)`` (two per cycle)."""
        return zero_crossings(self.d).size / 2.0

    @property
    def period(self) -> float:
        """Dominant input period, s, from the mean spacing of sign changes of ``d - mean(d)``."""
        z = zero_crossings(self.d)
        return float(2.0 * (self.t[z[-1]] - self.t[z[0]]) / (z.size - 1))

    def default_velocity_window(self) -> int:
        """Savitzky–Golay window used by :meth:`velocity`: a tenth of the input period, odd, 5..101 samples."""
        w = int(round(0.1 * self.period / self.dt))
        w = min(max(w, 5), 101, self.n_times - (1 - self.n_times % 2))
        return w if w % 2 else w + 1

    def default_acceleration_window(self) -> int:
        """Savitzky–Golay window used by :meth:`acceleration`: a tenth of the input's mean period
        :math:`2\\pi\\,\\mathrm{rms}(d)/\\mathrm{rms}(\\dot d)` (the period of a sine; shorter than the dominant
        period for a multisine, whose high lines weigh more in the acceleration), odd, 5..101 samples."""
        d = np.asarray(self.d) - np.mean(self.d)
        v = np.asarray(self.velocity())
        v = v - np.mean(v)
        rms_v = float(np.sqrt(np.mean(v**2)))
        period = 2 * math.pi * float(np.sqrt(np.mean(d**2))) / rms_v if rms_v > 0 else self.period
        w = int(round(0.1 * min(period, self.period) / self.dt))
        w = min(max(w, 5), 101, self.n_times - (1 - self.n_times % 2))
        return w if w % 2 else w + 1

    # ------------------------------------------------------------------ signals
    def velocity(self, *, window: int | None = None, polyorder: int = 3) -> Float1D:
        """The input velocity: ``d_dot`` if the record has it, else a Savitzky–Golay derivative of ``d``.

        Parameters
        ----------
        window : odd number of samples of the filter (default :meth:`default_velocity_window`).
        polyorder : degree of the local polynomial (3: exact for cubics).

        Raises
        ------
        DataError
            If the sampling is not uniform or the window is invalid.
        """
        if self.d_dot is not None:
            return self.d_dot
        dt = self.require_uniform("deriving the velocity from d")
        w = self._check_window("velocity", self.default_velocity_window() if window is None else int(window), polyorder)
        out = savgol_derivative(np.asarray(self.d), dt, w, polyorder)
        out.flags.writeable = False
        return out

    def _check_window(self, what: str, w: int, polyorder: int) -> int:
        """``w`` if it is a valid Savitzky–Golay window for this record, else a DataError naming ``what``."""
        if w % 2 == 0 or w <= polyorder or w > self.n_times:
            raise DataError(
                f"record {self.name or '(unnamed)'}: {what} window must be odd, larger than polyorder={polyorder} "
                f"and at most n_times={self.n_times}; got {w}"
            )
        return w

    def acceleration(self, *, window: int | None = None, polyorder: int = 3) -> Float1D:
        """The input acceleration: a Savitzky–Golay derivative of ``d_dot`` if the record has it, else the
        Savitzky–Golay second derivative of ``d`` (window :meth:`default_acceleration_window`).

        Like the velocity it is centred (no lag); for a sine of :math:`\\theta = \\omega\\,dt` rad per sample
        its gain is :math:`1 - O((\\theta w/2)^2)` for the second derivative of ``d`` (measured in the
        tests: below 1e-3 at 2 Hz with dt = 0.005 s and the default window) and :math:`1 - O((\\theta w/2)^4)`
        from a given ``d_dot``. Noise in ``d`` is amplified: use a longer window for noisy inputs.

        Raises
        ------
        DataError
            If the sampling is not uniform or the window is invalid.
        """
        dt = self.require_uniform("deriving the acceleration")
        w = self._check_window(
            "acceleration", self.default_acceleration_window() if window is None else int(window), polyorder
        )
        if self.d_dot is not None:
            out = savgol_derivative(np.asarray(self.d_dot), dt, w, polyorder)
        else:
            from scipy.signal import savgol_filter

            out = savgol_filter(
                np.asarray(self.d), window_length=w, polyorder=polyorder, deriv=2, delta=dt, mode="interp"
            )
        out.flags.writeable = False
        return out

    def input_matrix(self, model) -> np.ndarray:
        """The model's input matrix ``(n_times, n_inputs)`` on this record (columns in ``model.inputs``
        order; see :meth:`inputs_for`), built once per set of input channels and then reused (read-only)."""
        from duffsym.simulate import input_matrix

        key = tuple((c.name, c.signal, c.order) for c in model.inputs)
        cache = self.__dict__.setdefault("_input_matrices", {})
        if key not in cache:
            U = input_matrix(model, np.asarray(self.t), self.inputs_for(model))
            U.setflags(write=False)
            cache[key] = U
        return cache[key]

    def inputs_for(self, model) -> dict[str, np.ndarray]:
        """The model's input channels by name (order 0: ``d``; 1: the velocity; 2: the acceleration)."""
        out = {}
        for ch in model.inputs:
            if ch.signal == "command":
                if ch.order != 0:
                    raise DataError(
                        f"model {model.name} needs the derivative {ch.name} of the command; a record "
                        "provides the command itself only"
                    )
                out[ch.name] = self.command_signal(model.name)
            elif ch.signal in DRIFT_SIGNALS:
                out[ch.name] = self.drift_signal(ch.signal)
            elif ch.order == 0:
                out[ch.name] = np.asarray(self.d)
            elif ch.order == 1:
                out[ch.name] = np.asarray(self.velocity())
            elif ch.order == 2:
                out[ch.name] = np.asarray(self.acceleration())
            else:
                raise DataError(
                    f"model {model.name} needs input {ch.name} (derivative order {ch.order}); a record provides "
                    "the input and its first and second derivatives only"
                )
        return out

    def drift_signal(self, name: str) -> np.ndarray:
        """A slow signal a drifting parameter can follow (``duffsym.effects.drift``): ``"time"`` since the
        record's start (s), or ``"energy"``, the work done on the device since the start,
        :math:`\\int_0^t y\\,\\dot d\\,dt` (force units x displacement units; trapezoidal rule): the
        energy a damper dissipates, which heats it."""
        t = np.asarray(self.t, float)
        if name == "time":
            return t - t[0]
        if name == "energy":
            p = np.asarray(self.y, float) * np.asarray(self.velocity(), float)
            return np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t))])
        raise DataError(f"unknown drift signal {name!r}; choose from {DRIFT_SIGNALS}")

    def command_signal(self, model_name: str = "", *, missing: float | None = None) -> np.ndarray:
        """The command history ``(n_times,)``: :attr:`command`, else the constant current, else the voltage, else
        ``missing`` held over the record when it is given (a term that vanishes without a command).

        Raises
        ------
        DataError
            If the record has no command (no ``current``/``voltage`` column or value) and ``missing`` is None.
        """
        if self.command is not None:
            return np.asarray(self.command)
        for v in (self.current, self.voltage, missing):
            if v is not None:
                return np.full(self.n_times, float(v))
        who = f"model {model_name}" if model_name else "a command-driven model"
        raise DataError(
            f"record {self.name or '(unnamed)'}: no current or voltage column; {who} is driven by the damper's "
            "command: add a 'current' (A) or 'voltage' (V) column, or map one (--columns current=NAME)"
        )

    @property
    def command_varies(self) -> bool:
        """Whether the record's command changes over time (False for a constant or missing command)."""
        c = self.command
        return c is not None and bool(np.ptp(c) > 1e-9 * max(1.0, float(np.max(np.abs(c)))))

    def replace(self, **changes) -> Record:
        """A new (re-validated) record with some fields changed."""
        fields: dict[str, Any] = dict(
            t=self.t,
            d=self.d,
            y=self.y,
            d_dot=self.d_dot,
            current=self.current,
            voltage=self.voltage,
            units=dict(self.units),
            metadata=dict(self.metadata),
            source=self.source,
            name=self.name,
            command=self.command,
            command_name=self.command_name,
        )
        fields.update(changes)
        return Record(**fields)

    def slice(self, start: int | None = None, stop: int | None = None) -> Record:
        """A record of samples ``start:stop`` (re-validated)."""
        s = slice(start, stop)
        return self.replace(
            t=self.t[s],
            d=self.d[s],
            y=self.y[s],
            d_dot=None if self.d_dot is None else self.d_dot[s],
            command=None if self.command is None else self.command[s],
        )

    def summary(self) -> str:
        u = dict(self.units)
        extra = []
        if self.current is not None:
            extra.append(f"current {self.current:g} A")
        if self.voltage is not None:
            extra.append(f"voltage {self.voltage:g} V")
        if self.command is not None:
            c = np.asarray(self.command)
            unit = COMMAND_UNITS.get(self.command_name, "V")
            extra.append(f"{self.command_name} varying in [{c.min():g}, {c.max():g}] {unit}")
        vel = "given" if self.d_dot is not None else "derived (Savitzky-Golay)"
        return (
            f"record {self.name or '(unnamed)'}: {self.n_times} samples over {self.duration:g} {u.get('t', 's')}, "
            f"dt {self.dt:g}, {self.n_cycles:g} input cycles; d in [{self.d.min():g}, {self.d.max():g}] "
            f"{u.get('d', '')}, y in [{self.y.min():g}, {self.y.max():g}] {u.get('y', '')}; velocity {vel}"
            + (f"; {', '.join(extra)}" if extra else "")
        )
