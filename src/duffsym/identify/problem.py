"""An identification problem: a model, one or more records, and which parameters vary.

Validated once, at construction. The defaults of ``docs/contract.md`` are applied here and each is
recorded with its reason:

- ``A_f`` fixed to ``max|y|`` (over all records): the scaling symmetry :math:`x \\to s x` maps
  :math:`(c_1, c_2, k_1, k_2, c_3, k_3, A_f)` to
  :math:`(c_1/s,\\ c_1+c_2-c_1/s,\\ k_1/s,\\ k_1+k_2-k_1/s,\\ c_3 s^{n-1},\\ k_3 s^{n-1},\\ A_f s)` and leaves
  the output unchanged, so ``A_f`` and the gains are not identifiable together; the paper fixes
  ``A_f`` to the force peak.
- ``k3`` fixed at 0: under a single-amplitude sine, ``k3`` trades against ``k1`` and ``k2`` along
  a ridge of equal fit (Table 2 has ``k3 = 0`` throughout); several amplitudes free it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError, ModelError
from duffsym.model.core import SymbolicModel

REASON_AF = (
    "fixed to max|y| = {value:.6g}: the scaling symmetry x -> s*x leaves the output unchanged, so A_f "
    "and the gains are not identifiable together (the paper sets A_f to the force peak)"
)
REASON_K3 = (
    "fixed at 0: under a single-amplitude sine k3 trades against k1 and k2 along a ridge of equal fit "
    "(Table 2 has k3 = 0); free it (free=[..., 'k3']) with records at several amplitudes"
)
REASON_K3_OTHER = (
    "fixed at 0 (Table 2 has k3 = 0): at one excitation level k3 trades against k1 and k2 along a "
    "ridge of equal fit; free it (free=[..., 'k3']) with records that span several amplitudes"
)
#: A record is a single-amplitude sine when this share of its input's variance lies at one frequency.
SINE_SHARE = 0.995
REASON_AF_ELEMENT = (
    "fixed at {value:.6g}: the element's scaling symmetry x -> s*x leaves its force, hence the "
    "structure's output, unchanged, so A_f and the element's gains are not identifiable together"
)
REASON_HELD = "not listed in free; held at the model default {value:.6g}"


def single_sine(d) -> bool:
    """Whether the input ``d`` is one sine at one amplitude: :data:`SINE_SHARE` of its variance within
    two bins of its spectral peak (Hann window). A triangle wave (98.6 % at its fundamental), a multisine or
    a robot trajectory are not."""
    d = np.asarray(d, dtype=float)
    d = (d - np.mean(d)) * np.hanning(d.size)
    p = np.abs(np.fft.rfft(d)) ** 2
    if p.size < 5 or not np.sum(p[1:]) > 0:
        return False
    k = int(np.argmax(p[1:])) + 1
    return float(np.sum(p[max(1, k - 2) : k + 3]) / np.sum(p[1:])) >= SINE_SHARE


def effect_record_bounds(model, records) -> dict[str, tuple[float, float]]:
    """Default bounds of the catalogued effects' parameters scaled to the records (``Effect.record_bounds``, e.g.
    a seal friction's switching velocity within the records' velocity range, so that it cannot run off to a
    flat switch); over several records the widest range. Explicit ``bounds`` override them."""
    out: dict[str, tuple[float, float]] = {}
    for k, (lo, hi) in _effect_values(model, records, "record_bounds"):
        a, b = out.get(k, (lo, hi))
        out[k] = (min(a, lo), max(b, hi))
    return {k: v for k, v in out.items() if k in model.param_names}


def _effect_values(model, records, method: str):
    """``(parameter, value)`` pairs of each catalogued effect of ``model`` on each record, from the effect's
    ``method`` (``record_bounds`` or ``record_scales``)."""
    from duffsym.effects import CATALOGUE

    for name in getattr(model, "effects", ()):
        if name in CATALOGUE:
            for rec in records:
                yield from getattr(CATALOGUE[name], method)(rec).items()


def parameter_scales(model, records) -> dict[str, float]:
    """The magnitude by which the fit scales each parameter: ``ParamSpec.scale``, or for a catalogued effect's
    parameter that follows the records' units (``Effect.record_scales``) the larger of the two (over several
    records the largest)."""
    out = {p.name: p.typical_scale for p in model.params}
    for k, v in _effect_values(model, records, "record_scales"):
        if k in out and math.isfinite(v):
            out[k] = max(out[k], v)
    return out


#: A first-order state's own rate times the sampling step is at most this (its time constant at least a twelfth of
#: a step): the record does not resolve a much faster state, and the collocation of such a stiff state is
#: ill-conditioned. Measured on 6 s of the Dyke record (``mr-damper-current``, the field rate ``eta`` free up to its
#: ParamSpec bound 1e4/s; the start from :func:`~duffsym.identify.initial.command_start` at 3000/s): at 250 Hz
#: IPOPT's iterations grew to 36 s (Hessian regularisation 1.3e9) and the fit took 511 s; with the bound at 12/dt
#: (3000/s) 15 s and 117 iterations to the same optimum, eta = 128/s, well inside it. At 500 Hz the bound at 12/dt
#: leaves the fit as it was (54 iterations, NRMSE 0.1996, eta = 131/s). Tighter limits changed the start, and with
#: it the local optimum: at 6/dt the 500 Hz fit ended at another one (NRMSE 0.193) and the diagnosis's base fit at
#: 250 Hz at a poor one (0.396 against 0.204); at 1/dt or 2/dt the 500 Hz fit ran to IPOPT's iteration limit.
RATE_STEP_LIMIT = 12.0

#: model key -> ((parameter, "rate" | "time"), ...): see :func:`decay_parameters`
_DECAY: dict[str, tuple[tuple[str, str], ...]] = {}


def decay_parameters(model) -> tuple[tuple[str, str], ...]:
    """The parameters that set a first-order state's own decay: ``(name, "rate")`` where the state's equation has
    d f_s / d s = -p (the field rate ``eta``), ``(name, "time")`` where it is -1/p (a lag's time constant)."""
    if model.key in _DECAY:
        return _DECAY[model.key]
    import sympy as sp

    out = []
    for s, f in zip(model.states, model.rhs):
        if s in (model.position, model.velocity):
            continue
        j = sp.diff(f, s)
        for p in model.params:
            if p.symbol not in j.free_symbols:
                continue
            if sp.expand(j + p.symbol) == 0:
                out.append((p.name, "rate"))
            elif sp.expand(j * p.symbol + 1) == 0:
                out.append((p.name, "time"))
    _DECAY[model.key] = tuple(out)
    return _DECAY[model.key]


def sampling_bounds(model, records) -> dict[str, tuple[float, float]]:
    """Default bounds set by the records' sampling (the finest step ``dt`` of them): a decay rate at most
    ``RATE_STEP_LIMIT / dt``, a time constant at least ``dt / RATE_STEP_LIMIT`` (:data:`RATE_STEP_LIMIT`), within
    the parameter's own bounds; {} for a model without such a parameter. Explicit ``bounds`` override them."""
    names = decay_parameters(model)
    if not names:
        return {}
    dt = min(float(r.dt) for r in records)
    if not dt > 0:
        return {}
    out = {}
    for name, kind in names:
        spec = model.param(name)
        lo, hi = float(spec.lower), float(spec.upper)
        lo, hi = (lo, min(hi, RATE_STEP_LIMIT / dt)) if kind == "rate" else (max(lo, dt / RATE_STEP_LIMIT), hi)
        if lo < hi and (lo, hi) != (spec.lower, spec.upper):
            out[name] = (lo, hi)
    return out


def record_scaled_bounds(model, records) -> dict[str, tuple[float, float]]:
    """The default bounds scaled to the records: the sampling's (:func:`sampling_bounds`) and the effects'
    (:func:`effect_record_bounds`), the tighter of each limit where both bound a parameter (the effect's when they
    do not overlap). An automatic start outside them is moved inside."""
    out = sampling_bounds(model, records)
    for k, (lo, hi) in effect_record_bounds(model, records).items():
        a, b = out.get(k, (lo, hi))
        both = (max(a, lo), min(b, hi))  # both limits hold: the tighter of each
        out[k] = both if both[0] < both[1] else (lo, hi)
    return out


def _as_records(records) -> tuple[Record, ...]:
    if isinstance(records, Record):
        return (records,)
    out = tuple(records)
    if not out:
        raise DataError("a problem needs at least one record")
    for i, r in enumerate(out):
        if not isinstance(r, Record):
            raise DataError(f"records[{i}] is a {type(r).__name__}, not a duffsym.data.Record; load it with read_csv")
    return out


def _command_text(record: Record) -> str:
    c = np.asarray(record.command_signal())
    from duffsym.data.record import COMMAND_UNITS

    unit = COMMAND_UNITS[record.command_name or ("current" if record.current is not None else "voltage")]
    return f"{c.min():g} {unit}" if np.ptp(c) == 0 else f"{c.min():g} to {c.max():g} {unit}"


def check_command(model, records, free: Sequence[str] = ()) -> None:
    """The records carry what ``model`` needs of the damper's command.

    A model driven by the command (an input channel ``command``) needs a current or voltage in every
    record; to identify how the coefficients depend on it (``free`` holds a field parameter, ``*_u``,
    ``*_uu``, ``u_sat``, ``eta``) the command must vary, within a record or across records. A model
    without a command input refuses a record whose current or voltage varies (it would average the levels); a
    measured ``pressure`` is an operating condition such a model may leave out (a campaign discovery then asks
    whether a term in it is missing, :mod:`duffsym.diagnose.campaign`).

    Raises
    ------
    DataError
        One line naming the record, the problem and what to do.
    """
    recs = _as_records(records)
    if "command" not in model.signals:
        for r in recs:
            if r.command_varies and r.command_name != "pressure":
                c = np.asarray(r.command)
                raise DataError(
                    f"record {r.name or '(unnamed)'}: its {r.command_name} varies ({c.min():g} to {c.max():g}) but "
                    f"model {model.name} has no command input (it would average the levels); use a command-driven "
                    "model (--model mr-damper-current, see `duffsym models`)"
                )
        return
    values = []
    for r in recs:
        c = r.command_signal(model.name)
        values.append(c)
    field = [n for n in free if n.endswith(("_u", "_uu")) or n in ("u_sat", "eta")]
    if not field:
        return
    allc = np.concatenate(values)
    if np.ptp(allc) <= 1e-9 * max(1.0, float(np.max(np.abs(allc)))):
        where = recs[0].name or "(unnamed)" if len(recs) == 1 else f"all {len(recs)} records"
        raise DataError(
            f"{'record ' if len(recs) == 1 else ''}{where}: the command is constant ({_command_text(recs[0])}), "
            f"so model {model.name} cannot tell how the coefficients depend on it ({', '.join(field[:3])}, ...); "
            "fit records at several currents together, give a record whose command varies, or use --model mr-damper"
        )


def _group_labels(groups, records: tuple[Record, ...]) -> tuple[str, ...]:
    if groups is None:
        return ("",) * len(records)
    if isinstance(groups, str):
        if groups not in ("current", "voltage"):
            raise DataError(f"groups must be 'current', 'voltage' or one label per record; got {groups!r}")
        unit = "A" if groups == "current" else "V"
        out = []
        for i, r in enumerate(records):
            v = getattr(r, groups)
            if v is None:
                raise DataError(f"groups={groups!r}: record {i} ({r.name!r}) has no {groups}; set it or give labels")
            out.append(f"{v:g}{unit}")
        return tuple(out)
    labels = tuple(str(g) for g in groups)
    if len(labels) != len(records):
        raise DataError(f"groups: give one label per record ({len(records)}); got {len(labels)}")
    return labels


def _per_record(name: str, value, records: tuple[Record, ...], dtype) -> tuple[np.ndarray, ...] | None:
    """Normalise a per-sample array argument (one array, or one per record)."""
    if value is None:
        return None
    if len(records) == 1 and not (isinstance(value, (list, tuple)) and len(value) == 1):
        value = [value]
    value = list(value)
    if len(value) != len(records):
        raise DataError(f"{name}: give one array per record ({len(records)}); got {len(value)}")
    out = []
    for i, (v, r) in enumerate(zip(value, records)):
        a = np.array(v, dtype=dtype).reshape(-1)
        if a.size != r.n_times:
            raise DataError(
                f"{name}[{i}] has {a.size} values for record {r.name!r} of {r.n_times} samples; "
                "give one value per sample"
            )
        a.flags.writeable = False
        out.append(a)
    return tuple(out)


def _check_constraints(constraints, free: tuple[str, ...]) -> tuple:
    """Normalise ``constraints`` to ``((coefficients dict, lower, upper), ...)``, checked."""
    out = []
    for i, item in enumerate(constraints or ()):
        try:
            coeffs, lo, hi = item
            coeffs = {str(k): float(v) for k, v in dict(coeffs).items()}
            lo, hi = float(lo), float(hi)
        except (TypeError, ValueError):
            raise ModelError(f"constraints[{i}] must be (coefficients by name, lower, upper); got {item!r}") from None
        bad = sorted(set(coeffs) - set(free))
        if bad:
            raise ModelError(
                f"constraints[{i}]: {bad} not free parameters (free: {list(free)}); constrain free ones only"
            )
        finite = all(math.isfinite(v) for v in coeffs.values())
        if not coeffs or not finite or math.isnan(lo) or math.isnan(hi) or lo > hi:
            raise ModelError(f"constraints[{i}]: need finite coefficients and lower <= upper; got {coeffs}, {lo}, {hi}")
        out.append((coeffs, lo, hi))
    return tuple(out)


#: Memory of a collocation fit: a fixed part plus a part per sample and state, measured with
#: ``/usr/bin/time`` on ``duffsym fit`` of mr-damper records (2 states): peak RSS 334 MB at 5 000
#: samples and 669 MB at 20 000, i.e. ~22 kB per sample (IPOPT's KKT factorisation, CasADi's
#: expanded graph, the free run) on a ~220 MB base.
FIT_BYTES_BASE = 250e6
FIT_BYTES_PER_SAMPLE_STATE = 11.5e3


def estimate_fit_memory(model, records) -> float:
    """Estimated peak memory (bytes) of fitting ``model`` to ``records`` by collocation."""
    n = sum(r.n_times for r in records)
    return FIT_BYTES_BASE + FIT_BYTES_PER_SAMPLE_STATE * n * max(int(model.n_states), 1)


def available_memory() -> float | None:
    """Bytes the system can still give (``MemAvailable`` of /proc/meminfo), or None where unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def check_fit_memory(model, records) -> None:
    """A one-line :class:`DataError` before building an NLP that would not fit in memory."""
    need = estimate_fit_memory(model, records)
    have = available_memory()
    if have is not None and need > 0.9 * have:
        n = sum(r.n_times for r in records)
        keep = max(int(n * (0.9 * have - FIT_BYTES_BASE) / (need - FIT_BYTES_BASE)), 1)
        raise DataError(
            f"fitting {n} samples of a {model.n_states}-state model needs about {need / 1e9:.1f} GB but "
            f"{have / 1e9:.1f} GB is available; fit at most ~{keep} samples (decimate the record or fit a part of it)"
        )


def _checked_names(model, free, fixed, bounds) -> tuple[list[str] | None, dict[str, float]]:
    """``(free, fixed values)``: every name known, none both free and fixed, each fixed value a finite number
    not below a non-negative lower bound (a sign the model needs)."""
    names = list(model.param_names)
    fixed_in = dict(fixed or {})
    for label, group in (("fixed", fixed_in), ("bounds", dict(bounds or {}))):
        unknown = sorted(set(group) - set(names))
        if unknown:
            raise ModelError(f"{label}: unknown parameter(s) {unknown} for model {model.name}; known: {names}")
    if free is not None:
        if isinstance(free, str):
            free = [free]
        unknown = sorted(set(free) - set(names))
        if unknown:
            raise ModelError(f"free: unknown parameter(s) {unknown} for model {model.name}; known: {names}")
        both = sorted(set(free) & set(fixed_in))
        if both:
            raise ModelError(f"parameter(s) {both} are both free and fixed; choose one")
    fixed_vals: dict[str, float] = {}
    for k, v in fixed_in.items():
        try:
            v = float(v)
        except (TypeError, ValueError):
            raise ModelError(f"fixed value of {k} must be a number; got {v!r}") from None
        if not math.isfinite(v):
            raise ModelError(f"fixed value of {k} must be finite; got {v}")
        lower = model.param(k).lower
        if lower >= 0 and v < lower:  # a sign the model needs (A_f > 0, c1 > 0, c3 >= 0, ...)
            raise ModelError(
                f"fixed value of {k} = {v:g} is below its lower bound {lower:g} (the model needs "
                f"{k} {'> 0' if lower > 0 else '>= 0'}); give a value >= {lower:g}"
            )
        fixed_vals[k] = v
    return free, fixed_vals


def _applied_defaults(model, recs, labels, groups, free, fixed_vals):
    """``(free, fixed, defaults applied with their reasons, per-group fixed values)``: the defaults of the
    module docstring (``A_f``, ``k3``, held parameters, parameters neither free nor fixed) applied."""
    names = list(model.param_names)
    fixed_vals = dict(fixed_vals)
    defaults: dict[str, str] = {}
    requested = set(free or ()) | set(fixed_vals)
    group_fixed: dict[tuple[str, str], float] = {}
    af_inside = "A_f" in names and bool(getattr(model, "composition", ()))
    if af_inside:  # each element's gain inside a composed model (A_f, A_f_2, ...)
        for name in (n for n in names if n == "A_f" or n.startswith("A_f_")):
            if name not in requested:
                fixed_vals[name] = model.param(name).default
                defaults[name] = REASON_AF_ELEMENT.format(value=fixed_vals[name])
    elif "A_f" in names and "A_f" not in requested:
        peak = max(float(np.max(np.abs(r.y))) for r in recs)
        fixed_vals["A_f"] = peak
        defaults["A_f"] = REASON_AF.format(value=peak)
        if groups is not None:
            for lab in dict.fromkeys(labels):
                gp = max(float(np.max(np.abs(r.y))) for r, lr in zip(recs, labels) if lr == lab)
                group_fixed[("A_f", lab)] = gp
            defaults["A_f"] = REASON_AF.format(value=peak).replace(
                f"fixed to max|y| = {peak:.6g}",
                "fixed per group to the group's max|y| ("
                + ", ".join(f"{lab}: {v:.6g}" for (_, lab), v in group_fixed.items())
                + ")",
            )
    for spec in model.params:  # a parameter its model holds (a scaling symmetry), unless requested
        if spec.held and spec.name not in requested and spec.name not in fixed_vals:
            fixed_vals[spec.name] = spec.default
            defaults[spec.name] = f"fixed at {spec.default:.6g}: {spec.held}"
    if "k3" in names and "k3" not in requested:
        fixed_vals["k3"] = 0.0
        defaults["k3"] = REASON_K3 if all(single_sine(r.d) for r in recs) else REASON_K3_OTHER
    if free is None:
        free_t = tuple(n for n in names if n not in fixed_vals)
    else:
        free_t = tuple(n for n in names if n in set(free))
        for n in names:
            if n not in free_t and n not in fixed_vals:
                fixed_vals[n] = model.param(n).default
                defaults[n] = REASON_HELD.format(value=fixed_vals[n])
    if not free_t:
        raise ModelError(f"no free parameter left for model {model.name}; list some in free=")
    return free_t, fixed_vals, defaults, group_fixed


def _free_bounds(model, recs, free_t, bounds) -> dict[str, tuple[float, float]]:
    """The bounds of the free parameters: given, else the record-scaled ones (:func:`record_scaled_bounds`), else
    the model's."""
    bnds: dict[str, tuple[float, float]] = {}
    bounds = {**record_scaled_bounds(model, recs), **dict(bounds or {})}
    for n in free_t:
        spec = model.param(n)
        lo, hi = (bounds or {}).get(n, (spec.lower, spec.upper))
        lo, hi = float(lo), float(hi)
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise ModelError(f"bounds of {n} must satisfy lower < upper; got ({lo}, {hi}); swap or widen them")
        bnds[n] = (lo, hi)
    return bnds


def _weights_and_mask(recs, weights, mask, n_free: int):
    """The per-record weights and masks, checked, with more samples left in the objective than free values."""
    w = _per_record("weights", weights, recs, float)
    if w is not None:
        for i, a in enumerate(w):
            if not np.all(np.isfinite(a)) or np.any(a < 0):
                raise DataError(f"weights[{i}] must be finite and >= 0")
    m = _per_record("mask", mask, recs, bool)
    eff = [np.ones(r.n_times) for r in recs]
    if w is not None:
        eff = [e * a for e, a in zip(eff, w)]
    if m is not None:
        eff = [e * ~a for e, a in zip(eff, m)]
    n_used = sum(int(np.count_nonzero(e)) for e in eff)
    if n_used <= n_free:
        raise DataError(
            f"only {n_used} sample(s) left in the objective after weights/mask for {n_free} free "
            "parameter(s); mask fewer samples"
        )
    return w, m


@dataclass(frozen=True, eq=False, init=False)
class Problem:
    """A model, its records and the parameters to identify.

    Parameters
    ----------
    model : the :class:`~duffsym.model.SymbolicModel` (the single source of the dynamics).
    records : one :class:`~duffsym.data.Record` or a sequence; all share the parameters (each
        record has its own state trajectory in the fit).
    free : names of the parameters to identify. Default: every parameter not fixed.
        Parameters neither free nor fixed are held at the model default (recorded).
    fixed : name -> value of parameters held constant. Defaults (when a name is neither given in
        ``free`` nor ``fixed``): ``A_f = max|y|`` and ``k3 = 0`` (see the module docstring).
    bounds : name -> ``(lower, upper)``; default the model's ParamSpec bounds.
    weights : per-sample non-negative weights of the squared output residuals (one array, or one per record).
    mask : per-sample booleans, True where a sample leaves the objective (one array or one per record);
        masked samples still obey the dynamics.
    mask_info : description of how the mask was chosen (e.g. from :func:`auto_mask`), kept in the result.
    groups : ``"current"`` or ``"voltage"`` (group the records by that value) or one label per record;
        with ``per_group`` the named free parameters get one value per group (e.g. the current
        dependence of Table 2 in one fit), the others stay shared. With groups, the default
        ``A_f`` is fixed per group to the group's ``max|y|``.
    per_group : free parameters identified once per group.
    constraints : linear inequalities on the free parameters, each ``(coefficients, lower, upper)``
        meaning ``lower <= sum(coefficients[name] * name) <= upper`` (use ``math.inf`` for no
        upper bound); e.g. ``[({"k1": 1, "k2": 1}, 0, math.inf)]`` keeps the total stiffness of
        ``mr_damper`` non-negative. With groups, a constraint on a per-group parameter holds in
        every group.

    Raises
    ------
    ModelError
        Unknown parameter names, a name both free and fixed, non-finite fixed values, bounds
        with ``lower >= upper``, no free parameter.
    DataError
        Bad records, weights or masks, or every sample masked.
        (ModelError also for constraints on unknown or non-free parameters, or with lower > upper.)
    """

    model: SymbolicModel
    records: tuple[Record, ...]
    free: tuple[str, ...] = ()
    fixed: Mapping[str, float] = field(default_factory=dict)
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    weights: tuple[np.ndarray, ...] = ()
    mask: tuple[np.ndarray, ...] = ()
    defaults_applied: Mapping[str, str] = field(default_factory=dict)
    mask_info: Mapping[str, object] = field(default_factory=dict)
    labels: tuple[str, ...] = ()
    group_order: tuple[str, ...] = ()
    per_group: tuple[str, ...] = ()
    group_fixed: Mapping[tuple[str, str], float] = field(default_factory=dict)
    slots: tuple[tuple[str, str | None], ...] = ()
    constraints: tuple = ()

    def __init__(
        self,
        model,
        records,
        *,
        free: Sequence[str] | None = None,
        fixed: Mapping[str, float] | None = None,
        bounds: Mapping[str, tuple[float, float]] | None = None,
        weights=None,
        mask=None,
        mask_info: Mapping[str, object] | None = None,
        groups=None,
        per_group: Sequence[str] = (),
        constraints=None,
    ):
        recs = _as_records(records)
        labels = _group_labels(groups, recs)
        free, fixed_vals = _checked_names(model, free, fixed, bounds)
        free_t, fixed_vals, defaults, group_fixed = _applied_defaults(model, recs, labels, groups, free, fixed_vals)
        check_command(model, recs, free_t)
        per_group = (per_group,) if isinstance(per_group, str) else tuple(per_group)
        if per_group and groups is None:
            raise ModelError("per_group needs groups= ('current', 'voltage' or one label per record)")
        not_free = sorted(set(per_group) - set(free_t))
        if not_free:
            raise ModelError(f"per_group parameter(s) {not_free} are not free; free: {list(free_t)}")
        order = tuple(dict.fromkeys(labels))
        slots: list[tuple[str, str | None]] = [(n, None) for n in free_t if n not in per_group]
        slots += [(n, lab) for n in free_t if n in per_group for lab in order]
        bnds = _free_bounds(model, recs, free_t, bounds)
        w, m = _weights_and_mask(recs, weights, mask, len(free_t))
        object.__setattr__(self, "model", model)
        object.__setattr__(self, "records", recs)
        object.__setattr__(self, "free", free_t)
        object.__setattr__(self, "fixed", dict(fixed_vals))
        object.__setattr__(self, "bounds", bnds)
        object.__setattr__(self, "weights", w or ())
        object.__setattr__(self, "mask", m or ())
        object.__setattr__(self, "defaults_applied", defaults)
        object.__setattr__(self, "mask_info", dict(mask_info or {}))
        object.__setattr__(self, "labels", labels)
        object.__setattr__(self, "group_order", order if groups is not None else ())
        object.__setattr__(self, "per_group", tuple(n for n in free_t if n in per_group))
        object.__setattr__(self, "group_fixed", group_fixed)
        object.__setattr__(self, "slots", tuple(slots))
        object.__setattr__(self, "constraints", _check_constraints(constraints, free_t))
        check_fit_memory(model, recs)

    # ------------------------------------------------------------------
    @property
    def slot_names(self) -> tuple[str, ...]:
        """Names of the identified values: ``name`` when shared, ``name[label]`` per group."""
        return tuple(n if lab is None else f"{n}[{lab}]" for n, lab in self.slots)

    def slot_index(self, i: int) -> list[int]:
        """For record ``i``, the slot index of each free parameter (ordered as ``free``)."""
        lab = self.labels[i]
        out = []
        for n in self.free:
            key = (n, lab if n in self.per_group else None)
            out.append(self.slots.index(key))
        return out

    def fixed_value(self, i: int, name: str) -> float:
        """Value of fixed parameter ``name`` for record ``i`` (per-group defaults included)."""
        return float(self.group_fixed.get((name, self.labels[i]), self.fixed[name]))

    def record_params(self, i: int, slot_values) -> dict[str, float]:
        """Every parameter of record ``i`` by name, from the slot values (mapping or sequence)."""
        if not isinstance(slot_values, Mapping):
            slot_values = dict(zip(self.slot_names, map(float, slot_values)))
        idx = dict(zip(self.free, self.slot_index(i)))
        names = self.slot_names
        return {
            n: float(slot_values[names[idx[n]]]) if n in idx else self.fixed_value(i, n) for n in self.model.param_names
        }

    def sample_weights(self, i: int) -> np.ndarray:
        """Effective weight of each sample of record ``i`` (0 where masked)."""
        w = np.ones(self.records[i].n_times)
        if self.weights:
            w = w * self.weights[i]
        if self.mask:
            w = w * ~self.mask[i]
        return w

    def masks(self) -> tuple[np.ndarray, ...]:
        """Mask per record (all False when none was given)."""
        return self.mask or tuple(np.zeros(r.n_times, dtype=bool) for r in self.records)

    def full_params(self, free_values: Mapping[str, float] | Sequence[float]) -> dict[str, float]:
        """All parameters by name from the free values and the fixed ones."""
        if not isinstance(free_values, Mapping):
            free_values = dict(zip(self.free, map(float, free_values)))
        out = {}
        for n in self.model.param_names:
            out[n] = float(free_values[n]) if n in self.free else float(self.fixed[n])
        return out

    def summary(self) -> str:
        lines = [
            f"problem: model {self.model.name}, {len(self.records)} record(s), "
            f"{sum(r.n_times for r in self.records)} samples"
        ]
        lines.append(f"  free:  {', '.join(self.free)}")
        for k, v in self.fixed.items():
            lines.append(
                f"  fixed: {k} = {v:g}" + (f"  ({self.defaults_applied[k]})" if k in self.defaults_applied else "")
            )
        if self.mask:
            n = sum(int(m.sum()) for m in self.mask)
            lines.append(f"  mask:  {n} sample(s) out of the objective")
        return "\n".join(lines)
