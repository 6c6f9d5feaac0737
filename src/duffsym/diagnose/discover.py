r"""When the catalogue has no answer, discover what is missing: a drifting parameter, or a term.

:func:`discover_term` first asks whether the base fit's residual grows (or shrinks) over the record;
if so, windowed refits name the parameter that changes and a :class:`~duffsym.effects.drift.ParameterDrift`
lets it follow time or the dissipated energy (:mod:`duffsym.diagnose.drift`). Otherwise (or when no
drift is needed) it regresses the free-run residual of the base fit (on the fitting part of the
record) on a systematic library of candidate output terms (:func:`term_library`, built with pysindy's
libraries — nothing typed in per term): a plain polynomial (degree 3) in the piston displacement,
velocity and acceleration ``d, d', d''`` and the model's states ``x, x'`` (and a measured command), plus
switching functions of each velocity — smooth signs ``tanh(v/ε)`` (ε = 3, 10, 30 % of its RMS), Stribeck
shapes ``exp(-(v/v_s)²)·tanh(v/ε)`` (v_s = 5, 10, 20 % of the RMS), ``|v|`` and ``v|v|`` — alone and
times a polynomial (degree 2) in the positions (pysindy's tensor product): ``d²·tanh(d'/ε)`` is friction
whose level grows toward the stroke ends. Selection is *stability selection* (:func:`stability`):
scikit-learn's orthogonal matching pursuit on the standardised library, fitted on a random half of the
whole input cycles and sized on the other half, 40 times; a family of terms (members that differ only
in ε or v_s) is kept when selected in at least 60 % of the resamples. Before selecting, the base model's own
linearised refit is projected out of the residual and the library (:func:`without_base`: the derivatives of
its free run with respect to its free parameters), so a term the base mimics by moving its own parameters
(a viscous ``d'`` against ``c1``) does not crowd out one it cannot. The stable set, its nested simpler
form (a Stribeck shape -> the plain sign) and its smaller subsets become :class:`DiscoveredEffect`\ s —
model extensions adding ``Σ c_i·term_i`` to the output, the coefficients as parameters — fitted through
the normal path (:func:`duffsym.identify.fit_with_effects`); the lowest BIC on the fitting part is kept
and judged by the same held-out evidence as a catalogued effect (ΔBIC, fall of the held-out error,
share of the excess error removed). The result is named in words and LaTeX in ``d, d'`` where the
physics acts there, with the catalogue effect it resembles.

Not done: terms inside the state equation (a coefficient of the fluid model that depends on a state or
a speed) other than the drift; such terms act on the output only here.

Delayed copies of the signals are not in the library: an output term must be a function of the
model's current states and inputs, and a short delay of ``d`` is ``d - τ d'`` to first order,
which the library spans.
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import sympy as sp

from duffsym.diagnose.options import required_improvement
from duffsym.effects.discovered import DiscoveredEffect, duplicates, resembles, term_latex, term_words
from duffsym.errors import DataError, ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.symbols import state_symbol
from duffsym.simulate import simulate_record
from duffsym.sindy import sparse

#: the fewest terms whose validation error is within this factor of the best is chosen
PARSIMONY = 1.05
MAX_TERMS = 3
#: stability selection: resamples of half the cycles, and the inclusion probability a family must reach
RESAMPLES = 40
INCLUSION = 0.6
#: when no stable term set is needed, the families included in at least this share of the resamples (below
#: ``INCLUSION``) are fitted one at a time, at most ``TENTATIVE_TRIES`` of them, and judged by the same held-out
#: evidence (measured on independent records whose misfit sits at the noise level but is not white: the
#: turbulent-orifice term d'|d'| reached 0.47)
TENTATIVE = 0.4
TENTATIVE_TRIES = 2
#: ... and only when the residual is within this factor of the noise, where the selection has little to go on (far
#: above the noise a real term is stable; on the real Dyke record, 2.9x the noise, the two tentative terms and their
#: measured forms took 49 s of a 233 s ladder and none was needed)
TENTATIVE_EXCESS = 1.5
#: term sets fitted by discover_term (measured on the four worst UTFSM 0 A tests: with 1, one of four
#: improves by 23 % of its excess error; with 3, 25 mm 0.5 Hz falls 0.239 -> 0.118 and 0.1 Hz 0.140 -> 0.117)
TRIES = 3
#: ε of the smooth signs and absolute values, as fractions of the signal's RMS
EPS_FRACTIONS = (0.03, 0.1, 0.3)


def signals(record, model: SymbolicModel, states: np.ndarray | None) -> dict[str, np.ndarray]:
    """The library's signals: the record's ``d, d', d''`` and the model's ``x, x'`` (from ``states``)."""
    cols = {
        "d": np.asarray(record.d, float),
        "d_dot": np.asarray(record.velocity(), float),
        "d_ddot": np.asarray(record.acceleration(), float),
    }
    if states is not None:
        for sym, key in ((model.position, "x"), (model.velocity, "x_dot")):
            if sym is not None and sym in model.states:
                cols[key] = np.asarray(states[:, model.states.index(sym)], float)
    return cols


#: the polynomial factor's degree in the positions (d, x, and any extra measured channel)
POSITION_DEGREE = 2
#: degree of the plain polynomial in every signal (d, d', d'', x, x')
PLAIN_DEGREE = 3
#: Stribeck speeds v_s, as fractions of the velocity's RMS
STRIBECK_FRACTIONS = (0.05, 0.1, 0.2)
POSITIONS = ("d", "x", "command")
VELOCITIES = ("d_dot", "x_dot")


def switches(rms: float) -> list[tuple[str, object]]:
    """The switching functions of one velocity ``v`` (RMS ``rms``), as (printable template, function):
    smooth signs ``tanh(v/ε)`` (ε = 3, 10, 30 % of the RMS), Stribeck shapes
    ``exp(-(v/v_s)**2)·tanh(v/ε)`` (v_s = 5, 10, 20 % of the RMS, ε = 3 %), the smooth ``|v|`` and ``v|v|``
    (``v·tanh(v/ε)``, ``v**2·tanh(v/ε)``, ε = 10 %). The template has ``{v}`` for the signal's name
    (:func:`duffsym.sindy.sparse.switches` with this module's grids)."""
    return sparse.switches(rms, EPS_FRACTIONS, STRIBECK_FRACTIONS)


def term_library(cols: Mapping[str, np.ndarray]):
    """The candidate library as a pysindy :class:`~pysindy.feature_library.GeneralizedLibrary` over the
    signals in ``cols`` and the signal names it takes, in order: a plain polynomial (degree
    ``PLAIN_DEGREE``) in every signal, plus each velocity's switching functions (:func:`switches`) alone
    and times a polynomial (degree ``POSITION_DEGREE``) in the positions — the tensor product
    ``positions ⊗ switches(d') ⊗ ...``: ``d²·tanh(d'/ε)`` (friction growing toward the stroke ends),
    ``exp(-(d'/v_s)²)·tanh(d'/ε)`` (a Stribeck peak), ``d·|x'|``, ... Nothing is typed in per term
    (the shared :func:`duffsym.sindy.sparse.switching_library`)."""
    return sparse.switching_library(
        cols,
        positions=POSITIONS,
        velocities=VELOCITIES,
        plain_degree=PLAIN_DEGREE,
        position_degree=POSITION_DEGREE,
        eps_fractions=EPS_FRACTIONS,
        stribeck_fractions=STRIBECK_FRACTIONS,
    )


def library(cols: Mapping[str, np.ndarray]) -> list[sp.Expr]:
    """The candidate terms (SymPy, in the signals' symbols, duplicates dropped) of :func:`term_library`."""
    return library_matrix(cols)[0]


def library_matrix(cols: Mapping[str, np.ndarray]) -> tuple[list[sp.Expr], np.ndarray]:
    """(terms, library matrix ``(n_times, n_terms)``): pysindy's evaluation of :func:`term_library`, its
    feature names read back as SymPy expressions; a duplicate or constant-free repeat is dropped
    (:func:`duffsym.sindy.sparse.named_matrix`)."""
    lib, names = term_library(cols)
    return sparse.named_matrix(lib, cols, names, {k: state_symbol(k) for k in names})


# ---------------------------------------------------------------------------------------------- selection
def select_terms(Theta: np.ndarray, r: np.ndarray, n_train: int, max_terms: int = MAX_TERMS):
    """Sparse support of ``r ≈ Theta c``: OMP on the standardised library for 1..``max_terms`` terms,
    fitted on the first ``n_train`` rows and scored on the rest; the fewest terms within
    ``PARSIMONY`` of the best validation MSE. Returns (column indices, per-size validation MSE, the
    other sizes' supports, best validation first). The shared path:
    :func:`duffsym.sindy.sparse.validated_support`."""
    return sparse.validated_support(Theta, r, n_train, max_terms, PARSIMONY)


# ---------------------------------------------------------------------------------------------- discovery
@dataclass(frozen=True)
class Discovery:
    """A discovered output term, fitted through the normal path, with the diagnosis's held-out evidence.

    ``supported``/``needed`` follow the rules of :func:`~duffsym.diagnose.diagnose` (ΔBIC below the
    threshold and a held-out fall of at least ``min_improvement``; needed when it also removes at
    least ``min_explained`` of the excess held-out error and the base's residual is worth a search:
    :attr:`~duffsym.diagnose.residuals.ResidualAnalysis.worth_a_search`).
    """

    found: bool
    effect: str
    term: str  # SymPy string with the fitted coefficients
    latex: str
    words: str
    resembles: list
    nrmse_before: float  # held-out NRMSE of the base model
    nrmse_after: float
    delta_bic: float
    improvement: float
    explained: float
    supported: bool
    needed: bool
    params: dict
    stderr: dict
    all_params: dict
    success: bool
    message: str
    selection: dict
    seconds: float
    model: object = None
    y_ext: np.ndarray | None = None

    def to_dict(self) -> dict:
        keys = (
            "found",
            "effect",
            "term",
            "latex",
            "words",
            "resembles",
            "nrmse_before",
            "nrmse_after",
            "delta_bic",
            "improvement",
            "explained",
            "supported",
            "needed",
            "params",
            "stderr",
            "success",
            "message",
            "selection",
            "seconds",
        )
        return {k: getattr(self, k) for k in keys}

    def summary(self) -> str:
        if not self.found:
            return f"discovery: no term found ({self.message})"
        like = f"; resembles {', '.join(self.resembles)}" if self.resembles else ""
        verdict = "needed" if self.needed else ("supported, partial" if self.supported else "not supported")
        return (
            f"discovery: {self.effect}{like}\n  held-out NRMSE {self.nrmse_before:.4g} -> {self.nrmse_after:.4g}, "
            f"dBIC {self.delta_bic:.1f}, {100 * self.explained:.0f} % of the excess error explained: {verdict}"
        )


def _nothing(message: str, before: float, selection: dict, seconds: float) -> Discovery:
    nan = math.nan
    return Discovery(
        found=False,
        effect="",
        term="",
        latex="",
        words="",
        resembles=[],
        nrmse_before=before,
        nrmse_after=nan,
        delta_bic=nan,
        improvement=nan,
        explained=nan,
        supported=False,
        needed=False,
        params={},
        stderr={},
        all_params={},
        success=False,
        message=message,
        selection=selection,
        seconds=seconds,
    )


def _states(model, params, record, x0) -> np.ndarray | None:
    tr = simulate_record(model, params, record, x0=x0, on_failure="return")
    return np.asarray(tr.x, float) if tr.success and np.all(np.isfinite(tr.x)) else None


def blocks(record, k: int) -> list[np.ndarray]:
    """Row indices of the resampling blocks of the fitting part (its first ``k`` rows): whole input cycles
    (between rising crossings of ``d``) when there are at least 6, else 8 equal stretches."""
    from duffsym.diagnose.residuals import rising_crossings

    cut = rising_crossings(np.asarray(record.d)[:k])
    cut = cut[(cut > 0) & (cut < k)]
    edges = np.concatenate([[0], cut, [k]]) if cut.size >= 5 else np.linspace(0, k, 9).astype(int)
    return [np.arange(a, b) for a, b in zip(edges[:-1], edges[1:]) if b > a]


def family(term: sp.Expr) -> str:
    """The term with its grid constants (ε, v_s) blanked: the members of one family differ only in them."""
    return re.sub(r"\d+\.\d+(e[+-]?\d+)?", "#", sp.sstr(term))


def stability(
    Theta: np.ndarray,
    r: np.ndarray,
    parts: list[np.ndarray],
    terms: list,
    *,
    resamples: int = RESAMPLES,
    max_terms: int = MAX_TERMS,
    seed: int = 0,
    groups: list[str] | None = None,
) -> dict:
    """Stability selection over resampled cycles: ``resamples`` times, half the blocks (``parts``) train an
    OMP path (:func:`select_terms`, 1..``max_terms`` terms) and the other half choose its size; returns
    the inclusion probability of every family of terms (:func:`family`, or ``groups``; any member selected)
    and of every term, and each family's most selected member (:func:`duffsym.sindy.sparse.stability_selection`)."""
    return sparse.stability_selection(
        Theta,
        r,
        parts,
        groups or [family(t) for t in terms],
        resamples=resamples,
        max_terms=max_terms,
        parsimony=PARSIMONY,
        seed=seed,
    )


def _simpler(terms: list, i: int) -> int:
    """The index of the nested simpler form of ``terms[i]``: a Stribeck shape ``exp(-(v/v_s)²)·tanh(v/ε)`` ->
    the plain smooth sign ``tanh(v/ε)`` (its v_s -> ∞ limit, same polynomial factor), if in the library; else ``i``.
    A residual of the base fit shows a Coulomb step partly absorbed by the damping, which looks like a
    Stribeck peak; the full refit tells them apart (the simpler form is kept when its BIC is as good)."""
    t = terms[i]
    plain = t.replace(lambda e: isinstance(e, sp.exp), lambda e: sp.Integer(1))
    return terms.index(plain) if plain != t and plain in terms else i


#: a library column whose part outside the base model's sensitivities is below this fraction of its norm is a
#: term the base absorbs by refitting its own parameters (left out of the selection)
ABSORBED = 1e-3


def base_sensitivities(model, base_fit, record, k: int, x0=None) -> np.ndarray | None:
    """``(k, n_free)``: the derivatives of the base model's free run (first ``k`` samples, from the fitted initial
    state, or ``x0``) with respect to its free parameters, by central differences (step 1e-4 of the value or of
    the parameter's scale). None when a free run fails."""
    params = dict(base_fit.params)
    x0 = base_fit.x0[0] if x0 is None else x0
    spec = {p.name: p for p in model.params}
    cols = []
    for name in base_fit.free:
        if name not in spec:
            continue
        h = 1e-4 * max(abs(float(params[name])), float(spec[name].scale or 0.0), 1e-8)
        runs = []
        for sign in (1.0, -1.0):
            tr = simulate_record(model, {**params, name: params[name] + sign * h}, record, x0=x0, on_failure="return")
            if not (tr.success and np.all(np.isfinite(tr.y))):
                return None
            runs.append(np.asarray(tr.y, float)[:k])
        cols.append((runs[0] - runs[1]) / (2 * h))
    return np.column_stack(cols) if cols else None


def without_base(J: np.ndarray | None, Theta: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, set[int]]:
    """The library and the residual with the span of the base model's sensitivities ``J`` projected out
    (Frisch-Waugh-Lovell: a regression on the projected data is the regression with the base's own linearised
    refit always included), and the columns the base absorbs (projected norm below ``ABSORBED`` of the
    original). A term the base can mimic by moving its parameters (``d'`` against ``c1``) is then not proposed;
    one it cannot (``d²·tanh(d'/ε)``) stands out."""
    if J is None:
        return Theta, r, set()
    U, s, _ = np.linalg.svd(J, full_matrices=False)
    Q = U[:, s > s[0] * 1e-10] if s.size and s[0] > 0 else U[:, :0]
    Tp = Theta - Q @ (Q.T @ Theta)
    rp = r - Q @ (Q.T @ r)
    norm = np.linalg.norm(Theta, axis=0)
    absorbed = {int(j) for j in np.flatnonzero(np.linalg.norm(Tp, axis=0) <= ABSORBED * np.where(norm > 0, norm, 1))}
    return Tp, rp, absorbed


@dataclass(frozen=True)
class StableTerms:
    """The stability selection of a residual on a term library, after the base's linearised refit is projected out
    (:func:`select_stable`): the terms left, the projected library and residual, the selection's counts and the
    stable families, most stable first."""

    terms: list
    Theta: np.ndarray
    r: np.ndarray
    stab: dict
    stable: list
    absorbed: int
    aliases: dict = dataclasses.field(default_factory=dict)  # group -> the other forms of its column here

    def inclusion(self, top: int = 8) -> dict:
        """The ``top`` families' inclusion probabilities, each named by its most selected member in words."""
        ranked = sorted(self.stab["family"].items(), key=lambda fp: -fp[1])[:top]
        return {term_words(self.terms[self.stab["best"][f]]).lstrip("+"): round(p, 3) for f, p in ranked}

    def supports(self) -> list[list[int]]:
        """The stable set, then it without its least stable family, and so on (term indices)."""
        return [[self.stab["best"][f] for f in self.stable[:n]] for n in range(len(self.stable), 0, -1)]

    def tentative(self, lo: float = TENTATIVE, top: int = TENTATIVE_TRIES) -> list[list[int]]:
        """The ``top`` families below the stability threshold but included in at least ``lo`` of the resamples,
        most included first, each alone (its most selected member)."""
        fam = self.stab["family"]
        ranked = sorted((f for f, p in fam.items() if lo <= p < INCLUSION), key=lambda f: -fam[f])
        return [[self.stab["best"][f]] for f in ranked[:top]]

    def effects(self, supports, index: int) -> list[DiscoveredEffect]:
        """Each support as a :class:`DiscoveredEffect`, its coefficients the terms' least-squares share of the
        projected residual (their share beside a refit base)."""
        out = []
        for sup in supports:
            coefs, *_ = np.linalg.lstsq(self.Theta[:, sup], self.r, rcond=None)
            out.append(DiscoveredEffect(tuple(self.terms[i] for i in sup), tuple(float(c) for c in coefs), index))
        return out


def select_stable(terms: list, Theta: np.ndarray, r: np.ndarray, J: np.ndarray | None, parts) -> StableTerms:
    """Project the base's sensitivities ``J`` out (:func:`without_base`), leave out the terms the base absorbs, and
    run the stability selection over the row blocks ``parts`` (:func:`stability`); families included in at least
    ``INCLUSION`` of the resamples are stable."""
    Tp, rp, absorbed = without_base(J, Theta, r)
    keep = [j for j in range(len(terms)) if j not in absorbed]
    terms, Tp = [terms[j] for j in keep], Tp[:, keep]
    groups = alias_groups(terms, Tp)
    stab = stability(Tp, rp, parts, terms, groups=groups)
    aliases = {}
    for g in stab["best"]:
        members = [j for j in range(len(terms)) if groups[j] == g]
        forms = {family(terms[j]): j for j in sorted(members, key=lambda j: -stab["term"][j])}
        if len(forms) > 1:  # one column in several forms: the simplest form stands for it
            first = min(
                forms.values(), key=lambda j: (derivative_order(terms[j]), sp.count_ops(terms[j]), -stab["term"][j])
            )
            stab["best"][g] = first
            aliases[g] = [terms[j] for j in forms.values() if j != first]
    stable = sorted((f for f, p in stab["family"].items() if p >= INCLUSION), key=lambda f: -stab["family"][f])
    return StableTerms(terms, Tp, rp, stab, stable, len(absorbed), aliases)


#: library columns whose parts outside the base's sensitivities have a |cosine| above this are one column on
#: the record: on a sine d² = A² - d'²/ω² (an offset in the model absorbs A²) and d'' = -ω²·d
ALIAS = 0.999


def alias_groups(terms: list, Tp: np.ndarray) -> list[str]:
    """The stability selection's group of each term: its :func:`family`, merged with the families of the terms
    whose projected column is the same up to scale (|cosine| >= ``ALIAS``), so that a selection split between
    two forms of one column counts once."""
    labels = [family(t) for t in terms]
    norm = np.linalg.norm(Tp, axis=0)
    U = Tp / np.where(norm > 0, norm, 1.0)
    parent = {f: f for f in labels}

    def root(f: str) -> str:
        while parent[f] != f:
            f = parent[f]
        return f

    for i, j in zip(*np.nonzero(np.triu(np.abs(U.T @ U) >= ALIAS, 1))):
        a, b = root(labels[i]), root(labels[j])
        if a != b:
            parent[max(a, b)] = min(a, b)
    members: dict[str, set[str]] = {}
    for f in labels:
        members.setdefault(root(f), set()).add(f)
    return [" ≡ ".join(sorted(members[root(f)])) for f in labels]


#: the derivative order each signal of the library carries
_ORDER = {"d": 0, "x": 0, "d_dot": 1, "x_dot": 1, "d_ddot": 2}


def derivative_order(term: sp.Expr) -> int:
    """The derivatives ``term`` contains, counted with their powers (d'² -> 2, d·d'' -> 2, d² -> 0)."""
    total = 0
    for factor in sp.Mul.make_args(term):
        base, power = factor.as_base_exp()
        inside = max((_ORDER.get(str(s), 0) for s in base.free_symbols), default=0)
        total += inside * (int(power) if power.is_Integer else 1)
    return total


def propose(record, model, dg, tries: int = TRIES) -> tuple[list[DiscoveredEffect], dict, list[DiscoveredEffect]]:
    """The term sets for ``dg``'s base fit (fitting part only), as effects: the families stable over
    resampled cycles (inclusion probability >= ``INCLUSION``, :func:`stability`), each by its most
    selected member, then that set without its least stable family; the selection's numbers; and the
    tentative terms (:meth:`StableTerms.tentative`), each alone, to fit when no stable set is needed."""
    k = dg.split["n_fit"]
    cols = signals(record, model, _states(model, dg.base_fit.params, record, dg.base_fit.x0[0]))
    terms, Theta = library_matrix(cols)
    ok = [j for j in range(len(terms)) if np.ptp(Theta[:k, j]) + abs(Theta[0, j]) > 0]
    same = [j for j in ok if duplicates(terms[j], model.effects)]  # terms the added effects already have
    ok = [j for j in ok if j not in same]
    terms, Theta = [terms[j] for j in ok], Theta[:, ok]
    r = dg.measured(record) - np.asarray(dg.y_base, float)
    J = base_sensitivities(model, dg.base_fit, record, k)
    if J is not None:
        J = dg.judged(J)
    sel = select_stable(terms, dg.judged(Theta)[:k], r[:k], J, blocks(record, k))
    selection = {
        "library": len(sel.terms),
        "selector": "stability selection (sklearn OrthogonalMatchingPursuit "
        f"on {RESAMPLES} resamples of half the cycles, inclusion >= {INCLUSION})",
        "library_builder": "pysindy GeneralizedLibrary (polynomials x switching functions)",
        "inclusion": sel.inclusion(),
        "aliases": {
            sp.sstr(sel.terms[sel.stab["best"][g]]): [term_words(t).lstrip("+") for t in others]
            for g, others in sel.aliases.items()
        },
        "n_terms": len(sel.stable),
        "duplicates_left_out": len(same),
        "base_refit": "none (the base free run's sensitivities could not be computed)"
        if J is None
        else f"projected out: the base model's {J.shape[1]} free parameters (linearised refit); "
        f"{sel.absorbed} terms it absorbs left out",
    }
    index = 1 + sum(e.startswith("discovered:") for e in model.effects)
    tentative = sel.effects(sel.tentative(), index)
    if not sel.stable:
        return [], selection, tentative
    supports = sel.supports()
    simpler = [_simpler(sel.terms, i) for i in supports[0]]
    if simpler != supports[0] and len(set(simpler)) == len(simpler):
        supports.insert(1, simpler)
    return sel.effects(supports[: max(tries, 1)], index), selection, tentative


def discover_term(
    record,
    model,
    dg,
    *,
    fixed: Mapping[str, float] | None = None,
    mask=None,
    bic_threshold: float | None = None,
    min_improvement: float | None = None,
    min_explained: float | None = None,
    max_iter: int = 300,
    tries: int = TRIES,
    progress=None,
    deadline: float | None = None,
) -> Discovery:
    """Discover what ``model`` lacks on ``record`` outside the catalogue, from the diagnosis ``dg`` of it.

    First, when the base fit's residual grows or shrinks over the record, a drifting parameter
    (:func:`duffsym.diagnose.drift.windowed_refits` and :class:`~duffsym.effects.drift.ParameterDrift`);
    if none is needed, an output term (:func:`propose`). Each is selected on the fitting part
    (``dg.split``) only, fitted by :func:`duffsym.identify.fit_with_effects` on the fitting part, and
    judged on the held-out tail by the same rules as a catalogued candidate (defaults: those of
    :mod:`duffsym.diagnose.search`). ``tries``: how many term sets to fit; the one with the lowest BIC on
    the fitting part is kept (the held-out tail is never used to choose). ``deadline`` (a ``time.monotonic()``
    instant): every fit is limited to the time left and fitted on at most ``BUDGET_SAMPLES`` samples, as a
    diagnosis under a budget; a fit left when it has passed is not made. Inside ``with on_engine(engine):`` the
    term sets are fitted at the same time on the engine's workers (the same fits).
    """
    token = _DEADLINE.set(deadline)
    try:
        return _discover(record, model, dg, fixed, mask, bic_threshold, min_improvement, min_explained, max_iter,
                         tries, progress)  # fmt: skip
    finally:
        _DEADLINE.reset(token)


@contextlib.contextmanager
def on_engine(engine):
    """Within it, :func:`discover_term` fits its term sets at the same time on ``engine``'s workers (an
    :class:`~duffsym.engine.Engine`; None or a serial one: one after the other, in this process)."""
    token = _ENGINE.set(engine)
    try:
        yield
    finally:
        _ENGINE.reset(token)


def _discover(
    record, model, dg, fixed, mask, bic_threshold, min_improvement, min_explained, max_iter, tries, progress
) -> Discovery:
    """:func:`discover_term`'s work (its deadline set)."""
    import time

    from duffsym.diagnose import search as S
    from duffsym.identify.result import nrmse as _nrmse

    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    k = dg.split["n_fit"]
    held = slice(k, None)
    before = _nrmse(dg.measured(record)[held], dg.y_base[held])
    rules = dict(
        bic_threshold=S.BIC_THRESHOLD if bic_threshold is None else bic_threshold,
        min_improvement=S.MIN_IMPROVEMENT if min_improvement is None else min_improvement,
        min_explained=S.MIN_EXPLAINED if min_explained is None else min_explained,
    )
    drifted = discover_drift(
        record, model, dg, fixed=fixed, mask=mask, max_iter=max_iter, rules=rules, progress=progress
    )
    if drifted is not None and drifted.needed:
        return dataclasses.replace(drifted, seconds=time.perf_counter() - t0)
    say("  discovering a term outside the catalogue")
    try:
        effects, selection, tentative = propose(record, model, dg, tries)
    except (ModelError, DataError, ValueError, np.linalg.LinAlgError) as exc:
        return _nothing(f"the term library could not be built: {exc}", before, {}, time.perf_counter() - t0)
    tried = ""
    if drifted is not None:
        selection["drift"] = drifted.to_dict()
        tried = (
            drifted.message
            if not drifted.found
            else f"drift: {drifted.effect} not needed "
            f"(held-out {drifted.nrmse_before:.3g} -> {drifted.nrmse_after:.3g})"
        )
        tried += "; "
    args = (record, model, dg, fixed, mask, max_iter, say)
    found = _fit_sets(effects, *args, rules, selection) if effects else None
    if (found is None or not found.needed) and tentative and dg.residuals.excess < TENTATIVE_EXCESS:
        say(f"  no stable term set is needed: fitting {len(tentative)} term(s) below the stability threshold")
        other = _fit_sets(tentative, *args, rules, selection, tentative=True)
        if other is not None and other.needed:
            found = other
    if found is not None:
        return dataclasses.replace(found, seconds=time.perf_counter() - t0)
    if not effects:
        best = max(selection.get("inclusion", {"": 0}).items(), key=lambda kv: kv[1], default=("", 0))
        what = f"highest inclusion {best[1]:.2f}, {best[0]}" if best[0] else "every resample chose no term"
        return _nothing(
            f"{tried}no term is stable over resampled cycles ({what})", before, selection, time.perf_counter() - t0
        )
    from duffsym.diagnose.search import time_left

    why = (
        "failed or its free run diverged" if time_left(_DEADLINE.get()) >= 2.0 else "not made: the time budget ran out"
    )
    return _nothing(f"the fit of {effects[0].name} {why}", before, selection, time.perf_counter() - t0)


def _fit_sets(effects, record, model, dg, fixed, mask, max_iter, say, rules, selection, tentative=False):
    """The best of the term sets ``effects`` fitted on the fitting part (lowest BIC; the simpler form without a
    Stribeck shape when its BIC is within 2; then pruned of terms within 2 standard errors of 0), as a
    :class:`Discovery` with the held-out evidence; None when no fit succeeded. ``tentative``: the sets are
    terms below the stability threshold, and the words say so."""
    fits = [f for f in _fit_each(effects, record, model, dg, fixed, mask, max_iter, say) if f]
    if not fits:
        return None
    fitted = min(fits, key=lambda f: f[3])
    simple = [f for f in fits if not any(t.has(sp.exp) for t in f[0].terms)]
    if simple and fitted[0].terms != simple[0][0].terms and min(f[3] for f in simple) <= fitted[3] + 2.0:
        fitted = min(simple, key=lambda f: f[3])  # as good without a Stribeck shape: the simpler form
    measured = measured_form(fitted[0], record, dg)
    if measured is not None:
        again = _fit_effect(measured, record, model, dg, fixed, mask, max_iter, say)
        if again is not None and again[3] < fitted[3] + MEASURED_PREFERENCE:
            fitted = again
    pruned = _prune(fitted, record, model, dg, fixed, mask, max_iter, say)
    if pruned is not None and pruned[3] <= fitted[3] + 2.0:  # fewer terms, BIC no worse (within 2)
        fitted = pruned
    final, fr, y_ext, bic_ext = fitted
    expr = final.expression(final.coefs)
    below = ""
    if tentative:
        share = selection.get("inclusion", {}).get(term_words(final.terms[0]).lstrip("+"))
        of = f" (included in {share:.0%} of the resamples, against {INCLUSION:.0%})" if share is not None else ""
        below = f"; a term below the stability threshold{of}, fitted because no stable term set was needed"
    return _found(
        final,
        fr,
        y_ext,
        bic_ext,
        record,
        model,
        dg,
        rules,
        selection,
        0.0,
        term=sp.sstr(expr, full_prec=False),
        latex=term_latex(expr),
        words=f"{term_words(expr)} added to the output"
        + "".join(_alias_clause(selection, t) for t in final.terms)
        + below,
        resembles=[r for r in map(resembles, final.terms) if r],
    )


#: a term written in the measured piston motion is kept unless its form in the model's states has a BIC lower by at
#: least this much ("strong" on Kass & Raftery's scale): the measured form is the physics' own and carries over to
#: another model; measured on the independent stroke-friction record, seed 6: d·x·tanh(d'/ε) against d²·tanh(d'/ε),
#: ΔBIC 3.1 for the state form, held-out 0.01136 against 0.01111; a gas spring's d²·x against d³: ΔBIC 387)
MEASURED_PREFERENCE = 6.0
#: the model's states and the measured signals that stand for them in a term's polynomial factor
_MEASURED = {state_symbol("x"): state_symbol("d"), state_symbol("x_dot"): state_symbol("d_dot")}


def measured_form(effect: DiscoveredEffect, record, dg) -> DiscoveredEffect | None:
    """``effect`` written in the measured piston motion: the model's states ``x, x'`` in the terms' polynomial
    factors replaced by ``d, d'`` (a gas spring found as ``d²·x`` is ``d³`` in the physics' own variables), the
    coefficients the least-squares share of the base's residual on the fitting part; None when no term has a
    state in its polynomial factor, one has it inside a switching function (its ε is on the state's scale), or a
    term has a measured command in it."""
    if not any(t.free_symbols & set(_MEASURED) for t in effect.terms):
        return None
    if any(f.free_symbols & set(_MEASURED) for t in effect.terms for f in t.atoms(sp.tanh, sp.exp)):
        return None
    terms = list(dict.fromkeys(t.xreplace(_MEASURED) for t in effect.terms))
    cols = {"d": np.asarray(record.d, float), "d_dot": np.asarray(record.velocity(), float)}
    cols["d_ddot"] = np.asarray(record.acceleration(), float)
    names = sorted(cols)
    if not set().union(*(t.free_symbols for t in terms)) <= {state_symbol(n) for n in names}:
        return None  # a measured command in the term: its form in the motion is not defined here
    k = dg.split["n_fit"]
    fns = [sp.lambdify([state_symbol(n) for n in names], t, "numpy") for t in terms]
    theta = np.column_stack([np.broadcast_to(f(*(cols[n] for n in names)), (cols["d"].size,)) for f in fns])
    theta = dg.judged(theta)[:k]
    r = dg.measured(record)[:k] - np.asarray(dg.y_base, float)[:k]
    coefs, *_ = np.linalg.lstsq(theta, r, rcond=None)
    return DiscoveredEffect(tuple(terms), tuple(float(c) for c in coefs), effect.index)


def _alias_clause(selection: dict, term: sp.Expr) -> str:
    """ "" or, when ``term`` stands for a column that other forms share on this record (a sine: d², d'² and
    d·d''), a clause that names them."""
    others = selection.get("aliases", {}).get(sp.sstr(term), [])
    if not others:
        return ""
    return (
        f"; on this record {term_words(term).lstrip('+')} is the same column as {', '.join(others)}: the input "
        "cannot tell them apart (the form with the fewest derivatives is named; a record with other amplitudes "
        "or frequencies can)"
    )


def _found(effect, fr, y_ext, bic_ext, record, model, dg, rules, selection, seconds, **named) -> Discovery:
    """The Discovery of a fitted ``effect`` (on ``model``), with the diagnosis's held-out evidence."""
    from duffsym.identify.result import nrmse as _nrmse

    k = dg.split["n_fit"]
    y = dg.measured(record)
    own = [p.name for p in effect.parameters()]
    return Discovery(
        found=True,
        effect=effect.name,
        nrmse_before=_nrmse(y[k:], dg.y_base[k:]),
        nrmse_after=_nrmse(y[k:], y_ext[k:]),
        params={n: float(fr.params[n]) for n in own},
        stderr={n: float(fr.stderr.get(n, math.nan)) for n in own},
        all_params=dict(fr.params),
        success=True,
        message=fr.message,
        selection=selection,
        seconds=seconds,
        model=effect.apply(model),
        y_ext=y_ext,
        **named,
        **_evidence(y, dg, y_ext, bic_ext, rules),
    )


#: when no windowed parameter changes monotonically, this many parameters (ranked by :func:`_drift_ranking`) are
#: fitted drifting
FALLBACK_DRIFTS = 2


def _drift_ranking(names: list[str], record, model, dg) -> list[str]:
    """``names`` ranked by how much of the base's residual on the fitting part the linearised drift of each
    (its sensitivity times the dissipated energy) explains once the base's own linearised refit is projected
    out (:func:`without_base`): the first-order form of ``p·(1 - a·E/E_ref)``. Unranked if a free run fails."""
    k = dg.split["n_fit"]
    J = base_sensitivities(model, dg.base_fit, record, k)
    spec = {p.name for p in model.params}
    free = [n for n in dg.base_fit.free if n in spec]
    names = [n for n in names if n in free]
    if J is None or not names:
        return names
    u = np.asarray(record.drift_signal("energy"), float)[:k]
    cols = np.column_stack([J[:, free.index(n)] * u for n in names])
    Tp, rp, _ = without_base(dg.judged(J), dg.judged(cols), dg.measured(record)[:k] - dg.y_base[:k])
    norm2 = np.sum(Tp**2, axis=0)
    gain = np.where(norm2 > 0, (Tp.T @ rp) ** 2 / np.where(norm2 > 0, norm2, 1.0), 0.0)
    return [names[i] for i in np.argsort(-gain, kind="stable")]


def discover_drift(
    record, model, dg, *, fixed=None, mask=None, max_iter: int = 300, rules: dict, progress=None
) -> Discovery | None:
    """A drifting parameter, when the base fit's residual grows or shrinks over the record
    (:mod:`duffsym.diagnose.drift`): windowed refits name the parameters that change; each follows time or
    the dissipated energy in turn; the lowest BIC on the fitting part is judged. None when nothing trends
    or nothing changes."""
    from duffsym.diagnose import drift as D

    if not D.trending(dg) or any(e.startswith("drift:") for e in model.effects):  # one drifting parameter at most
        return None
    say = progress or (lambda msg: None)
    say("  the error grows over the record: windowed refits")
    before = float(dg.nrmse_heldout)
    try:
        windows = D.windowed_refits(dg.work(record), model, dg, fixed)
    except (ModelError, DataError) as exc:
        return _nothing(f"drift: the windowed refits failed ({exc})", before, {}, 0.0)
    selection: dict[str, object] = {"windows": windows.to_dict()}
    names = windows.drifting()[: D.MAX_PARAMETERS]
    if names:  # and the first by the linearised drift, when the windows did not name it (they trade parameters off)
        first = _drift_ranking(D.any_change(windows), record, model, dg)[:1]
        names += [n for n in first if n not in names]
        selection["ranked_by_linearised_drift"] = first
    else:  # the windows trade parameters off: the linearised drift of each parameter ranks them
        names = _drift_ranking(D.any_change(windows), record, model, dg)[:FALLBACK_DRIFTS]
        selection["no_monotone_change"] = ", ".join(f"{n} {100 * c:+.0f} %" for n, c in windows.change.items())
        selection["ranked_by_linearised_drift"] = names
        say("  no parameter changes monotonically over the windows: trying " + ", ".join(names))
    if not names:
        return _nothing(f"drift: no parameter changes over {len(windows.bounds)} windows", before, selection, 0.0)
    cands = D.candidates(record, dg, windows, "energy", names)
    fits = _drift_fits(cands, windows, record, model, dg, fixed, mask, max_iter, say)
    if fits:  # the best parameter following time instead of the dissipated energy
        best = min(fits, key=lambda f: f[3])[0].parameter
        fits += _drift_fits(
            D.candidates(record, dg, windows, "time", [best]), windows, record, model, dg, fixed, mask, max_iter, say
        )
    if not fits:
        return _nothing("drift: the fits of " + ", ".join(names) + " drifting failed", before, selection, 0.0)
    eff, fr, y_ext, bic = min(fits, key=lambda f: f[3])
    selection["tried"] = {f[0].name: round(f[3], 1) for f in fits}
    a = float(fr.params["drift_a"])
    sentence = eff.sentence(a)
    return _found(
        eff,
        fr,
        y_ext,
        bic,
        record,
        model,
        dg,
        rules,
        selection,
        0.0,
        term=eff.form,
        latex=eff.latex(a),
        words=sentence,
        resembles=[f"no catalogued effect: {eff.physics} (e.g. a damper whose fluid warms and thins)"],
    )


#: the deadline of the discovery running in this context (:func:`discover_term`); None: no limit
_DEADLINE: contextvars.ContextVar[float | None] = contextvars.ContextVar("discover_deadline", default=None)
#: the engine of the :func:`discover_term` call in progress (None: its fits run in this process)
_ENGINE: contextvars.ContextVar[Any] = contextvars.ContextVar("discover_engine", default=None)


def _fit_each(effects, record, model, dg, fixed, mask, max_iter, say) -> list:
    """:func:`_fit_effect` of every term set, in order: here one after the other, or at the same time on the
    engine of :func:`discover_term` (on the 6 s Dyke slice two sets took 18 and 11 s one after the other)."""
    engine = _ENGINE.get()
    if engine is None or engine.kind == "serial" or len(effects) < 2:
        return [_fit_effect(e, record, model, dg, fixed, mask, max_iter, say) for e in effects]
    from duffsym.diagnose.search import time_left

    say(f"  fitting {len(effects)} term sets on {engine!r}: " + "; ".join(e.name for e in effects))
    left = time_left(_DEADLINE.get())
    seconds = None if math.isinf(left) else left  # a clock of this process: each worker starts its own
    return engine.map(_fit_effect_task, [(e, record, model, dg, fixed, mask, max_iter, seconds) for e in effects])


def _fit_effect_task(item):
    """:func:`_fit_effect` in a worker process: ``item`` is its arguments and the seconds left (None: no limit)."""
    import time

    *args, seconds = item
    token = _DEADLINE.set(None if seconds is None else time.monotonic() + seconds)
    try:
        return _fit_effect(*args, lambda msg: None)
    finally:
        _DEADLINE.reset(token)


def _fit_effect(effect, record, model, dg, fixed, mask, max_iter, say):
    """``effect`` fitted on the fitting part by :func:`duffsym.identify.fit_with_effects`:
    (effect rebuilt with the fitted coefficients, fit, free run over the record, BIC on the fitting part);
    None on failure."""
    got = _fit_any(effect, record, model, dg, fixed, mask, max_iter, say)
    if got is None:
        return None
    coefs = tuple(float(got[0].params[p.name]) for p in effect.parameters())
    return (DiscoveredEffect(effect.terms, coefs, effect.index), *got)


def _fit_any(effect, record, model, dg, fixed, mask, max_iter, say, start: Mapping[str, float] | None = None):
    """(fit, free run over the record as judged, BIC on the fitting part) of ``model`` + ``effect`` on the
    fitting part, from the base fit (updated by ``start``); None on failure. Fitted to the record as the
    diagnosis fitted its models (a force smoothed by a moving average: restored, :meth:`Diagnosis.work`)."""
    from duffsym.diagnose import search as S
    from duffsym.identify import Problem, fit_with_effects

    deadline = _DEADLINE.get()
    left = S.time_left(deadline)
    if left < 2.0:
        say(f"  {effect.name}: not fitted, the time budget ran out")
        return None
    say(f"  fitting {effect.name}")
    k = dg.split["n_fit"]
    work = dg.work(record)
    rec_fit = S._part(work, k)
    fixed = S.with_default_af(model, fixed, rec_fit)
    mask_fit = None if mask is None else np.asarray(mask, bool)[:k]
    # at the rate the diagnosis fitted its base and candidates
    factor = dg.prepare.factor if dg.prepare is not None else 1
    prep, rec_fit, mask_fit = S._prepare_fit(work, rec_fit, mask_fit, factor, S.BUDGET_SAMPLES)
    ext = effect.apply(model)
    problem = Problem(ext, rec_fit, fixed={n: v for n, v in fixed.items() if n in ext.param_names}, mask=mask_fit)
    limit = {} if deadline is None else {"max_wall_time": left / 2}  # two starts (fit_with_effects)
    fr = fit_with_effects(
        problem,
        [effect],
        {**dg.base_fit.params, **dict(start or {})},
        dg.y_base[:k][:: prep.factor],
        max_iter=max_iter,
        compute_stderr=True,
        bound_restart=False,
        **limit,
    )
    band = dg.band
    if fr.success and band is not None:  # a low-pass filtered force: refined in the band it is judged in
        own = tuple(p.name for p in effect.parameters())
        start = {**dg.base_fit.params, **{n: fr.params[n] for n in own if n in fr.params}}
        fr, _ = S.refine_in_band(ext, fr, work, k, band, mask, [(start, own)], deadline)
    run = simulate_record(ext, fr.params, work, x0=fr.x0[0], on_failure="return") if fr.success else None
    if run is None or not (run.success and np.all(np.isfinite(run.y))):
        return None
    y_ext = dg.judged(run.y)
    y = dg.measured(record)
    bic = S._bic(float(np.sum((y[:k] - y_ext[:k]) ** 2)), k, S._n_estimated(fr, ext), band)
    return fr, y_ext, bic


def _drift_fits(effects, windows, record, model, dg, fixed, mask, max_iter, say) -> list:
    """(effect, fit, free run, BIC) of each drift effect that fits, started from the windowed refits' slope."""
    from duffsym.diagnose import drift as D

    out = []
    for eff in effects:
        a = D.guess(eff, windows)
        eff = dataclasses.replace(eff, start=a)
        p0 = float(dg.base_fit.params[eff.parameter]) / (1 - 0.5 * a)  # its value at the start (u = 0)
        try:
            got = _fit_any(eff, record, model, dg, fixed, mask, max_iter, say, start={eff.parameter: p0})
        except (ModelError, DataError) as exc:
            say(f"  {eff.name}: {exc}")
            continue
        if got is not None:
            out.append((eff, *got))
    return out


def _prune(fitted, record, model, dg, fixed, mask, max_iter, say):
    """Refit without the terms whose fitted coefficient is within 2 standard errors of 0 (None if none is)."""
    effect, fr = fitted[0], fitted[1]
    keep = [
        i
        for i, p in enumerate(effect.parameters())
        if abs(fr.params[p.name]) > 2 * float(fr.stderr.get(p.name, math.inf) or math.inf)
    ]
    if not keep or len(keep) == len(effect.terms):
        return None
    smaller = DiscoveredEffect(tuple(effect.terms[i] for i in keep), tuple(effect.coefs[i] for i in keep), effect.index)
    return _fit_effect(smaller, record, model, dg, fixed, mask, max_iter, say)


def _evidence(y, dg, y_ext, bic_ext: float, rules: dict) -> dict:
    """The diagnosis's evidence for a candidate: ΔBIC, held-out fall, share of the excess error removed."""
    k = dg.split["n_fit"]
    mse_held = float(np.mean((y[k:] - dg.y_base[k:]) ** 2))
    mse_h = float(np.mean((y[k:] - y_ext[k:]) ** 2))
    improvement = 1 - math.sqrt(mse_h / mse_held) if mse_held > 0 else 0.0
    excess = mse_held - dg.noise**2
    explained = float(min((mse_held - mse_h) / excess, 1.0)) if excess > 0 else 0.0
    dbic = bic_ext - dg.bic_base
    measurable = dg.noise_estimate is None or dg.noise_estimate.measurable
    need = required_improvement(rules["min_improvement"], mse_held, dg.noise, measurable)
    supported = bool(dbic < rules["bic_threshold"] and improvement >= need)
    needed = bool(supported and explained >= rules["min_explained"] and dg.residuals.worth_a_search)
    return dict(delta_bic=dbic, improvement=improvement, explained=explained, supported=supported, needed=needed)
