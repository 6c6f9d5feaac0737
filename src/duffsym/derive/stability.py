r"""Stability conditions of the Duffing-like models, derived from the Lyapunov function (Eq. 6–10).

The paper assumes :math:`\gamma, \delta, \alpha, \beta > 0` and concludes global asymptotic
stability. Here the conditions are derived, for any parameter signs and for the parity of n:

* :math:`V = \tfrac12\dot x^2 + P(x)` is positive definite and radially unbounded iff the
  potential :math:`P(x) = \sum_k c_k x^{e_k}` is. Each monomial is examined: an even exponent
  makes it :math:`c_k|x|^{e_k}`, an odd one changes sign with x. Near x = 0 the lowest power
  dominates, for large |x| the highest.
* :math:`\dot V = -W(\dot x)` (unforced) is negative semi-definite iff :math:`W \ge 0`, examined
  the same way (:math:`W = \gamma\dot x^2 + \delta\dot x^{n+1}`).
* LaSalle (Eq. 10): on :math:`\{\dot V = 0\}` the roots of W are found; on :math:`\dot x \equiv 0`
  invariance needs :math:`\ddot x = -R(x) = 0`. The roots of :math:`R(x) = x^{e_0}Q(x)` are
  solved by putting :math:`t = x^{e}` in the two-term :math:`Q` and keeping the real roots of
  :math:`x^{e} = t^*` (two of them for even e and :math:`t^* > 0`, one for odd e).

References
----------
H. K. Khalil, *Nonlinear Systems*, 3rd ed., Prentice Hall, 2002, Sect. 4.1–4.2 (Lyapunov's
direct method, radial unboundedness, LaSalle's invariance principle).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import sympy as sp

from duffsym.derive._mechanics import condition_text, mechanics, power_of, split_terms, tidy
from duffsym.derive.lyapunov import LyapunovAnalysis, lyapunov_analysis
from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel


# ----------------------------------------------------------------------------- monomial analysis
@dataclass(frozen=True)
class MonomialSum:
    """:math:`\\sum_k c_k\\,\\mathrm{var}^{e_k}` with exponents sorted ascending (like powers merged)."""

    var: sp.Symbol
    exponents: tuple[sp.Expr, ...]
    coefficients: tuple[sp.Expr, ...]
    polynomial: bool

    def parity(self, e) -> str:
        return "even" if sp.sympify(e).is_even else "odd" if sp.sympify(e).is_odd else "unknown parity"


def _monomials(expr: sp.Expr, var: sp.Symbol, structural=()) -> MonomialSum:
    parts = split_terms(expr, (var,))
    exps, coeffs, poly = [], [], True
    for mono, c in parts.items():
        e = power_of(mono, var)
        if e is None:
            poly = False
            continue
        exps.append(e)
        coeffs.append(c)
    # order: symbolic powers (n) are ordered as for n = 3, the smallest odd power with distinct terms
    probe = dict.fromkeys(structural, 3)
    order = sorted(range(len(exps)), key=lambda i: float(sp.sympify(exps[i]).subs(probe)))
    return MonomialSum(var, tuple(exps[i] for i in order), tuple(coeffs[i] for i in order), poly)


def _same_sign(c: sp.Expr) -> sp.Expr:
    """``c`` without its positive factors (``alpha/2 -> alpha``, ``beta/(n+1) -> beta``), for readable conditions."""
    c = sp.factor(c)
    if isinstance(c, sp.Mul):
        kept = [a for a in c.args if not a.is_positive]
        neg = [a for a in kept if a.is_negative]
        kept = [a for a in kept if not a.is_negative]
        out = sp.Mul(*kept)
        return -out if len(neg) % 2 else out
    return c


def _gt(c, strict=True):
    """``c > 0`` (or ``>= 0``) written with the sign flipped when c is a negated expression."""
    c = _same_sign(c)
    if c.could_extract_minus_sign():
        return sp.StrictLessThan(-c, 0) if strict else sp.LessThan(-c, 0)
    return sp.StrictGreaterThan(c, 0) if strict else sp.GreaterThan(c, 0)


def _eq0(c):
    return sp.Eq(_same_sign(c), 0)


def _ne0(c):
    return sp.Ne(_same_sign(c), 0)


def _definite(ms: MonomialSum, *, strict: bool) -> tuple[sp.Basic, bool, list[str]]:
    """Condition for ``sum > 0`` (strict) or ``>= 0`` for every var != 0: (condition, exact, reasons)."""
    exps, cs = list(ms.exponents), list(ms.coefficients)
    reasons: list[str] = []
    conds: list[sp.Basic] = []
    exact = True
    # strip odd powers at the ends: they change sign with var, so they must vanish
    while exps and sp.sympify(exps[-1]).is_odd:
        reasons.append(
            f"{ms.var}^{exps[-1]} has an odd exponent: it changes sign with {ms.var} and dominates "
            f"for large |{ms.var}|, so its coefficient {cs[-1]} must vanish"
        )
        conds.append(_eq0(cs[-1]))
        exps.pop(), cs.pop()
    while exps and sp.sympify(exps[0]).is_odd:
        reasons.append(
            f"{ms.var}^{exps[0]} has an odd exponent: it changes sign with {ms.var} and dominates "
            f"near {ms.var} = 0, so its coefficient {cs[0]} must vanish"
        )
        conds.append(_eq0(cs[0]))
        exps.pop(0), cs.pop(0)
    if not exps:
        return (sp.false if strict else sp.And(*conds)), True, reasons + ["no even power is left: the sum vanishes"]
    if any(not sp.sympify(e).is_even for e in exps):
        exact = False
        odd = [e for e in exps if not sp.sympify(e).is_even]
        reasons.append(f"inner power(s) {odd} not known to be even: taken as vanishing (sufficient only)")
        conds += [_eq0(c) for e, c in zip(exps, cs) if not sp.sympify(e).is_even]
        keep = [(e, c) for e, c in zip(exps, cs) if sp.sympify(e).is_even]
        exps, cs = [e for e, _ in keep], [c for _, c in keep]

    def rel(c, zero):
        return _gt(c, strict)

    if len(exps) == 1:
        reasons.append(f"one even power {ms.var}^{exps[0]} = |{ms.var}|^{exps[0]}: its coefficient decides")
        conds.append(rel(cs[0], 0))
    elif len(exps) == 2:
        lo, hi = cs
        reasons.append(
            f"even powers {ms.var}^{exps[0]} and {ms.var}^{exps[1]} are |{ms.var}|^k: near 0 the lower dominates "
            f"(needs {lo} >= 0), for large |{ms.var}| the higher (needs {hi} >= 0); two non-negative terms "
            + ("are positive unless both coefficients vanish" if strict else "give a non-negative sum")
        )
        if strict:
            conds.append(sp.Or(sp.And(_gt(lo), _gt(hi, False)), sp.And(_gt(lo, False), _gt(hi))))
        else:
            conds.append(sp.And(_gt(lo, False), _gt(hi, False)))
    else:
        exact = False
        reasons.append(
            "more than two even powers: all coefficients >= 0 is sufficient (lowest and highest >= 0 necessary)"
        )
        conds += [_gt(c, False) for c in cs]
        if strict:
            conds.append(sp.Or(*[_gt(c) for c in cs]))
    if not ms.polynomial:
        exact = False
    return sp.And(*conds), exact, reasons


def _radially_unbounded(ms: MonomialSum) -> sp.Basic:
    """Condition for ``sum -> +inf`` as ``|var| -> inf`` (two-term exact)."""
    exps, cs = list(ms.exponents), list(ms.coefficients)
    conds = []
    while exps and sp.sympify(exps[-1]).is_odd:
        conds.append(_eq0(cs[-1]))
        exps.pop(), cs.pop()
    if not exps:
        return sp.false
    if len(exps) == 1:
        return sp.And(*conds, _gt(cs[0]))
    return sp.And(*conds, sp.Or(_gt(cs[-1]), sp.And(_eq0(cs[-1]), _gt(cs[-2]))))


@dataclass(frozen=True)
class RootAnalysis:
    """Real roots of :math:`\\sum c_k x^{e_k} = x^{e_0} Q(x)` other than x = 0.

    Attributes
    ----------
    only_zero : condition under which x = 0 is the only real root (None if undecided).
    extra_roots : the other real roots, as expressions, valid when ``exists`` holds.
    exists : condition for the extra roots to be real and non-zero.
    text : the reasoning.
    """

    only_zero: sp.Basic | None
    extra_roots: tuple[sp.Expr, ...]
    exists: sp.Basic | None
    text: str


def _roots(ms: MonomialSum) -> RootAnalysis:
    x = ms.var
    if not ms.polynomial or not ms.exponents:
        return RootAnalysis(None, (), None, "not a sum of powers: roots not analysed symbolically")
    e0 = ms.exponents[0]
    q_exps = [tidy(e - e0) for e in ms.exponents]
    cs = ms.coefficients
    if len(cs) == 1:
        return RootAnalysis(
            _ne0(cs[0]), (), sp.false, f"{ms.var}^{e0} times a constant: only {x} = 0 unless {cs[0]} = 0"
        )
    if len(cs) != 2:
        return RootAnalysis(None, (), None, "more than two powers: roots found numerically only")
    c0, ce = cs
    e = q_exps[1]
    t = sp.Symbol("t", real=True)
    sol = sp.solveset(c0 + ce * t, t, sp.S.Reals)  # Q(x) with t = x^e
    t_star = -c0 / ce
    if isinstance(sol, sp.FiniteSet) and len(sol) == 1:
        t_star = next(iter(sol))
    num, den = sp.fraction(sp.together(t_star))
    sign = sp.factor(num * den)  # sign(t*) = sign(num * den)
    head = (
        f"{x}^{sp.sstr(e0)}*Q({x}) with Q = {sp.sstr(c0)} + {sp.sstr(ce)}*{x}^{sp.sstr(e)}; "
        f"Q = 0 <=> {x}^{sp.sstr(e)} = t* = {sp.sstr(t_star)}"
    )
    both_zero = sp.And(_eq0(c0), _eq0(ce))
    if sp.sympify(e).is_even:
        root = sp.Pow(t_star, 1 / sp.sympify(e))
        exists = sp.And(_ne0(ce), _gt(sign))
        text = (
            head + f"; {x}^{sp.sstr(e)} >= 0 (even exponent), so real roots +-(t*)^(1/{sp.sstr(e)}) exist "
            f"iff t* > 0, i.e. {sp.sstr(sign)} > 0"
        )
        return RootAnalysis(sp.And(sp.Not(exists), sp.Not(both_zero)).to_nnf(), (root, -root), exists, text)
    if sp.sympify(e).is_odd:
        root = sp.sign(t_star) * sp.Pow(sp.Abs(t_star), 1 / sp.sympify(e))
        exists = sp.And(_ne0(ce), _ne0(c0))
        text = head + f"; odd exponent: the real root sign(t*)|t*|^(1/{sp.sstr(e)}) exists whenever t* != 0"
        return RootAnalysis(sp.And(sp.Not(exists), sp.Not(both_zero)).to_nnf(), (root,), exists, text)
    return RootAnalysis(None, (), None, head + "; parity of the exponent unknown")


# ----------------------------------------------------------------------------- symbolic conditions
@dataclass(frozen=True)
class StabilityConditions:
    """Conditions for the Lyapunov argument of Eq. 6–10, derived for one model.

    Attributes
    ----------
    lyapunov : the analysis they come from.
    potential, dissipation : :math:`P(x)` and :math:`W(x, \\dot x) = \\dot x D(x, \\dot x)`
        (:math:`\\dot V = -W` unforced).
    v_positive_definite, v_radially_unbounded, v_dot_nsd : conditions (SymPy booleans).
    v_dot_zero_set : condition for :math:`\\dot V = 0` only on :math:`\\dot x = 0`.
    only_origin : condition for R(x) = 0 only at x = 0 (LaSalle: the origin is the largest
        invariant set in :math:`\\{\\dot V = 0\\}`).
    equilibria : the other equilibria :math:`x^*` (when they exist).
    exact : per condition, whether it is necessary and sufficient (else sufficient).
    reasons : per condition, the derivation in words.
    """

    lyapunov: LyapunovAnalysis
    potential: sp.Expr
    dissipation: sp.Expr
    v_positive_definite: sp.Basic
    v_radially_unbounded: sp.Basic
    v_dot_nsd: sp.Basic
    v_dot_zero_set: sp.Basic | None
    only_origin: sp.Basic | None
    equilibria: tuple[sp.Expr, ...]
    equilibria_exist: sp.Basic | None
    exact: dict[str, bool] = field(default_factory=dict)
    reasons: dict[str, list[str]] = field(default_factory=dict)

    @property
    def globally_stable(self) -> sp.Basic:
        """All conditions together: global asymptotic stability of the unforced origin."""
        parts = [self.v_positive_definite, self.v_radially_unbounded, self.v_dot_nsd]
        parts += [c for c in (self.v_dot_zero_set, self.only_origin) if c is not None]
        if self.lyapunov.coupling != 0:
            parts.append(sp.false)
        return sp.And(*parts)

    def summary(self) -> str:
        lines = [
            f"stability conditions for model {self.lyapunov.model.name}",
            f"  V  = {sp.sstr(self.lyapunov.v_energy)}",
            f"  dV/dt = -W,  W = {sp.sstr(self.dissipation)}",
        ]
        for key, cond in self.named().items():
            tag = "iff" if self.exact.get(key, False) else "if"
            lines.append(f"  {key}: {tag} {sp.sstr(cond)}")
        if self.equilibria:
            lines.append(
                f"  other equilibria x* = {', '.join(map(sp.sstr, self.equilibria))} when "
                f"{sp.sstr(self.equilibria_exist)}"
            )
        return "\n".join(lines)

    def named(self) -> dict[str, sp.Basic]:
        out = {
            "V positive definite": self.v_positive_definite,
            "V radially unbounded": self.v_radially_unbounded,
            "dV/dt negative semi-definite": self.v_dot_nsd,
        }
        if self.v_dot_zero_set is not None:
            out["dV/dt = 0 only at x' = 0"] = self.v_dot_zero_set
        if self.only_origin is not None:
            out["R(x) = 0 only at x = 0 (LaSalle)"] = self.only_origin
        return out


@lru_cache(maxsize=64)
def stability_conditions(model: SymbolicModel) -> StabilityConditions:
    """Derive the stability conditions of ``model`` from its Lyapunov function (see module docs).

    Cached per model (like :func:`~duffsym.derive._mechanics.mechanics`): the fit's quality flags, the
    diagnosis's certificate of every candidate and ``derive`` share one (symbolic, comparatively slow)
    derivation per model."""
    lya = lyapunov_analysis(model)
    mech = mechanics(model)
    structural = mech.structural_symbols
    x, v = lya.x, lya.v
    potential = lya.potential
    dissipation = tidy(v * lya.dissipative)
    pot = _monomials(potential, x, structural)
    pd, pd_exact, pd_why = _definite(pot, strict=True)
    ru = _radially_unbounded(pot)
    reasons = {
        "V positive definite": ["V = x'^2/2 + P(x); x'^2/2 is positive definite in x'"] + pd_why,
        "V radially unbounded": [
            "needs P(x) -> +inf as |x| -> inf: the highest even power's coefficient > 0, odd highest powers absent"
        ],
    }
    exact = {"V positive definite": pd_exact and pot.polynomial, "V radially unbounded": pot.polynomial}
    # dissipation: a sum of powers of x' (the paper's models), else per-term sufficient conditions
    w = _monomials(dissipation, v, structural) if not dissipation.has(x) else None
    if w is not None and w.polynomial and w.exponents:
        nsd, nsd_exact, nsd_why = _definite(w, strict=False)
        roots_w = _roots(w)
        zero_set = roots_w.only_zero
        reasons["dV/dt negative semi-definite"] = ["dV/dt = -W; needs W >= 0"] + nsd_why
        reasons["dV/dt = 0 only at x' = 0"] = [roots_w.text]
        exact["dV/dt negative semi-definite"] = nsd_exact
        exact["dV/dt = 0 only at x' = 0"] = roots_w.only_zero is not None
    else:
        terms = lya.dissipation_terms
        nsd = sp.And(*[t.condition if t.condition is not None else sp.false for t in terms]) if terms else sp.true
        reasons["dV/dt negative semi-definite"] = ["per term (sufficient): " + "; ".join(t.text() for t in terms)]
        exact["dV/dt negative semi-definite"] = False
        zero_set = None
    if lya.coupling != 0:
        reasons["dV/dt negative semi-definite"].append(
            f"the coupling to extra states adds {sp.sstr(tidy(v * lya.coupling))} to dV/dt, which is not "
            "sign-definite: this V does not certify the extended model"
        )
        nsd = sp.false
    rest = _monomials(lya.restoring, x, structural)
    roots_r = _roots(rest)
    reasons["R(x) = 0 only at x = 0 (LaSalle)"] = [
        "on x' = 0 (where dV/dt = 0) invariance needs x'' = -R(x) = 0 (Eq. 10)",
        roots_r.text,
    ]
    exact["R(x) = 0 only at x = 0 (LaSalle)"] = roots_r.only_zero is not None
    return StabilityConditions(
        lyapunov=lya,
        potential=potential,
        dissipation=dissipation,
        v_positive_definite=pd,
        v_radially_unbounded=ru,
        v_dot_nsd=nsd,
        v_dot_zero_set=zero_set,
        only_origin=roots_r.only_zero,
        equilibria=roots_r.extra_roots,
        equilibria_exist=roots_r.exists,
        exact=exact,
        reasons=reasons,
    )


# ----------------------------------------------------------------------------- numeric certificate
@dataclass(frozen=True)
class Condition:
    """One condition of a stability certificate.

    Attributes
    ----------
    name : short name (``"V positive definite"``).
    statement : the condition in the model's parameters (plain text).
    latex : the same in LaTeX.
    holds : whether it holds for the given parameters.
    detail : numbers and what a failure means physically.
    """

    name: str
    statement: str
    latex: str
    holds: bool
    detail: str


@dataclass(frozen=True)
class StabilityCertificate:
    """Lyapunov/LaSalle certificate of global asymptotic stability of the unforced origin.

    Attributes
    ----------
    model : model name.
    params : the parameter values checked.
    holds : True when every condition holds.
    conditions : the conditions, in the order of the argument.
    conclusion : what follows, in words.
    """

    model: str
    params: dict
    holds: bool
    conditions: tuple[Condition, ...]
    conclusion: str

    @property
    def failed(self) -> tuple[Condition, ...]:
        return tuple(c for c in self.conditions if not c.holds)

    def summary(self) -> str:
        lines = [f"stability certificate for {self.model}: {'HOLDS' if self.holds else 'FAILS'}"]
        for c in self.conditions:
            lines.append(f"  [{'ok' if c.holds else 'FAIL'}] {c.name}: {c.statement}")
            if c.detail:
                lines.append(f"         {c.detail}")
        lines.append("  " + self.conclusion)
        return "\n".join(lines)


def _truth(cond: sp.Basic, values: dict) -> bool:
    val = cond.subs(values) if cond not in (sp.true, sp.false) else cond
    val = sp.simplify(val) if val not in (sp.true, sp.false) else val
    if val not in (sp.true, sp.false):
        raise ModelError(f"condition {cond} did not evaluate to True/False with the given parameters ({val})")
    return bool(val)


def _num(e, values) -> float:
    return float(sp.sympify(e).subs(values))


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def stability_certificate(model: SymbolicModel, params: Mapping[str, float]) -> StabilityCertificate:
    """Check the derived stability conditions for numeric ``params``.

    Parameters
    ----------
    model : a model with a mechanical pair and an integer power n.
    params : parameter values by name (missing ones take the model defaults).

    Returns
    -------
    StabilityCertificate : whether the Lyapunov/LaSalle argument proves global asymptotic stability
        of the unforced origin, condition by condition, with what a failure means.
    """
    if any(isinstance(v, sp.Symbol) for _, v in model.structural):
        raise ModelError("stability_certificate needs numeric powers; build the model with an integer n")
    vec = model.param_vector(dict(params), fill_defaults=True)
    values = {p.symbol: sp.nsimplify(float(v), rational=True) for p, v in zip(model.params, vec)}
    named_values = {p.name: float(v) for p, v in zip(model.params, vec)}
    sc = stability_conditions(model)
    lya = sc.lyapunov
    x, v = lya.x, lya.v
    pot = _monomials(sc.potential, x)
    P_num = tidy(sc.potential.subs(values))
    R_num = tidy(lya.restoring.subs(values))
    W_num = tidy(sc.dissipation.subs(values))
    # equilibria of the unforced model, numerically (solveset over the reals)
    eq_set = sp.solveset(R_num, x, sp.S.Reals) if R_num != 0 else sp.S.Reals
    finite_eq = sorted(float(r) for r in eq_set) if isinstance(eq_set, sp.FiniteSet) else None
    extra_eq = [r for r in (finite_eq or []) if r != 0.0]
    lin = _linearization(model, values)
    conds = []
    latex = model.latex
    named = sc.named()
    if sc.v_dot_zero_set is None and W_num.free_symbols <= {v}:
        conds_zero = _numeric_zero_set(W_num, v)
    else:
        conds_zero = None
    for name, cond in named.items():
        holds = _truth(cond, values)
        detail = _detail(name, holds, sc, pot, values, P_num, W_num, R_num, extra_eq, finite_eq, lin)
        tag = "" if sc.exact.get(name, False) else " (sufficient)"
        conds.append(
            Condition(name=name, statement=condition_text(cond) + tag, latex=latex(cond), holds=holds, detail=detail)
        )
    if conds_zero is not None:
        conds.insert(3, conds_zero)
    ok = all(c.holds for c in conds)
    conclusion = _conclusion(ok, conds, lin, extra_eq)
    return StabilityCertificate(
        model=model.name, params=named_values, holds=ok, conditions=tuple(conds), conclusion=conclusion
    )


def _numeric_zero_set(W_num: sp.Expr, v: sp.Symbol) -> Condition:
    """W(v) > 0 for v != 0, checked on a logarithmic grid (for non-polynomial dissipation)."""
    f = sp.lambdify(v, W_num, "numpy")
    grid = np.logspace(-6, 4, 2001)
    vals = np.concatenate([np.broadcast_to(f(grid), grid.shape), np.broadcast_to(f(-grid), grid.shape)])
    holds = bool(np.all(vals > 0))
    return Condition(
        name="dV/dt = 0 only at x' = 0",
        statement="W(x') > 0 for x' != 0 (checked numerically, 1e-6 <= |x'| <= 1e4)",
        latex=r"W(\dot x) > 0 \ \text{for}\ \dot x \ne 0",
        holds=holds,
        detail="non-polynomial dissipation: checked on a grid of velocities, not proved",
    )


def _linearization(model: SymbolicModel, values: dict) -> np.ndarray:
    """Eigenvalues of the state Jacobian at the origin (inputs zero)."""
    J = sp.Matrix(model.rhs).jacobian(sp.Matrix(model.states))
    at = dict.fromkeys(model.states, 0) | dict.fromkeys(model.input_symbols, 0) | values
    Jn = np.array(J.subs(at).evalf(), dtype=float)
    return np.linalg.eigvals(Jn)


def _eig_text(lin: np.ndarray) -> str:
    return ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" if abs(z.imag) > 1e-12 else f"{z.real:.4g}" for z in lin)


def _detail(name, holds, sc, pot, values, P_num, W_num, R_num, extra_eq, finite_eq, lin) -> str:
    x, v = sc.lyapunov.x, sc.lyapunov.v
    if name == "V positive definite":
        base = f"P(x) = {sp.sstr(sp.N(P_num, 6))}"
        if holds:
            return base + ": P > 0 for x != 0"
        lo = [_num(c, values) for c in pot.coefficients]
        if lo and lo[0] < 0:
            return (
                base + f"; the lowest stiffness term is negative, so V < 0 near x = 0: a double well. "
                f"The origin is a saddle (linearization eigenvalues {_eig_text(lin)}); other equilibria at "
                f"x = {', '.join(_fmt(r) for r in extra_eq)}, where the motion settles instead"
            )
        if lo and lo[-1] < 0:
            return base + "; the highest stiffness term is negative: V < 0 for large |x| (softening spring)"
        return base + "; P is not positive for every x != 0"
    if name == "V radially unbounded":
        if holds:
            return "V -> inf as |(x, x')| -> inf: level sets are bounded"
        barrier = ""
        if extra_eq:
            vb = min(float(P_num.subs(x, r)) for r in extra_eq)
            barrier = (
                f"; equilibria at x = {', '.join(_fmt(r) for r in extra_eq)} are saddles with energy "
                f"V = {_fmt(vb)}: the origin is only locally asymptotically stable, for V < {_fmt(vb)}; "
                "larger disturbances or forcing push the motion over the barrier and it diverges"
            )
        return (
            f"P(x) = {sp.sstr(sp.N(P_num, 6))} -> -inf for large |x| (softening: negative highest-power "
            f"stiffness)" + barrier
        )
    if name == "dV/dt negative semi-definite":
        base = f"dV/dt = -({sp.sstr(sp.N(W_num, 6))})"
        if W_num == 0:
            return "dV/dt = 0 identically: no dissipation"
        if holds:
            return base + " <= 0: energy is never created"
        w = _monomials(W_num, v)
        cs = [float(c) for c in w.coefficients] if w.polynomial and w.exponents else []
        if cs and cs[0] < 0:
            txt = (
                base + "; the linear damping is negative: energy is pumped in at small velocities, so the "
                f"origin is unstable (linearization eigenvalues {_eig_text(lin)})"
            )
            if len(cs) > 1 and cs[-1] > 0:
                e = float(w.exponents[-1] - w.exponents[0])
                vb = (-cs[0] / cs[-1]) ** (1 / e)
                txt += (
                    f"; the higher-power damping removes energy for |x'| > {_fmt(vb)}, so the motion stays "
                    "bounded and can settle on a limit cycle around the origin (self-excited oscillation)"
                )
            return txt
        if cs and cs[-1] < 0:
            return base + (
                "; the highest-power damping is negative: energy is pumped in at large velocities, "
                "so fast enough motion grows without bound"
            )
        return base + "; a term of dV/dt is not sign-definite"
    if name == "dV/dt = 0 only at x' = 0":
        if holds:
            return "W(x') = 0 only at x' = 0: the set {dV/dt = 0} is the x-axis of the phase plane"
        if W_num == 0:
            return (
                "no dissipation: dV/dt = 0 identically, V is conserved (conservative system); the origin is "
                "at best stable, not asymptotically stable: solutions keep oscillating on level curves of V"
            )
        return "W(x') vanishes at non-zero velocities too (damping terms of opposite sign)"
    if name.startswith("R(x) = 0"):
        if finite_eq is None:
            return "R(x) = 0 for every x: a continuum of equilibria (no restoring force)"
        if holds:
            return f"R(x) = {sp.sstr(sp.N(R_num, 6))} vanishes only at x = 0: the origin is the largest invariant set"
        return (
            f"R(x) = {sp.sstr(sp.N(R_num, 6))} also vanishes at x = {', '.join(_fmt(r) for r in extra_eq)}: "
            "these equilibria are invariant in {x' = 0}, so solutions need not approach the origin"
        )
    return ""


def _conclusion(ok: bool, conds, lin, extra_eq) -> str:
    if ok:
        return (
            "all conditions hold: V is a global Lyapunov function and, by LaSalle's invariance principle "
            "(Eq. 10), the unforced origin is globally asymptotically stable. With an input, dV/dt = -W + F x': "
            "the input work is the only energy source, and over a periodic steady-state cycle it equals the "
            "energy dissipated (duffsym.derive.energy)"
        )
    broken = ", ".join(c.name for c in conds if not c.holds)
    unstable = bool(np.any(lin.real > 1e-12))
    tail = (
        " The linearization at the origin has an eigenvalue with positive real part: the origin is unstable."
        if unstable
        else ""
    )
    return f"the Lyapunov argument does not prove global asymptotic stability: {broken} fails.{tail}"
