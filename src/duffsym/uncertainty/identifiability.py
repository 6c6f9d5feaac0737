r"""Identifiability of a fit: the model's scaling symmetry, the Fisher information of the data at the
optimum, and the posterior correlations, combined into named weak directions with what data would
resolve them.

- **Symmetry** (:func:`duffsym.derive.symmetry.find_scaling_symmetry`): a one-parameter family of
  parameter sets with *identical* output. If every parameter it moves is free, no data can fix that
  direction: one of them must be fixed.
- **Fisher information** :math:`F = S^\top S/\sigma^2`, with :math:`S` the sensitivities of the
  simulated output to the coordinates :math:`\zeta` (:math:`\log\theta` for positive scale parameters,
  :math:`\theta/\mathrm{scale}` otherwise), by central differences on the sampler's fixed substep
  schedule, and :math:`\sigma^2` from the residuals. An eigenvalue :math:`\lambda` gives the standard
  deviation :math:`1/\sqrt\lambda` of the data's knowledge along its eigenvector (for log
  coordinates, a relative change). Its inverse (Cramer-Rao) gives each parameter's **variance
  inflation factor** (scale-free: how much the correlations with the others widen its uncertainty)
  and its correlated partners. A parameter with VIF above :data:`VIF_UNIDENTIFIABLE` whose
  Cramer-Rao sd exceeds half its value is *unidentifiable* (a ridge), with VIF above
  :data:`VIF_WEAK` *weak*; the finding names it with its partners (|correlation| >= 0.8) and, when
  an x^n-type term trades against linear ones, asks for several amplitudes.
- **Posterior correlations** above :data:`CORRELATED` in magnitude (sampling coordinates).

References
----------
Raue et al. (2009), structural and practical identifiability analysis of partially observed dynamical
models by exploiting the profile likelihood, Bioinformatics 25, 1923, doi:10.1093/bioinformatics/btp358.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

UNIDENTIFIABLE_SD = 0.5
WEAK_SD = 0.1
#: Variance inflation factor (scale-free: 1 / (1 - R^2) of a parameter regressed on the others, Cramer-Rao)
#: above which a parameter is named with its correlated partners: *unidentifiable* when also its
#: Cramer-Rao sd exceeds half its value (the ridge lets it wander by more than its size), else *weak*.
VIF_UNIDENTIFIABLE = 100.0
VIF_WEAK = 50.0
REL_SD_UNIDENTIFIABLE = 0.5
CORRELATED = 0.9
#: Relative spread of the input's cycle peaks below which a record counts as "single amplitude".
SINGLE_AMPLITUDE_SPREAD = 0.05


@dataclass(frozen=True, eq=False)
class IdentifiabilityReport:
    """What the fit's data can and cannot identify. ``to_dict()`` for JSON, ``text`` for people."""

    free: tuple
    coordinates: tuple
    symmetry: dict
    eigenvalues: np.ndarray
    eigenvectors: np.ndarray
    directions: list
    correlations: list
    findings: list
    excitation: dict
    text: str
    fisher: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    fisher_correlation: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    params: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "free": list(self.free),
            "coordinates": list(self.coordinates),
            "symmetry": self.symmetry,
            "eigenvalues": self.eigenvalues.tolist(),
            "directions": self.directions,
            "posterior_correlations": self.correlations,
            "findings": self.findings,
            "excitation": self.excitation,
            "text": self.text,
            "fisher_correlation": self.fisher_correlation.tolist(),
            "params": self.params,
        }


def _coordinate(prior):
    return "log" if prior.kind == "log-uniform" else "linear"


def fisher_information(post, *, rel_step: float = 1e-4):
    """Fisher information of the free parameters in the sampling-like coordinates at the fit's optimum.

    Returns ``(F, names, coordinate kinds, scales, sigma2 per record)``. ``post`` is a
    :class:`~duffsym.uncertainty.LogPosterior` (its fixed substep schedule keeps the differences smooth).
    """
    free = list(post.free)
    theta = post.base[post.index]
    n = len(free)
    kinds, scales = [], []
    for j, n_ in enumerate(free):
        pr = post.priors[j]
        kinds.append(_coordinate(pr))
        spec_scale = post.model.param(n_).scale or 1.0
        scales.append(1.0 if pr.kind == "log-uniform" else max(abs(theta[j]), abs(spec_scale)))
    P = np.tile(post.base, (2 * n + 1, 1))
    for j in range(n):
        i = post.index[j]
        if kinds[j] == "log":
            P[2 * j + 1, i] = theta[j] * math.exp(rel_step)
            P[2 * j + 2, i] = theta[j] * math.exp(-rel_step)
        else:
            P[2 * j + 1, i] = theta[j] + rel_step * scales[j]
            P[2 * j + 2, i] = theta[j] - rel_step * scales[j]
    F = np.zeros((n, n))
    sig2 = []
    for sim, y, keep in zip(post.simulators, post.ys, post.keep):
        Y, status, _, _ = sim.run(P)
        if np.any(status != 0):
            raise RuntimeError("a sensitivity run failed to simulate; the optimum is at a stiffness limit")
        r = (Y[0] - y)[keep]
        s2 = float(np.sum(r**2) / max(r.size - n, 1))
        S = np.column_stack([(Y[2 * j + 1] - Y[2 * j + 2])[keep] / (2 * rel_step) for j in range(n)])
        F += S.T @ S / s2
        sig2.append(s2)
    return F, free, kinds, np.array(scales), sig2


def _label(name, kind, scale):
    if kind == "log":
        return f"log {name}"
    return f"{name}/{scale:.3g}"


def _state_degree(model, name) -> int:
    """Highest degree in the states of the rhs terms that ``name`` multiplies (1 for linear terms)."""
    sym = model.param(name).symbol
    best = 0
    for e in model.rhs:
        d = sp.diff(e, sym)
        if d == 0:
            continue
        try:
            poly = sp.Poly(sp.expand(d), *model.states)
            best = max(best, poly.total_degree())
        except sp.PolynomialError:
            best = max(best, 99)
    return best


def excitation_summary(records) -> dict:
    """Per record: the spread of the input's cycle peaks (single amplitude if below 5 %)."""
    out = []
    for rec in records:
        d = np.asarray(rec.d, dtype=float) - float(np.mean(rec.d))
        found: list[float] = []
        for sgn in (1, -1):
            s = sgn * d
            k = np.flatnonzero((s[1:-1] > s[:-2]) & (s[1:-1] >= s[2:]) & (s[1:-1] > 0.2 * np.max(np.abs(d)))) + 1
            found.extend(s[k].tolist())
        peaks = np.asarray(found)
        spread = float(np.std(peaks) / np.mean(peaks)) if peaks.size >= 2 else math.nan
        out.append(
            {
                "record": rec.name,
                "n_peaks": int(peaks.size),
                "peak_spread": spread,
                "max_abs_input": float(np.max(np.abs(d))),
            }
        )
    amps = [o["max_abs_input"] for o in out]
    single = all(o["peak_spread"] < SINGLE_AMPLITUDE_SPREAD for o in out if math.isfinite(o["peak_spread"])) and (
        len(amps) == 1 or (max(amps) - min(amps)) / max(amps) < SINGLE_AMPLITUDE_SPREAD
    )
    return {"records": out, "single_amplitude": bool(single)}


def identifiability_report(result, records, *, chains=None, model=None, post=None) -> IdentifiabilityReport:
    """Combine the scaling symmetry, the Fisher spectrum at the optimum and (when ``chains`` are given)
    the posterior correlations into named weak directions, with the data that would resolve each."""
    from duffsym.uncertainty._setup import as_records, build_posterior

    records = as_records(records)
    if post is None:
        post, model, records, _ = build_posterior(result, records, model=model)
    model = post.model
    F, free, kinds, scales, sig2 = fisher_information(post)
    labels = [_label(n, k, s) for n, k, s in zip(free, kinds, scales)]
    w, V = np.linalg.eigh(0.5 * (F + F.T))
    order = np.argsort(w)
    w, V = w[order], V[:, order]
    exc = excitation_summary(records)
    sym, sym_info, sym_dir = _symmetry(model, post, free, kinds, scales)
    # --- Fisher directions; the Cramer-Rao correlations name the partners of a weak direction (the
    # eigenvectors depend on the coordinates' scales, the correlations do not)
    cov = np.linalg.pinv(0.5 * (F + F.T))
    csd = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    fcorr = cov / np.outer(csd, csd)
    # variance inflation: how much the correlations widen each parameter's uncertainty (scale-free)
    vif = np.clip(np.diag(cov) * np.diag(F), 1.0, None)
    directions = _directions(w, V, free, fcorr, labels, sym_dir)
    corr_pairs = _posterior_pairs(chains)
    params_info = _params_info(post, free, kinds, scales, fcorr, csd, vif)
    degrees = {n: _state_degree(model, n) for n in free}
    findings = _findings(sym, sym_info, free, params_info, degrees, corr_pairs, exc)
    text = _report_text(model, free, records, exc, sym, sym_info, params_info, directions, findings)
    return IdentifiabilityReport(
        free=tuple(free),
        coordinates=tuple(labels),
        symmetry=sym_info,
        eigenvalues=w,
        eigenvectors=V,
        directions=directions,
        correlations=corr_pairs,
        findings=findings,
        excitation=exc,
        text=text,
        fisher=F,
        fisher_correlation=fcorr,
        params=params_info,
    )


def _symmetry(model, post, free, kinds, scales):
    """(the model's scaling symmetry, what it moves and whether fixing a parameter breaks it, its direction in
    the report's coordinates when every parameter it moves is free, else None)."""
    from duffsym.derive.symmetry import find_scaling_symmetry

    sym = find_scaling_symmetry(model)
    sym_info = {"exists": bool(sym.exists), "text": sym.text, "moved": [], "fixed_moved": [], "broken": True}
    sym_dir = None
    if sym.exists:
        values = {p.symbol: float(v) for p, v in zip(model.params, post.base)}
        tangent = {k: float(sp.sympify(e).xreplace(values)) for k, e in sym.tangent.items()}
        moved = [k for k, v in tangent.items() if abs(v) > 0]
        fixed_moved = [k for k in moved if k not in free]
        sym_info.update(
            moved=moved,
            fixed_moved=fixed_moved,
            broken=bool(fixed_moved),
            mapping={k: str(e) for k, e in sym.mapping.items()},
        )
        if not fixed_moved:
            theta = post.base[post.index]
            v = np.array(
                [tangent[n] / theta[j] if kinds[j] == "log" else tangent[n] / scales[j] for j, n in enumerate(free)]
            )
            sym_dir = v / np.linalg.norm(v)
    return sym, sym_info, sym_dir


def _directions(w, V, free, fcorr, labels, sym_dir) -> list[dict]:
    """Each Fisher eigen-direction: its sd, status, leading components and the correlated partners of its lead."""
    directions = []
    for k in range(len(w)):
        sd = 1 / math.sqrt(w[k]) if w[k] > 0 else math.inf
        v = V[:, k] * (1 if V[np.argmax(np.abs(V[:, k])), k] > 0 else -1)
        comps = {free[j]: float(v[j]) for j in np.argsort(-np.abs(v)) if abs(v[j]) >= 0.2}
        lead = int(np.argmax(np.abs(v)))
        partners = {
            free[j]: float(fcorr[lead, j])
            for j in np.argsort(-np.abs(fcorr[lead]))
            if j != lead and abs(fcorr[lead, j]) >= 0.8
        }
        status = "unidentifiable" if sd > UNIDENTIFIABLE_SD else ("weak" if sd > WEAK_SD else "identified")
        directions.append(
            {
                "eigenvalue": float(w[k]),
                "sd": sd,
                "status": status,
                "components": comps,
                "correlated_with": partners,
                "label": " ".join(f"{c:+.2f} {labels[free.index(n)]}" for n, c in comps.items()),
                "symmetry_overlap": float(abs(sym_dir @ v)) if sym_dir is not None else None,
            }
        )
    return directions


def _posterior_pairs(chains) -> list[dict]:
    """The pairs of sampled quantities whose posterior correlation reaches ``CORRELATED`` ([] without chains)."""
    corr_pairs = []
    if chains is not None:
        C = chains.correlation()
        names = list(chains.names)
        for i in range(len(names)):
            for j in range(i):
                if abs(C[i, j]) >= CORRELATED:
                    corr_pairs.append({"pair": [names[j], names[i]], "correlation": float(C[i, j])})
    return corr_pairs


def _params_info(post, free, kinds, scales, fcorr, csd, vif) -> dict:
    """Per free parameter: its variance inflation, relative sd, strongly correlated partners and status."""
    params_info = {}
    for j, n in enumerate(free):
        partners = {
            free[i]: float(fcorr[j, i]) for i in np.argsort(-np.abs(fcorr[j])) if i != j and abs(fcorr[j, i]) >= 0.8
        }
        theta_j = float(post.base[post.index[j]])
        # csd is in the report's coordinates: log (relative) for log-scale parameters, value/scale otherwise
        rel = float(csd[j]) if kinds[j] == "log" else float(csd[j] * scales[j] / max(abs(theta_j), 1e-300))
        status = (
            "unidentifiable"
            if vif[j] > VIF_UNIDENTIFIABLE and rel > REL_SD_UNIDENTIFIABLE
            else ("weak" if vif[j] > VIF_WEAK else "identified")
        )
        params_info[n] = {"vif": float(vif[j]), "relative_sd": rel, "partners": partners, "status": status}
    return params_info


def _findings(sym, sym_info, free, params_info, degrees, corr_pairs, exc) -> list[dict]:
    """The named findings: the symmetry, each group of weak parameters (with why and what data resolve it),
    and the posterior correlations no group covers."""
    findings = []
    if sym.exists and not sym_info["broken"]:
        findings.append(
            {
                "kind": "symmetry",
                "params": sym_info["moved"],
                "evidence": "x -> s x leaves the output unchanged along this family (found symbolically)",
                "resolve": "no data can: fix one of them (the paper fixes A_f = max|y|)",
            }
        )
    elif sym.exists:
        findings.append(
            {
                "kind": "symmetry broken",
                "params": sym_info["moved"],
                "evidence": f"the scaling symmetry is broken by fixing {', '.join(sym_info['fixed_moved'])}",
                "resolve": "nothing needed; the gains are relative to the fixed value",
            }
        )
    done: set = set()
    for n in sorted(free, key=lambda k: (_RANK[params_info[k]["status"]], -params_info[k]["vif"])):
        info = params_info[n]
        if info["status"] == "identified" or n in done:
            continue
        involved = [n] + [m for m in info["partners"] if m not in done]
        done.update(involved)
        findings.append(_weak_finding(n, info, involved, params_info, degrees, corr_pairs, exc))
    for p in corr_pairs:
        if not any(set(p["pair"]) <= set(f["params"]) for f in findings):
            findings.append(
                {
                    "kind": "correlated",
                    "params": p["pair"],
                    "evidence": f"posterior correlation {p['correlation']:+.2f}",
                    "resolve": "richer excitation (several amplitudes and frequencies)",
                }
            )
    return findings


_RANK = {"unidentifiable": 0, "weak": 1, "identified": 2}


def _weak_finding(n, info, involved, params_info, degrees, corr_pairs, exc) -> dict:
    """The finding of a weak parameter ``n`` and its partners ``involved``: the evidence, why, what resolves it."""
    nonlinear = [m for m in involved if degrees.get(m, 1) > 1]
    linear = [m for m in involved if degrees.get(m, 1) <= 1]
    pairs = [p for p in corr_pairs if set(p["pair"]) <= set(involved)]
    ev = (
        f"the correlations with {', '.join(f'{m} ({c:+.2f})' for m, c in info['partners'].items()) or 'the others'} "
        f"inflate the variance of {n} {info['vif']:.3g}-fold (Cramer-Rao)"
    )
    if pairs:
        ev += "; posterior correlations " + ", ".join(
            f"{a}-{b} {c['correlation']:+.2f}" for c in pairs for a, b in [c["pair"]]
        )
    if nonlinear and linear:
        why = (
            f"the x^n-type term(s) of {', '.join(nonlinear)} can be mimicked by the linear one(s) of "
            f"{', '.join(linear)} at a single amplitude"
        )
        if exc["single_amplitude"]:
            why += " (every record here has one amplitude)"
        resolve = "records at several amplitudes: an amplitude-stepped sine, a multisine or a band-limited random input"
    else:
        why = "the record does not separate these terms"
        resolve = "records at several frequencies and amplitudes (band-limited random excitation)"
    return {
        "kind": min((params_info[m]["status"] for m in involved), key=_RANK.__getitem__),
        "params": involved,
        "evidence": ev,
        "why": why,
        "resolve": resolve,
        "vif": info["vif"],
    }


def _report_text(model, free, records, exc, sym, sym_info, params_info, directions, findings) -> str:
    """The identifiability report for people (``IdentifiabilityReport.text``)."""
    lines = [
        f"identifiability of {model.name} ({', '.join(free)} free) on {len(records)} record(s)"
        + (" at a single amplitude" if exc["single_amplitude"] else "")
    ]
    lines.append(
        "  scaling symmetry: "
        + (
            "none"
            if not sym.exists
            else (
                f"moves {', '.join(sym_info['moved'])}; "
                + (
                    "broken by fixing " + ", ".join(sym_info["fixed_moved"])
                    if sym_info["broken"]
                    else "UNBROKEN (all free)"
                )
            )
        )
    )
    lines.append(
        "  variance inflation (Cramer-Rao): " + ", ".join(f"{n} {p['vif']:.3g}" for n, p in params_info.items())
    )
    lines.append(
        "  Fisher sd along eigen-directions (weakest first): "
        + "; ".join(f"{d['sd']:.2g} [{d['label']}]" for d in directions[:3])
    )
    if not [f for f in findings if f["kind"] not in ("symmetry broken",)]:
        lines.append("  every free parameter is identified by this data")
    for f in findings:
        if f["kind"] == "symmetry broken":
            continue
        lines.append(
            f"  {f['kind'].upper()}: {', '.join(f['params'])}: {f['evidence']}"
            + (f"; {f['why']}" if "why" in f else "")
            + f". Resolve: {f['resolve']}"
        )
    return "\n".join(lines)
