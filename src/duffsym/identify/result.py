"""The outcome of an identification, and its JSON form (``docs/contract.md``)."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from duffsym._json import finite_or_none, jsonable
from duffsym.errors import DataError


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
    params : every parameter by name (free and fixed).
    free : names of the identified parameters; ``fixed`` the held ones with their values.
    stderr : standard error of each free parameter (Laplace approximation, see :func:`~duffsym.identify.fit`).
    covariance : (n_free, n_free) covariance of the free parameters, ordered as ``free``.
    cost : final least-squares cost, sum of weighted squared output residuals of the collocation fit
        (output units squared).
    nrmse : free-run simulation error over all samples of all records, RMS(y - yhat) / RMS(y - mean y)
        (pooled); ``r2 = 1 - nrmse**2``; ``nrmse_records`` per record; ``nrmse_objective`` over
        the samples in the objective only (unmasked).
    status, success, message : IPOPT's return status, whether it converged and the free run
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
        lines = [f"fit of {self.model}" + (f" + {', '.join(self.effects)}" if self.effects else "")
                 + f": {self.status} ({'success' if self.success else 'FAILED'}), {self.n_iter} iterations, "
                 f"build {self.timings.get('build', math.nan):.3g} s, solve {self.timings.get('solve', math.nan):.3g} s"]
        if not self.success:
            lines.append(f"  {self.message}")
        lines.append(f"  free-run NRMSE {self.nrmse:.4g} (R2 {self.r2:.5g}) over {self.n_samples} samples; "
                     f"cost {self.cost:.4g}")
        lines += [f"  flag {f.get('flag', '?')}: {f.get('message', '')}" for f in self.flags]
        for n, v in self.params.items():
            if n in self.stderr:
                se = self.stderr[n]
                rel = f" ({abs(se / v):.2%})" if v != 0 and math.isfinite(se) else ""
                lines.append(f"  {n:>6} = {v:12.6g} +/- {se:.3g}{rel}")
            else:
                why = self.defaults_applied.get(n.split("[")[0], "fixed by the user")
                lines.append(f"  {n:>6} = {v:12.6g}  fixed: {why}")
        n = sum(int(np.sum(m)) for m in self.mask)
        if n:
            lines.append(f"  mask: {n} sample(s) out of the objective" + (f" ({self.mask_info})" if self.mask_info else ""))
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
            "status": self.status,
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
        }

    def save(self, path) -> Path:
        """Write the result as JSON (``docs/contract.md``)."""
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=2, allow_nan=False))
        return path

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source: str = "result") -> "IdentificationResult":
        """Rebuild a result from its JSON form (the masks come back; the sample arrays are not stored)."""
        need = ("model", "params", "stderr", "nrmse", "status", "success")
        missing = [k for k in need if k not in data]
        if missing:
            raise DataError(f"{source}: not a duffsym fit: missing key(s) {missing}; produce it with duffsym fit --out")

        def f(v):
            return math.nan if v is None else float(v)

        free = tuple(data.get("free", [k for k in data["stderr"]]))
        cov = data.get("covariance")
        cov = np.array([[f(v) for v in row] for row in cov]) if cov else np.full((len(free), len(free)), np.nan)
        nrmse = f(data["nrmse"])
        return cls(
            model=str(data["model"]), params={k: float(v) for k, v in data["params"].items()}, free=free,
            fixed={k: float(v) for k, v in data.get("fixed", {}).items()},
            stderr={k: f(v) for k, v in data["stderr"].items()}, covariance=cov, cost=f(data.get("cost")),
            nrmse=nrmse, r2=f(data.get("r2", 1 - nrmse**2 if math.isfinite(nrmse) else None)),
            status=str(data["status"]), success=bool(data["success"]), message=str(data.get("message", "")),
            n_iter=int(data.get("n_iter", 0)), timings=dict(data.get("timings", {})),
            defaults_applied=dict(data.get("defaults_applied", {})), effects=tuple(data.get("effects", ())),
            structural=dict(data.get("structural", {})),
            nrmse_records=tuple(f(v) for v in data.get("nrmse_records", ())),
            nrmse_objective=f(data.get("nrmse_objective")), x0=tuple(tuple(x) for x in data.get("x0", ())),
            records=tuple(data.get("records", ())), mask_info=dict(data.get("mask_info", {})),
            mask=tuple(mask_from_ranges(m, source=source) for m in data.get("mask", ())),
            settings=dict(data.get("settings", {})), versions=dict(data.get("versions", {})),
            n_samples=int(data.get("n_samples", 0)),
            group_params={g: {k: float(v) for k, v in p.items()} for g, p in data.get("group_params", {}).items()},
            groups=tuple(data.get("groups", ())),
            flags=tuple(dict(f) for f in (data.get("flags") if isinstance(data.get("flags"), list) else ())
                        if isinstance(f, Mapping)),
        )


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
    except (KeyError, TypeError, ValueError):
        raise DataError(f"{source}: a stored mask must be {{'n_times': N, 'ranges': [[start, stop], ...]}}; "
                        f"got {str(data)[:80]}") from None
    m = np.zeros(n, dtype=bool)
    for a, b in ranges:
        if not 0 <= a < b <= n:
            raise DataError(f"{source}: mask range [{a}, {b}) lies outside 0..{n}")
        m[a:b] = True
    return m


def load_result(path) -> IdentificationResult:
    """Read a result saved by :meth:`IdentificationResult.save` (or ``duffsym fit --out``)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text())
    except FileNotFoundError:
        raise DataError(f"{path}: no such file; give a fit saved with duffsym fit --out") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise DataError(f"{path}: not valid JSON ({exc}); give a fit saved with duffsym fit --out") from None
    if not isinstance(data, dict):
        raise DataError(f"{path}: expected a JSON object (a duffsym fit)")
    return IdentificationResult.from_dict(data, source=str(path))
