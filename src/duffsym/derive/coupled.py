r"""The Lyapunov argument and the per-cycle energy of a structure carrying a Duffing-like element.

Computed from the composed model (:mod:`duffsym.model.structure`), nothing typed in:

1. **Coupled Lyapunov function.** The structure's energy :math:`E_s = \tfrac12 m\dot q^2 + \int_0^q R_s`
   (kinetic term from the coefficient of :math:`\ddot q`, potential from the terms in q alone) and the
   element's own energy :math:`E_e` (Eq. 8 of the element, :func:`~duffsym.derive.lyapunov.energy_lyapunov`)
   are combined as :math:`V = a E_s + E_e`. Along the free dynamics :math:`\dot V` has a cross term in
   :math:`\dot q\dot x`: the element pushes the structure with :math:`A_f\dot x` and is driven by
   :math:`c_1\dot q`; the weight :math:`a` is solved so that it cancels (:math:`a = c_1/A_f` for the
   MR-damper element). What is left is the sign-definite dissipation
   :math:`-W = -\tfrac{c_1}{A_f}c\dot q^2 - (c_1+c_2)\dot x^2 - c_3\dot x^{n+1}` plus a **remainder**
   (:math:`k_1 q\dot x`: the element is driven by the structure's displacement through its spring, but
   its force does not act back through that spring). With the remainder zero (:math:`k_1 = 0`) the
   argument is the paper's: V positive definite and radially unbounded, :math:`\dot V = -W\le 0`,
   and LaSalle's invariant set :math:`\dot q = \dot x = 0` holds only the origin, so the coupled
   system is globally asymptotically stable. With :math:`k_1\ne 0` the report says the energy
   argument does not close and falls back on the linearization.
2. **Linearization.** The characteristic polynomial of the state matrix and its Hurwitz conditions
   (local asymptotic stability of the origin); :func:`coupled_certificate` checks them numerically.
3. **Rate-independent (path-time) elements** (:func:`duffsym.model.library.path_time`): the element's
   equations carry the path rate :math:`\rho = \sqrt{\dot q^2/L^2 + \varepsilon^2}`; it is replaced by a
   positive symbol ``rho`` for the argument. E_e is the element's Eq. 8 energy in its own (path) time;
   :math:`\dot E_e = \rho\,dE_e/ds` plus the input term :math:`c_1\dot d x'`, so the same weight cancels
   the cross term and the element's dissipation is multiplied by :math:`\rho \ge \varepsilon > 0`: the
   argument holds for :math:`\varepsilon > 0` and says so; as :math:`\varepsilon \to 0` the element
   freezes at rest and LaSalle's set is no longer the origin alone (the report states it).
4. **Energy per cycle.** Over a period of a periodic steady state the input's work splits into the
   structure's viscous loss and the element's share,
   :math:`\oint F\dot q\,dt = \oint c\dot q^2\,dt + \oint H\dot q\,dt`, and the element's share is its
   own balance with the piston motion replaced by the structure's:
   :math:`\oint H\,dq = \tfrac{A_f}{c_1}\bigl(\oint W_e\,dt + k_1\oint x\dot q\,dt\bigr)`,
   :math:`W_e = (c_1+c_2)\dot x^2 + c_3\dot x^{n+1}`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
import sympy as sp

from duffsym.derive.items import ReportItem
from duffsym.derive.lyapunov import energy_lyapunov
from duffsym.errors import ModelError
from duffsym.model.core import SymbolicModel
from duffsym.model.structure import FORCE_SYMBOL, Q_DDOT, Q_DOT, H, Q, composition


@dataclass(frozen=True)
class CoupledAnalysis:
    """The coupled system's Lyapunov argument, linearization and per-cycle energy (see the module docstring)."""

    model: str
    E_structure: sp.Expr
    E_element: sp.Expr
    weight: sp.Expr
    V: sp.Expr
    V_dot: sp.Expr
    dissipation: sp.Expr
    remainder: sp.Expr
    conditions: tuple[tuple[str, sp.Basic], ...]
    char_poly: sp.Expr
    hurwitz: tuple[sp.Expr, ...]
    structure_cycle: sp.Eq
    element_cycle: sp.Eq
    conclusion: str
    states: tuple = field(default=(), repr=False)
    path_rate: sp.Expr | None = None  # rho = sqrt(q'^2/L^2 + eps^2) of a path-time element, else None

    def summary(self) -> str:
        lines = [
            f"coupled stability of {self.model}",
            f"  E_s = {self.E_structure}",
            f"  E_e = {self.E_element}",
            f"  weight a = {self.weight}",
            f"  V = a E_s + E_e = {self.V}",
            f"  dV/dt (F = 0) = {self.V_dot}",
            f"  = -W + remainder, W = {self.dissipation}, remainder = {self.remainder}",
        ]
        lines += [f"  condition {n}: {c}" for n, c in self.conditions]
        lines.append(f"  characteristic polynomial: {self.char_poly}")
        lines += [f"  Hurwitz {i + 1}: {h} > 0" for i, h in enumerate(self.hurwitz)]
        lines.append(f"  per cycle (structure): {self.structure_cycle}")
        lines.append(f"  per cycle (element):   {self.element_cycle}")
        if self.path_rate is not None:
            lines.append(f"  rho = {self.path_rate} (the path rate of the rate-independent element, >= eps > 0)")
        lines.append(f"  {self.conclusion}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "E_structure": str(self.E_structure),
            "E_element": str(self.E_element),
            "weight": str(self.weight),
            "V": str(self.V),
            "V_dot": str(self.V_dot),
            "dissipation": str(self.dissipation),
            "remainder": str(self.remainder),
            "conditions": {n: str(c) for n, c in self.conditions},
            "char_poly": str(self.char_poly),
            "hurwitz": [str(h) for h in self.hurwitz],
            "structure_cycle": str(self.structure_cycle),
            "element_cycle": str(self.element_cycle),
            "conclusion": self.conclusion,
            "path_rate": None if self.path_rate is None else str(self.path_rate),
        }


def _structure_energy(comp) -> sp.Expr:
    eq = comp["equation"]
    expr = sp.expand(eq.lhs - eq.rhs)
    mass = expr.coeff(Q_DDOT)
    restoring = sum(
        (
            t
            for t in sp.Add.make_args(expr)
            if t.free_symbols & {Q} and not t.free_symbols & {Q_DOT, Q_DDOT, H, FORCE_SYMBOL}
        ),
        sp.Integer(0),
    )
    s = sp.Dummy("s", real=True)
    q1, q2 = comp["structure_states"]
    pot = sp.integrate(restoring.xreplace({Q: s}), (s, 0, q1))
    return sp.expand(mass * q2**2 / 2 + pot)


#: The symbol standing for the path rate of a rate-independent element in the coupled argument.
RHO = sp.Symbol("rho", positive=True)


def _path_rate(model, q2) -> sp.Expr | None:
    """The path rate sqrt(q2^2/L^2 + eps^2) in a composed model's equations (a path-time element), else None."""
    found = {p for e in model.rhs for p in e.atoms(sp.Pow) if p.exp == sp.Rational(1, 2) and q2 in p.base.free_symbols}
    if len(found) > 1:
        raise ModelError(
            f"model {model.name}: the coupled argument covers one path rate; found {sorted(map(str, found))}"
        )
    return next(iter(found), None)


def _element_in_own_time(el) -> SymbolicModel:
    """A path-time element with its path rate set to 1: the element's equations in its own time (Eq. 8 applies)."""
    from dataclasses import replace

    from duffsym.model.library import D_DOT

    found = {
        p for e in el.rhs for p in e.atoms(sp.Pow) if p.exp == sp.Rational(1, 2) and D_DOT.symbol in p.base.free_symbols
    }
    return replace(el, rhs=tuple(e.xreplace({p: sp.Integer(1) for p in found}) for e in el.rhs)) if found else el


def _free_rhs(model) -> list[sp.Expr]:
    zero = {c.symbol: sp.Integer(0) for c in model.inputs}
    return [e.xreplace(zero) for e in model.rhs]


@lru_cache(maxsize=16)
def coupled_analysis(model: SymbolicModel) -> CoupledAnalysis:
    """The coupled system's derivations (module docstring) for a composed model."""
    comp = composition(model)
    if comp is None:
        raise ModelError(f"model {model.name} is not a composed structure model; use lyapunov_analysis")
    if len(model.states) != 4:
        raise ModelError(
            f"model {model.name}: the coupled argument covers a structure and its element "
            f"(4 states); effects added {len(model.states) - 4} state(s)"
        )
    el = comp["element_model"]
    q1, q2 = comp["structure_states"]
    x1, x2 = el.position, el.velocity
    Es = _structure_energy(comp)
    rho = _path_rate(model, q2)
    Ee = energy_lyapunov(_element_in_own_time(el))
    a = sp.Symbol("a", positive=True)
    V = a * Es + Ee
    rhs = _free_rhs(model)
    rhs_rho = rhs if rho is None else [e.xreplace({rho: RHO}) for e in rhs]
    Vd = sp.expand(sum((sp.diff(V, s) * e for s, e in zip(model.states, rhs_rho)), sp.Integer(0)))
    # the weight cancels the bilinear exchange q2*x2 (state-dependent parts of the coefficient, e.g. of a
    # directional damping d' |x'|, stay in the remainder)
    cross = Vd.coeff(q2).coeff(x2).xreplace({s: sp.Integer(0) for s in (q1, q2, x1, x2)})
    sol = sp.solve(cross, a)
    weight = sp.simplify(sol[0]) if sol else sp.Integer(1)
    V = sp.expand(V.xreplace({a: weight}))
    Vd = sp.expand(Vd.xreplace({a: weight}))
    diss, rem = sp.Integer(0), sp.Integer(0)
    for term in sp.Add.make_args(Vd):
        sig = term.free_symbols & {q1, q2, x1, x2}
        only = len(sig) == 1 and next(iter(sig)) in (q2, x2)
        if only:
            diss -= term
        else:
            rem += term
    conds = _conditions(weight, Es, Ee, diss, rem, (q1, q2, x1, x2), model)
    lam = sp.Symbol("lambda")
    A = sp.Matrix(rhs).jacobian(sp.Matrix(model.states)).xreplace(dict.fromkeys(model.states, 0))
    poly = sp.Poly(sp.expand((lam * sp.eye(4) - A).det() * _mass(comp)), lam)
    hurwitz = _hurwitz(poly)
    s_cyc, e_cyc = _cycle_identities(model, comp, el, diss, weight)
    if rem == 0 and rho is not None:
        concl = (
            "dV/dt = -W <= 0 with no remainder; the element's dissipation carries the path rate rho >= eps > 0, "
            "so for eps > 0 the coupled system is globally asymptotically stable under the conditions (LaSalle: "
            "dq/dt = dx/ds = 0 leaves only the origin); as eps -> 0 the element freezes at rest (rho = 0) and "
            "the argument gives stability only, not convergence to the origin"
        )
    elif rem == 0:
        concl = (
            "dV/dt = -W <= 0 with no remainder: under the conditions the coupled system is globally "
            "asymptotically stable (LaSalle: dq/dt = dx/dt = 0 leaves only the origin)"
        )
    else:
        concl = (
            f"the energy argument does not close: the remainder {rem} has no sign (k1 terms: the element is "
            "driven through its spring by the structure's displacement, but its force A_f x' does not act back "
            "through that spring; dir_c terms: a direction-dependent damping, x' times the drive's velocity, "
            "which adds or removes energy); it closes when the remainder vanishes, otherwise stability of the "
            "origin is local, by the Hurwitz conditions of the linearization"
        )
    return CoupledAnalysis(
        model=model.name,
        E_structure=Es,
        E_element=sp.expand(Ee),
        weight=weight,
        V=V,
        V_dot=Vd,
        dissipation=sp.expand(diss),
        remainder=sp.expand(rem),
        conditions=conds,
        char_poly=poly.as_expr(),
        hurwitz=hurwitz,
        structure_cycle=s_cyc,
        element_cycle=e_cyc,
        conclusion=concl,
        states=(q1, q2, x1, x2),
        path_rate=None if rho is None else sp.Eq(RHO, rho),
    )


def _mass(comp) -> sp.Expr:
    eq = comp["equation"]
    return sp.expand(eq.lhs - eq.rhs).coeff(Q_DDOT)


def _conditions(weight, Es, Ee, diss, rem, states, model) -> tuple:
    q1, q2, x1, x2 = states
    out = [("weight positive", sp.simplify(weight > 0))]
    for name, expr, var in (
        ("structure kinetic", Es, q2),
        ("structure stiffness", Es, q1),
        ("element kinetic", Ee, x2),
        ("element stiffness", Ee, x1),
    ):
        c = sp.expand(expr).coeff(var, 2)
        out.append((f"{name} positive", c > 0))
    for var in (q2, x2):
        for term in sp.Add.make_args(sp.expand(diss)):
            if term.free_symbols & set(states) == {var}:
                coeff, _ = term.as_independent(var)
                out.append((f"dissipation in {var}^{sp.degree(term, var)} >= 0", coeff >= 0))
    out.append(("remainder zero", sp.Eq(rem, 0)))
    return tuple(out)


def _hurwitz(poly: sp.Poly) -> tuple[sp.Expr, ...]:
    """Hurwitz determinants of a polynomial (leading coefficient positive) as expressions that must be > 0."""
    c = poly.all_coeffs()
    n = len(c) - 1
    coef = lambda i: c[i] if 0 <= i <= n else sp.Integer(0)  # noqa: E731
    dets = []
    for k in range(1, n + 1):
        M = sp.Matrix(k, k, lambda i, j: coef(2 * j - i + 1))
        dets.append(sp.factor(sp.expand(M.det())))
    return tuple(dets)


def _cycle_identities(model, comp, el, diss, weight):
    t, T = sp.Symbol("t", real=True), sp.Symbol("T", positive=True)
    q1, q2 = comp["structure_states"]
    force = comp["force"]
    c = sp.expand(comp["equation"].lhs).coeff(Q_DOT)
    F = FORCE_SYMBOL
    cyc = lambda e: sp.Integral(e, (t, 0, T))  # noqa: E731
    s_eq = sp.Eq(cyc(F * q2), cyc(c * q2**2) + cyc(force * q2))
    x1, x2 = el.position, el.velocity
    W_e = sp.expand(
        sum(
            (
                tm
                for tm in sp.Add.make_args(sp.expand(diss))
                if tm.free_symbols & {x2} and not tm.free_symbols & {q1, q2}
            ),
            sp.Integer(0),
        )
    )
    k1 = [p.symbol for p in el.params if p.name == "k1"]
    gain = sp.simplify(force / x2) if x2 in force.free_symbols else sp.Integer(0)
    c1 = sp.simplify(weight * gain)  # the element's input damper: a = c1 / A_f cancels the cross term
    rhs = (gain / c1) * (cyc(W_e) + (k1[0] if k1 else 0) * cyc(x1 * q2))
    return s_eq, sp.Eq(cyc(force * q2), rhs)


@dataclass(frozen=True)
class CoupledCertificate:
    """Numeric check of the coupled conditions for one parameter set."""

    holds_global: bool
    holds_local: bool
    eigenvalues: tuple
    failed: tuple[str, ...]

    @property
    def holds(self) -> bool:
        return self.holds_local

    def summary(self) -> str:
        kind = (
            "global (energy argument)"
            if self.holds_global
            else ("local (linearization)" if self.holds_local else "none")
        )
        eig = ", ".join(f"{complex(e).real:.4g}{complex(e).imag:+.4g}j" for e in self.eigenvalues)
        return f"coupled stability certificate: {kind}; linearization eigenvalues {eig}" + (
            f"; failed: {', '.join(self.failed)}" if self.failed else ""
        )

    def to_dict(self) -> dict:
        return {
            "holds_global": self.holds_global,
            "holds_local": self.holds_local,
            "failed": list(self.failed),
            "eigenvalues": [[complex(e).real, complex(e).imag] for e in self.eigenvalues],
        }


def coupled_certificate(model: SymbolicModel, params: Mapping[str, float]) -> CoupledCertificate:
    """Which of the coupled conditions hold for ``params`` (global energy argument, local Hurwitz test)."""
    an = coupled_analysis(model)
    vals = {model.param(k).symbol: float(v) for k, v in params.items()}
    failed = []
    for name, cond in an.conditions:
        c = cond.xreplace(vals) if hasattr(cond, "xreplace") else cond
        if c not in (sp.true, True):
            failed.append(name)
    hur = [float(h.xreplace(vals)) for h in an.hurwitz]
    local = all(h > 0 for h in hur)
    rhs = [e.xreplace(vals) for e in _free_rhs(model)]
    A = np.array(sp.Matrix(rhs).jacobian(sp.Matrix(model.states)).xreplace(dict.fromkeys(model.states, 0)), dtype=float)
    eig = tuple(np.linalg.eigvals(A))
    if not local:
        failed.append("Hurwitz")
    return CoupledCertificate(holds_global=not failed, holds_local=local, eigenvalues=eig, failed=tuple(failed))


def coupled_report_items(model: SymbolicModel) -> list:
    """The coupled derivations as report items (used by :func:`duffsym.derive.report.derivation_report`)."""
    from duffsym.model.statespace import state_space

    an = coupled_analysis(model)
    comp = composition(model)
    assert comp is not None  # coupled_analysis refuses a model that is not a structure
    tex = model.latex
    ss = state_space(model)
    eq = comp["equation"]
    items = [
        ReportItem(
            "equation",
            "structure and element",
            "Eq. 11/12 inside a structure",
            f"{eq.lhs} = {eq.rhs},  H = {comp['force']}\n"
            + "\n".join(f"d{s}/dt = {e}" for s, e in zip(model.states, model.rhs)),
            " \\\\ ".join(f"\\dot{{{tex(s)}}} = {tex(e)}" for s, e in zip(model.states, model.rhs)),
            note=f"the element ({comp['element']}) is driven by the structure's own (q, q'); its force H acts "
            "on the mass",
            data={"force": str(comp["force"])},
        ),
        ReportItem(
            "state_space",
            "state-space form of the coupled system",
            "Eq. 4/13",
            f"A = {ss.A.tolist()}\nf = {ss.f.T.tolist()}\nB = {ss.B.tolist()}\nC = {ss.C.tolist()}",
            f"A = {sp.latex(ss.A)}",
            data={"A": str(ss.A), "f": str(ss.f), "B": str(ss.B)},
        ),
        ReportItem(
            "coupled_lyapunov",
            "coupled Lyapunov function V = a E_s + E_e",
            "Eq. 8 for the coupled system",
            f"E_s = {an.E_structure}\nE_e = {an.E_element}\na = {an.weight}\nV = {an.V}",
            f"V = {tex(an.V)}",
            note="a is solved so that the q'x' cross term of dV/dt cancels",
            data={"V": str(an.V), "weight": str(an.weight)},
        ),
        ReportItem(
            "coupled_lyapunov_derivative",
            "its time derivative along the free coupled dynamics",
            "Eq. 9 for the coupled system",
            f"dV/dt = {an.V_dot}\n  = -W + remainder\nW = {an.dissipation}\nremainder = {an.remainder}"
            + ("" if an.path_rate is None else f"\n{an.path_rate.lhs} = {an.path_rate.rhs} (path rate, >= eps > 0)"),
            f"\\dot V = {tex(an.V_dot)}",
            note=an.conclusion,
            data={"V_dot": str(an.V_dot), "W": str(an.dissipation), "remainder": str(an.remainder)},
        ),
        ReportItem(
            "coupled_conditions",
            "conditions of the energy argument",
            "",
            "\n".join(f"{n}: {c}" for n, c in an.conditions),
            "",
            data={n: str(c) for n, c in an.conditions},
        ),
        ReportItem(
            "coupled_linearization",
            "linearization: characteristic polynomial and Hurwitz conditions",
            "",
            f"p(lambda) = {an.char_poly}\n" + "\n".join(f"H{i + 1} > 0: {h}" for i, h in enumerate(an.hurwitz)),
            f"p(\\lambda) = {sp.latex(an.char_poly)}",
            note="all Hurwitz determinants positive <=> the origin is locally asymptotically stable",
            data={"char_poly": str(an.char_poly), "hurwitz": [str(h) for h in an.hurwitz]},
        ),
        ReportItem(
            "coupled_energy",
            "energy per cycle of a periodic steady state",
            "",
            f"{an.structure_cycle}\n{an.element_cycle}",
            f"{sp.latex(an.structure_cycle)} \\\\ {sp.latex(an.element_cycle)}",
            note="the input's work = the structure's viscous loss + the energy the element dissipates; "
            "the element's share from its own balance with d = q",
            data={"structure": str(an.structure_cycle), "element": str(an.element_cycle)},
        ),
    ]
    return items
