"""The outcome of an identification, and its JSON form (``docs/contract.md``)."""

from __future__ import annotations

import builtins
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from duffsym._json import finite_or_none, jsonable
from duffsym.errors import DataError, ModelError
from duffsym.status import Status

if TYPE_CHECKING:
    from duffsym.effects.base import Effect

#: FIT.json keys about the data that :attr:`IdentificationResult.extras` carries (each an object)
EXTRA_KEYS = ("training_ranges", "decimation", "data_sanity")


def nrmse(y, y_hat) -> float:
    """The free-run error of ``docs/contract.md``: RMS(y - y_hat) / RMS(y - mean y); inf when y_hat is not finite."""
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    if not np.all(np.isfinite(y_hat)):
        return math.inf
    return float(np.sqrt(np.mean((y - y_hat) ** 2)) / np.sqrt(np.mean((y - y.mean()) ** 2)))


@dataclass(frozen=True, eq=False)
class IdentificationResult:
    """Identified parameters with their uncertainty, the fit quality and how the solver ended.

    Attributes
    ----------
    model : model name; ``effects`` the effects applied to it; ``structural`` its structural integers.
        :attr:`model_obj` is the model object itself: the one the fit ran with (``fitted_model``; the
        constructor also takes the object as ``model=``), or for a loaded fit the model rebuilt from
        ``model_spec`` (FIT.json's recipe, :mod:`duffsym.effects.spec`), or, for a file written before
        ``model_spec`` existed, from the name, powers and catalogue effects. :meth:`simulate` and
        :meth:`predict` run it on a record (lmfit's ``ModelResult.eval``).
    params : every parameter by name (free and fixed).
    free : names of the identified parameters; ``fixed`` the held ones with their values.
    stderr : standard error of each free parameter (Laplace approximation, see :func:`~duffsym.identify.fit`).
    covariance : (n_free, n_free) covariance of the free parameters, ordered as ``free``.
    cost : final least-squares cost, sum of weighted squared output residuals of the collocation fit
        (output units squared).
    nrmse : free-run simulation error over all samples of all records, RMS(y - yhat) / RMS(y - mean y)
        (pooled); ``r2 = 1 - nrmse**2``; ``nrmse_records`` per record; ``nrmse_objective`` over
        the samples in the objective only (unmasked).
    status, success, message : IPOPT's return status (a :class:`~duffsym.status.Status`, whose value is
        IPOPT's name; a string no member has is kept as it is), whether it converged and the free run
        succeeded, and a sentence for people.
    n_iter : IPOPT iterations. ``timings``: seconds spent in ``build``, ``solve``, ``free_run``, ``stderr``,
        ``flags`` (the quality checks).
    mask : per record, True where a sample was left out of the objective. ``mask_info``: how it was chosen.
    defaults_applied : name -> reason for each default the problem applied (``A_f``, ``k3``, ...).
    x0 : per record, the fitted initial state. ``y_sim``: per record, the free-run output.
    settings : solver tolerances and options used; ``versions`` of casadi/duffsym.
    flags : doubtful features of a usable fit, each ``{"flag": name, "message": ..., ...}``
        (:func:`duffsym.identify.quality.fit_flags`: parameters on a bound, outside the stability
        certificate, R² < 0.5).
    extras : what the command line adds about the data, written as top-level FIT.json keys
        (:data:`EXTRA_KEYS`): ``training_ranges`` (the command, amplitude and frequency ranges the fit saw,
        :func:`duffsym.data.sanity.training_ranges`), ``decimation`` (the rate the fit ran at) and
        ``data_sanity`` (the invalid stretches left out).
    model_spec : the recipe read from a FIT.json (:func:`duffsym.effects.spec.model_spec`); a fit in memory writes
        its model's recipe instead. ``fitted_model``: the model object the fit ran with (None for a loaded fit).
    """

    model: str
    params: dict
    free: tuple
    fixed: dict
    stderr: dict
    covariance: np.ndarray
    cost: float
    nrmse: float
    r2: float
    status: str
    success: bool
    message: str
    n_iter: int
    timings: dict
    mask: tuple = ()
    defaults_applied: dict = field(default_factory=dict)
    effects: tuple = ()
    structural: dict = field(default_factory=dict)
    nrmse_records: tuple = ()
    nrmse_objective: float = math.nan
    x0: tuple = ()
    y_sim: tuple = ()
    records: tuple = ()
    mask_info: dict = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    versions: dict = field(default_factory=dict)
    n_samples: int = 0
    group_params: dict = field(default_factory=dict)
    groups: tuple = ()
    flags: tuple = ()
    sampling: tuple = ()
    extras: dict = field(default_factory=dict)
    model_spec: dict = field(default_factory=dict, repr=False)
    fitted_model: Any = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.model, str) and hasattr(self.model, "param_names"):  # the model object itself
            object.__setattr__(self, "fitted_model", self.model)
            object.__setattr__(self, "model", self.model.name)
        status = Status.parse(self.status)
        if status is not Status.UNKNOWN:
            object.__setattr__(self, "status", status)

    # ------------------------------------------------------------------ the model
    @property
    def model_obj(self):
        """The fitted model object (see the class docstring); rebuilt once for a loaded fit.

        Raises
        ------
        ModelError
            When the saved fit cannot be rebuilt by this duffsym (one line saying why).
        """
        if self.fitted_model is not None:
            return self.fitted_model
        if "_rebuilt" not in self.__dict__:
            self.__dict__["_rebuilt"] = rebuild_model(self)
        return self.__dict__["_rebuilt"]

    def _spec(self) -> dict | None:
        """The ``model_spec`` to save: the fitted model's recipe, else the one read from the file."""
        if self.fitted_model is None:
            return dict(self.model_spec) or None
        if "_spec_cache" not in self.__dict__:
            from duffsym.effects.spec import model_spec

            try:
                self.__dict__["_spec_cache"] = model_spec(self.fitted_model)
            except ModelError:  # a setting that cannot be stored: the file falls back to the names
                self.__dict__["_spec_cache"] = None
        return self.__dict__["_spec_cache"]

    def group_for(self, record) -> str | None:
        """The group whose parameters apply to ``record`` in a fit with groups: its current (``"0.5A"``) or
        voltage (``"0.4V"``, which wins when both match) label when the fit has that group; None otherwise."""
        group = None
        for value, unit in ((record.current, "A"), (record.voltage, "V")):
            if self.group_params and value is not None and f"{value:g}{unit}" in self.group_params:
                group = f"{value:g}{unit}"
        return group

    def simulate(self, record, *, group: str | None = None, x0=None, **options):
        """The free run of the fitted model on ``record`` (a :class:`~duffsym.simulate.Trajectory`).

        The parameters are the fit's (those of ``group``, by default :meth:`group_for` the record); the
        initial state ``x0``, unless given, is estimated from the record's first input period as
        ``duffsym validate`` does (:func:`duffsym.identify.states.start_state`). ``options`` go to
        :func:`duffsym.simulate.simulate_record` (default ``on_failure="return"``: a failed run comes
        back with its status, not as an exception).
        """
        from duffsym.simulate import simulate_record

        model = self.model_obj
        p = model.param_vector(self.params_for(self.group_for(record) if group is None else group))
        if x0 is None:
            from duffsym.identify.states import start_state

            x0, _ = start_state(model, p, record)
        return simulate_record(model, p, record, x0=x0, **{"on_failure": "return", **options})

    def predict(self, record, **options) -> np.ndarray:
        """The fitted model's free-run output on ``record`` (``(n_times,)``; see :meth:`simulate`)."""
        return np.asarray(self.simulate(record, **options).y, dtype=float)

    def params_for(self, group: str | None = None) -> dict:
        """Every parameter by name for one group (``None`` for a fit without groups)."""
        if not self.group_params:
            return dict(self.params)
        if group not in self.group_params:
            raise DataError(f"this fit has groups {sorted(self.group_params)}; choose one (got {group!r})")
        return dict(self.group_params[group])

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix of the free parameters."""
        s = np.sqrt(np.diag(self.covariance))
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(s, s)

    def summary(self) -> str:
        lines = [
            f"fit of {self.model}"
            + (f" + {', '.join(self.effects)}" if self.effects else "")
            + f": {self.status} ({'success' if self.success else 'FAILED'}), {self.n_iter} iterations, "
            f"build {self.timings.get('build', math.nan):.3g} s, solve {self.timings.get('solve', math.nan):.3g} s"
        ]
        if not self.success:
            lines.append(f"  {self.message}")
        lines.append(
            f"  free-run NRMSE {self.nrmse:.4g} (R2 {self.r2:.5g}) over {self.n_samples} samples; cost {self.cost:.4g}"
        )
        lines += [
            f"  free run of {i.get('record', '?')} by {i['method']}: {i.get('reason', '')}"
            for i in self.settings.get("integrator", [])
            if i.get("method") != "rk4"
        ]
        lines += [f"  flag {f.get('flag', '?')}: {f.get('message', '')}" for f in self.flags]
        for n, v in self.params.items():
            if n in self.stderr:
                se = self.stderr[n]
                rel = f" ({_percent(abs(se / v))})" if v != 0 and math.isfinite(se) else ""
                lines.append(f"  {n:>6} = {v:12.6g} +/- {se:.3g}{rel}")
            else:
                why = self.defaults_applied.get(n.split("[")[0], "fixed by the user")
                lines.append(f"  {n:>6} = {v:12.6g}  fixed: {why}")
        n = sum(int(np.sum(m)) for m in self.mask)
        if n:
            lines.append(
                f"  mask: {n} sample(s) out of the objective" + (f" ({self.mask_info})" if self.mask_info else "")
            )
        return "\n".join(lines)

    # ------------------------------------------------------------------ JSON
    def to_dict(self) -> dict[str, Any]:
        """The JSON form of ``docs/contract.md`` (plus details); arrays of samples are not included."""
        return {
            "model": self.model,
            "effects": list(self.effects),
            "structural": {k: int(v) for k, v in self.structural.items()},
            "params": {k: float(v) for k, v in self.params.items()},
            "stderr": {k: finite_or_none(v) for k, v in self.stderr.items()},
            "nrmse": finite_or_none(self.nrmse),
            "r2": finite_or_none(self.r2),
            "status": str(self.status),
            "success": bool(self.success),
            "message": self.message,
            "flags": jsonable([dict(f) for f in self.flags]),
            "free": list(self.free),
            "fixed": {k: float(v) for k, v in self.fixed.items()},
            "defaults_applied": dict(self.defaults_applied),
            "covariance": [[finite_or_none(v) for v in row] for row in np.asarray(self.covariance)],
            "cost": finite_or_none(self.cost),
            "nrmse_records": [finite_or_none(v) for v in self.nrmse_records],
            "nrmse_objective": finite_or_none(self.nrmse_objective),
            "n_iter": int(self.n_iter),
            "timings": {k: float(v) for k, v in self.timings.items()},
            "x0": [list(map(float, x)) for x in self.x0],
            "records": list(self.records),
            "n_masked": [int(np.sum(m)) for m in self.mask],
            "mask": [mask_to_ranges(m) for m in self.mask],
            "mask_info": jsonable(self.mask_info),
            "n_samples": int(self.n_samples),
            "settings": jsonable(self.settings),
            "versions": dict(self.versions),
            "group_params": {g: {k: float(v) for k, v in p.items()} for g, p in self.group_params.items()},
            "groups": list(self.groups),
            **(
                {"sampling": jsonable(self.sampling[0] if len(self.sampling) == 1 else list(self.sampling))}
                if self.sampling
                else {}
            ),
            **{k: jsonable(v) for k, v in self.extras.items() if k in EXTRA_KEYS},
            **({"model_spec": spec} if (spec := self._spec()) else {}),
        }

    def with_extras(self, **extras) -> IdentificationResult:
        """This result with FIT.json keys of :data:`EXTRA_KEYS` added (None values are left out)."""
        import dataclasses

        unknown = set(extras) - set(EXTRA_KEYS)
        if unknown:
            raise ValueError(f"unknown result extras {sorted(unknown)}; known: {EXTRA_KEYS}")
        return dataclasses.replace(self, extras={**self.extras, **{k: v for k, v in extras.items() if v is not None}})

    def save(self, path) -> Path:
        """Write the result as JSON (``docs/contract.md``), atomically (a temporary file renamed over ``path``)."""
        from duffsym._io import write_json_atomic

        return write_json_atomic(path, self.to_dict())

    def with_sampling(self, records) -> IdentificationResult:
        """This result with each record's time-base description (``metadata["sampling"]``) attached."""
        import dataclasses

        return dataclasses.replace(self, sampling=tuple(dict(r.metadata.get("sampling", {})) for r in records))

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "result") -> IdentificationResult:
        """Rebuild a result from its JSON form (the masks come back; the sample arrays are not stored).

        Every field is checked: a tampered or truncated file gives a :class:`DataError` naming the
        field, never a Python error from deep inside.
        """
        if not isinstance(data, Mapping):
            raise DataError(f"{source}: expected a JSON object (a duffsym fit); produce it with duffsym fit --out")
        need = ("model", "params", "stderr", "nrmse", "status", "success")
        missing = [k for k in need if k not in data]
        if missing:
            raise DataError(f"{source}: not a duffsym fit: missing key(s) {missing}; produce it with duffsym fit --out")
        r = _Reader(data, source)
        flags = data.get("flags")
        params = r.numbers("params")
        stderr = r.numbers("stderr", allow_none=True)
        free: tuple[str, ...] = tuple(r.strings("free", default=list(stderr)))
        cov = r.matrix("covariance", len(free))
        nrmse = r.number("nrmse", allow_none=True)
        r2_default = 1 - nrmse**2 if math.isfinite(nrmse) and abs(nrmse) < 1e150 else None
        return cls(
            model=r.string("model"),
            params=params,
            free=free,
            fixed=r.numbers("fixed", default={}),
            stderr=stderr,
            covariance=cov,
            cost=r.number("cost", default=None, allow_none=True),
            nrmse=nrmse,
            r2=r.number("r2", default=r2_default, allow_none=True),
            status=r.string("status"),
            success=r.boolean("success"),
            message=r.string("message", default=""),
            n_iter=r.integer("n_iter", default=0),
            timings=r.numbers("timings", default={}),
            defaults_applied=r.mapping("defaults_applied"),
            effects=tuple(r.strings("effects", default=[])),
            structural={k: r.bounded_int(f"structural.{k}", v, 1, 1000) for k, v in r.mapping("structural").items()},
            nrmse_records=tuple(r.number_list("nrmse_records")),
            nrmse_objective=r.number("nrmse_objective", default=None, allow_none=True),
            x0=tuple(tuple(r.number_list(f"x0[{i}]", x)) for i, x in enumerate(r.list("x0"))),
            records=tuple(r.strings("records", default=[])),
            mask_info=r.mapping("mask_info"),
            mask=tuple(mask_from_ranges(m, source=source) for m in r.list("mask")),
            settings=r.mapping("settings"),
            versions=r.mapping("versions"),
            n_samples=r.integer("n_samples", default=0),
            group_params={str(g): r.numbers(f"group_params.{g}", p) for g, p in r.mapping("group_params").items()},
            groups=tuple(r.strings("groups", default=[])),
            sampling=_sampling_of(data.get("sampling")),
            flags=tuple(dict(f) for f in (flags if isinstance(flags, list) else ()) if isinstance(f, Mapping)),
            extras={k: r.mapping(k) for k in EXTRA_KEYS if k in data},
            model_spec=r.mapping("model_spec"),
        )


def rebuild_model(result: IdentificationResult):
    """The model of a saved fit: from its ``model_spec`` (any model it was fitted with), else, for a file
    written before ``model_spec``, from the name, structural powers and effects (the catalogue's, a
    discovered term and a drifting parameter by their names)."""
    if result.model_spec:
        from duffsym.effects.spec import model_from_spec

        return model_from_spec(result.model_spec, source=f"fit of {result.model}: model_spec")
    return _model_from_names(result)


def _model_from_names(result: IdentificationResult):
    """The name-based rebuild of a fit saved without ``model_spec``."""
    from duffsym.model import get_model

    structural = dict(result.structural)
    n = structural.get("n_x", structural.get("n"))
    try:
        model = get_model(result.model, None if n is None or result.model == "duffing" else int(n))
    except ModelError as exc:
        raise ModelError(f"cannot rebuild the fitted model: {exc}") from None
    if result.effects:
        from duffsym.effects import CATALOGUE, apply_effects
        from duffsym.effects.discovered import PREFIX, from_name
        from duffsym.effects.drift import PREFIX as DRIFT
        from duffsym.effects.drift import from_name as drift_from_name

        missing = [e for e in result.effects if e not in CATALOGUE and not e.startswith((PREFIX, DRIFT))]
        if missing:
            raise ModelError(f"the fit uses effect(s) {missing} unknown to this duffsym; known: {sorted(CATALOGUE)}")
        n_disc = 0
        for e in result.effects:  # a discovered term (duffsym ladder --discover) is rebuilt from its name
            n_disc += e.startswith(PREFIX)
            effect: Effect
            if e.startswith(PREFIX):
                effect = from_name(e, n_disc)
            else:  # a drift term or a catalogued effect (an unknown name was refused above)
                effect = drift_from_name(e) if e.startswith(DRIFT) else CATALOGUE[e]
            model = apply_effects(model, [effect])
    return model


def _sampling_of(value) -> tuple:
    if isinstance(value, Mapping):
        return (dict(value),)
    if isinstance(value, list):
        return tuple(dict(v) for v in value if isinstance(v, Mapping))
    return ()


class _Reader:
    """Typed access to the fields of a FIT.json, with one-line errors naming the field."""

    def __init__(self, data: Mapping[str, Any], source: str):
        self.data, self.source = data, source

    def fail(self, key: str, what: str, value) -> DataError:
        text = json.dumps(value, default=str)[:60] if _shallow(value) else type(value).__name__
        return DataError(
            f"{self.source}: field {key!r} must be {what}; got {text}; the file is damaged or edited: "
            "produce it again with duffsym fit --out"
        )

    def get(self, key, default=KeyError):
        if key in self.data:
            return self.data[key]
        if default is KeyError:
            raise DataError(f"{self.source}: missing field {key!r}; produce it with duffsym fit --out")
        return default

    def number(self, key, value=KeyError, *, default=KeyError, allow_none=False) -> float:
        v = self.get(key, default) if value is KeyError else value
        if v is None and allow_none:
            return math.nan
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(key, "a number", v)
        try:
            out = float(v)
        except OverflowError:
            out = math.inf
        if not math.isfinite(out):
            raise self.fail(key, "a finite number (JSON has no inf/NaN; duffsym writes null)", v)
        return out

    def integer(self, key, *, default=KeyError) -> int:
        v = self.get(key, default)
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= 10**12:
            raise self.fail(key, "a non-negative integer", v)
        return int(v)

    def bounded_int(self, key, v, lo, hi) -> int:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not float(v).is_integer() or not lo <= v <= hi:
            raise self.fail(key, f"an integer in [{lo}, {hi}]", v)
        return int(v)

    def boolean(self, key) -> bool:
        v = self.get(key)
        if not isinstance(v, bool):
            raise self.fail(key, "true or false", v)
        return v

    def string(self, key, *, default=KeyError) -> str:
        v = self.get(key, default)
        if not isinstance(v, str):
            raise self.fail(key, "a string", v)
        return v

    def list(self, key, value=KeyError) -> list:
        v = self.get(key, []) if value is KeyError else value
        if not isinstance(v, list):
            raise self.fail(key, "a list", v)
        return v

    def strings(self, key, *, default=KeyError) -> builtins.list[str]:
        v = self.get(key, default)
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise self.fail(key, "a list of strings", v)
        return list(v)

    def mapping(self, key) -> dict:
        v = self.get(key, {})
        if not isinstance(v, Mapping):
            raise self.fail(key, "an object", v)
        return dict(v)

    def numbers(self, key, value=KeyError, *, default=KeyError, allow_none=False) -> dict[str, float]:
        v = self.get(key, default) if value is KeyError else value
        if not isinstance(v, Mapping):
            raise self.fail(key, "an object of name: number", v)
        return {str(k): self.number(f"{key}.{k}", x, allow_none=allow_none) for k, x in v.items()}

    def number_list(self, key, value=KeyError) -> builtins.list[float]:
        return [self.number(f"{key}[{i}]", x, allow_none=True) for i, x in enumerate(self.list(key, value))]

    def matrix(self, key, n: int) -> np.ndarray:
        v = self.get(key, None)
        if not v:
            return np.full((n, n), np.nan)
        rows = self.list(key, v)
        if len(rows) != n or not all(isinstance(row, list) and len(row) == n for row in rows):
            raise self.fail(key, f"a {n} x {n} matrix (one row and column per free parameter)", v)
        return np.array([self.number_list(f"{key}[{i}]", row) for i, row in enumerate(rows)], dtype=float)


def _shallow(value) -> bool:
    """Whether ``value`` is a scalar or a flat container (safe and short to print)."""
    if isinstance(value, (dict, list)):
        return all(not isinstance(v, (dict, list)) for v in (value.values() if isinstance(value, dict) else value))
    return True


def mask_to_ranges(mask) -> dict:
    """A boolean mask as ``{"n_times": N, "ranges": [[start, stop], ...]}`` (half-open runs of True)."""
    m = np.asarray(mask, dtype=bool).reshape(-1)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], m.astype(np.int8), [0]])))
    return {"n_times": int(m.size), "ranges": edges.reshape(-1, 2).tolist()}


def mask_from_ranges(data: Mapping[str, Any], *, source: str = "result") -> np.ndarray:
    """Inverse of :func:`mask_to_ranges`, checked."""
    try:
        n = int(data["n_times"])
        ranges = [(int(a), int(b)) for a, b in data["ranges"]]
        if isinstance(data["n_times"], bool) or not 0 < n <= 10**8:
            raise ValueError
    except (KeyError, TypeError, ValueError, OverflowError):
        raise DataError(
            f"{source}: a stored mask must be {{'n_times': N, 'ranges': [[start, stop], ...]}}; got {str(data)[:80]}"
        ) from None
    m = np.zeros(n, dtype=bool)
    for a, b in ranges:
        if not 0 <= a < b <= n:
            raise DataError(f"{source}: mask range [{a}, {b}) lies outside 0..{n}")
        m[a:b] = True
    return m


def load_result(path) -> IdentificationResult:
    """Read a result saved by :meth:`IdentificationResult.save` (or ``duffsym fit --out``)."""
    from duffsym._io import check_input_file

    path = Path(path)
    if not path.exists():
        raise DataError(f"{path}: no such file; give a fit saved with duffsym fit --out")
    check_input_file(path, what="fit file", limit=256 * 1024**2)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid JSON ({str(exc)[:80]}); give a fit saved with duffsym fit --out") from None
    except RecursionError:
        raise DataError(
            f"{path}: JSON nested too deeply to be a duffsym fit; give a fit saved with duffsym fit --out"
        ) from None
    if not isinstance(data, dict):
        raise DataError(f"{path}: expected a JSON object (a duffsym fit)")
    return IdentificationResult.from_dict(data, source=str(path))


def _percent(r: float) -> str:
    """A relative standard error as a percentage with two significant digits (``0.0031%``, not ``0.00%``)."""
    return f"{r:.2%}" if r >= 1e-3 else f"{100 * r:.2g}%"
