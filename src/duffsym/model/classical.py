r"""The classical hysteresis and damper models, written once in SymPy like the paper's models.

The seed paper argues against these models ("tanh, signum and absolute functions ... nonideal for numerical
computation"); here they sit in the same library, so codegen, simulation, the collocation fit, the uncertainty,
the diagnosis and ``duffsym compare`` treat them exactly like Eq. 3 and Eq. 12.

Every model is driven by the piston displacement ``d`` and velocity ``d_dot`` (a command-driven variant adds the
``command`` channel) and outputs the force ``y``. Sign conventions follow Spencer et al. (1997): in
:math:`\dot z = -\gamma|v|z|z|^{n-1} - \beta v|z|^n + A v` the ``gamma`` term carries :math:`|v|`.

**The smooth forms.** Where a law has :math:`|\cdot|` or :math:`\operatorname{sign}`, the equations here use
:math:`|v| \approx \sqrt{v^2 + \varepsilon^2}` and :math:`\operatorname{sign} v \approx \tanh(v/\varepsilon)`
(:func:`smooth_abs`, :func:`smooth_sign`), so the right-hand side is smooth for the collocation fit and
its derivatives. ``eps`` (units of d/dt) and ``eps_z`` (units of the hysteretic state) are constructor
settings, stated in each model's description; ``eps=0`` is refused (the collocation fit needs derivatives).
An even integer power :math:`|z|^{2m}` is written :math:`z^{2m}` (exact, no smoothing). The effect of the
smoothing on accuracy is measured against the exact nonsmooth law by ``benchmarks/bench_classical_smoothing.py``
(independent Radau with sign/abs, ``tests/independent_classical_sim.py``).

Static laws (Bingham, biviscous) carry one *carrier* state :math:`\dot s = -s` that the output does not read:
the simulation and the collocation fit need a state vector; the carrier decays from 0 and changes nothing.

References
----------
- R. Bouc (1967); Y.-K. Wen, J. Eng. Mech. Div. 102 (1976) 249-263 (the Bouc-Wen law).
- B. F. Spencer Jr., S. J. Dyke, M. K. Sain, J. D. Carlson, J. Eng. Mech. 123 (1997) 230-238
  (the phenomenological MR-damper model; its Table 1 gives the defaults of :func:`spencer`).
- P. R. Dahl, Aerospace Corp. report TOR-0158(3107-18)-1 (1968) (Dahl friction).
- C. Canudas de Wit, H. Olsson, K. J. Astrom, P. Lischinsky, IEEE TAC 40 (1995) 419-425 (LuGre).
- R. Stanway, J. L. Sproston, N. G. Stevens, J. Electrostatics 20 (1987) 167-184 (Bingham damper).
- N. M. Wereley, L. Pang, G. M. Kamath, J. Intell. Mater. Syst. Struct. 9 (1998) 642-649 (biviscous).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec, state_symbol

D = InputChannel("d", 0)
D_DOT = InputChannel("d", 1)
COMMAND = InputChannel("command", 0)
Z = state_symbol("z")  # hysteretic (or friction bristle) state
Y_INT = state_symbol("y_int")  # Spencer's internal displacement y
CARRIER = state_symbol("s_carrier")
FIELD = state_symbol("u_field")  # the same field symbol as mr-damper-current (u' = -eta (u - command))

#: Default smoothing of |v| and sign(v), in units of d/dt (1e-3 mm/s or cm/s on the damper records).
EPS_V = 1e-3
#: Default smoothing of |z|, in units of the hysteretic state.
EPS_Z = 1e-3
#: Why a scale parameter is held by the fit: the classical z-scaling symmetry.
REASON_A = (
    "held at Spencer et al.'s A: z -> s z with alpha -> alpha/s, A -> s A, gamma, beta -> gamma/s^n, "
    "beta/s^n leaves the force unchanged, so A and alpha are not identifiable together"
)


def _p(name, latex, default, lower, upper, description, unit="1", scale=None, held="") -> ParamSpec:
    return ParamSpec(
        name=name,
        latex=latex,
        default=default,
        lower=lower,
        upper=upper,
        unit=unit,
        scale=scale,
        description=description,
        held=held,
    )


def _eps(value: float, what: str) -> sp.Expr:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ModelError(f"{what} must be a positive number (the smoothing of |.| and sign); got {value!r}")
    return sp.Float(value)


def smooth_abs(v: sp.Expr, eps: float) -> sp.Expr:
    r""":math:`|v| \approx \sqrt{v^2 + \varepsilon^2}` (error at most ``eps``, at v = 0)."""
    return sp.sqrt(v**2 + _eps(eps, "eps") ** 2)


def smooth_sign(v: sp.Expr, eps: float) -> sp.Expr:
    r""":math:`\operatorname{sign} v \approx \tanh(v/\varepsilon)`."""
    return sp.tanh(v / _eps(eps, "eps"))


def abs_power(z: sp.Expr, p, eps: float) -> sp.Expr:
    r""":math:`|z|^p`: exact :math:`z^p` for an even integer p, else :math:`(z^2 + \varepsilon^2)^{p/2}`."""
    p = sp.nsimplify(p)
    if p == 0:
        return sp.Integer(1)
    if p.is_integer and p % 2 == 0:
        return z**p
    return (z**2 + _eps(eps, "eps_z") ** 2) ** (p / 2)


def check_exponent(n) -> sp.Expr:
    """The Bouc-Wen exponent: a real number >= 1 (1 and 2 are the usual choices)."""
    try:
        value = float(n)
    except (TypeError, ValueError):
        raise ModelError(f"the Bouc-Wen exponent n must be a number >= 1; got {n!r}") from None
    if not math.isfinite(value) or value < 1 or value > 25:
        raise ModelError(f"the Bouc-Wen exponent n must be in [1, 25]; got {n!r}")
    return sp.nsimplify(value)


def bouc_wen_rate(v: sp.Expr, z: sp.Expr, gamma, beta, A, n, *, eps: float, eps_z: float) -> sp.Expr:
    r"""Spencer's form of the Bouc-Wen law, smoothed:
    :math:`\dot z = -\gamma|v|\,z|z|^{n-1} - \beta v|z|^n + A v`."""
    return -gamma * smooth_abs(v, eps) * z * abs_power(z, n - 1, eps_z) - beta * v * abs_power(z, n, eps_z) + A * v


def _structural(n) -> tuple:
    """``(("n", n),)``: an integer exponent as int, else the SymPy number."""
    return (("n", int(n) if sp.nsimplify(n).is_integer else n),)


def bouc_wen(n: float = 2, *, eps: float = EPS_V, eps_z: float = EPS_Z) -> SymbolicModel:
    r"""The Bouc-Wen model of a damper (Spencer et al. 1997, Fig. 3), with the hysteretic state in force units.

    .. math:: y = c_0\dot d + k_0(d - x_0) + z, \qquad
              \dot z = -\gamma|\dot d|\,z|z|^{n-1} - \beta\dot d|z|^n + A\dot d

    Spencer's :math:`F = c_0\dot x + k_0(x - x_0) + \alpha z'` with :math:`z'` dimensionless is this law with
    :math:`z = \alpha z'`, :math:`A = \alpha A'`, :math:`\gamma = \gamma'/\alpha^n`, :math:`\beta = \beta'/\alpha^n`
    (the symmetry that makes :math:`\alpha` and :math:`A'` redundant removed). Defaults: Spencer et al.'s
    Table 1 at 0 V in N and cm (:math:`\alpha = 140` N/cm, :math:`A' = 301`, :math:`\gamma' = \beta' = 363`
    cm^-2, :math:`c_0 = 21` N s/cm, :math:`k_0 = 46.9` N/cm, :math:`x_0 = 14.3` cm; n = 2). ``n`` is the
    general exponent (a number >= 1, structural); ``eps``/``eps_z`` the smoothing of |d'| and |z|.
    The term :math:`k_0 x_0` is a constant force: ``x0`` is identifiable only with ``k0`` away from 0.
    """
    n = check_exponent(n)
    alpha = 140.0
    params = (
        _p("c0", "c_{0}", 21.0, -1e7, 1e7, "viscous damping (post-yield slope)", scale=10.0),
        _p("k0", "k_{0}", 46.9, -1e7, 1e7, "linear stiffness (accumulator)", scale=10.0),
        _p("x0", "x_{0}", 14.3, -1e6, 1e6, "initial displacement of the accumulator spring", unit="d unit", scale=1.0),
        _p(
            "A",
            "A",
            alpha * 301.0,
            0.0,
            1e12,
            "initial hysteretic stiffness (alpha A' of Spencer et al.)",
            scale=alpha * 301.0,
        ),
        _p("gamma", r"\gamma", 363.0 / alpha**2, -1e6, 1e6, "shape of the loop (|v| term)", scale=363.0 / alpha**2),
        _p("beta", r"\beta", 363.0 / alpha**2, -1e6, 1e6, "shape of the loop (v term)", scale=363.0 / alpha**2),
    )
    c0, k0, x0, A, gamma, beta = (p.symbol for p in params)
    dd = D_DOT.symbol
    return SymbolicModel(
        name="bouc-wen",
        states=(Z,),
        inputs=(D, D_DOT),
        params=params,
        rhs=(bouc_wen_rate(dd, Z, gamma, beta, A, n, eps=eps, eps_z=eps_z),),
        output=c0 * dd + k0 * (D.symbol - x0) + Z,
        output_name="y",
        structural=_structural(n),
        description=f"Bouc-Wen damper (Spencer et al. 1997 Fig. 3), z in force units, n = {n}; "
        f"|d'| ~ sqrt(d'^2 + {eps:g}^2), |z| ~ sqrt(z^2 + {eps_z:g}^2)",
    )


def spencer(n: float = 2, *, eps: float = EPS_V, eps_z: float = EPS_Z) -> SymbolicModel:
    r"""Spencer's phenomenological MR-damper model (Spencer, Dyke, Sain, Carlson 1997, Eq. 10-16).

    .. math:: y = c_1(u)\dot y_{int} + k_1(d - x_0), \qquad
              \dot y_{int} = \frac{\alpha(u) z + c_0(u)\dot d + k_0(d - y_{int})}{c_0(u) + c_1(u)},

    .. math:: \dot z = -\gamma|\dot d - \dot y_{int}|\,z|z|^{n-1} - \beta(\dot d - \dot y_{int})|z|^n
              + A(\dot d - \dot y_{int}), \qquad \dot u = -\eta(u - i)

    with :math:`\alpha(u) = \alpha + \alpha_u u`, :math:`c_0(u) = c_0 + c_{0,u} u`,
    :math:`c_1(u) = c_1 + c_{1,u} u` (their :math:`\alpha_a, \alpha_b, c_{0a}, \dots`) and the command i (the
    ``current`` or ``voltage`` column) filtered by the first-order lag of rate :math:`\eta` (their Eq. 16).
    Defaults: their Table 1 (N, cm, V): c0a 21.0, c0b 3.50, k0 46.9, c1a 283, c1b 2.95, k1 5.00, x0 14.3,
    alpha_a 140, alpha_b 695, gamma = beta = 363, A = 301, n = 2, eta = 190. ``A`` is held by the fit at its
    default (it trades with alpha under z -> s z; free it explicitly to change it). ``n`` (>= 1) is structural;
    ``eps``/``eps_z`` smooth |d' - y'| and |z|.
    """
    n = check_exponent(n)
    params = (
        _p("alpha", r"\alpha", 140.0, -1e7, 1e7, "hysteretic force per unit z at zero field", scale=100.0),
        _p("alpha_u", r"\alpha^{(u)}", 695.0, -1e7, 1e7, "change of alpha per command unit", scale=100.0),
        _p("c0", "c_{0}", 21.0, -1e7, 1e7, "viscous damping at large velocity, zero field", scale=10.0),
        _p("c0_u", "c_{0}^{(u)}", 3.50, -1e7, 1e7, "change of c0 per command unit", scale=10.0),
        _p("c1", "c_{1}", 283.0, -1e7, 1e7, "viscous damping producing the roll-off at low velocity", scale=100.0),
        _p("c1_u", "c_{1}^{(u)}", 2.95, -1e7, 1e7, "change of c1 per command unit", scale=100.0),
        _p("k0", "k_{0}", 46.9, -1e7, 1e7, "stiffness at large velocity", scale=10.0),
        _p("k1", "k_{1}", 5.0, -1e7, 1e7, "accumulator stiffness", scale=10.0),
        _p(
            "x0",
            "x_{0}",
            14.3,
            -1e6,
            1e6,
            "initial displacement of the accumulator spring k1",
            unit="d unit",
            scale=1.0,
        ),
        _p("gamma", r"\gamma", 363.0, -1e7, 1e7, "shape of the loop (|v| term)", scale=100.0),
        _p("beta", r"\beta", 363.0, -1e7, 1e7, "shape of the loop (v term)", scale=100.0),
        _p(
            "A",
            "A",
            301.0,
            1e-9,
            1e9,
            "initial slope of z against the relative displacement",
            scale=100.0,
            held=REASON_A,
        ),
        _p(
            "eta",
            r"\eta",
            190.0,
            0.1,
            1e5,
            "rate of the field's first-order lag behind the command",
            unit="1/s",
            scale=100.0,
        ),
    )
    al, al_u, c0, c0_u, c1, c1_u, k0, k1, x0, gamma, beta, A, eta = (p.symbol for p in params)
    u = FIELD
    alpha_f, c0_f, c1_f = al + al_u * u, c0 + c0_u * u, c1 + c1_u * u
    d, dd = D.symbol, D_DOT.symbol
    y_rate = (alpha_f * Z + c0_f * dd + k0 * (d - Y_INT)) / (c0_f + c1_f)
    rel = dd - y_rate
    return SymbolicModel(
        name="spencer",
        states=(Z, Y_INT, FIELD),
        inputs=(D, D_DOT, COMMAND),
        params=params,
        rhs=(bouc_wen_rate(rel, Z, gamma, beta, A, n, eps=eps, eps_z=eps_z), y_rate, -eta * (u - COMMAND.symbol)),
        output=c1_f * y_rate + k1 * (d - x0),
        output_name="y",
        structural=_structural(n),
        description=f"Spencer's MR damper (modified Bouc-Wen, 1997), alpha, c0, c1 linear in the field u, "
        f"u' = -eta (u - command), n = {n}; |v| ~ sqrt(v^2 + {eps:g}^2), |z| ~ sqrt(z^2 + {eps_z:g}^2)",
    )


def dahl(*, eps: float = EPS_V) -> SymbolicModel:
    r"""Dahl's friction model (Dahl 1968, exponent 1) with a viscous term.

    .. math:: y = z + \sigma_2\dot d, \qquad \dot z = \sigma_0\left(\dot d - |\dot d|\,\frac{z}{F_c}\right)

    z is the friction force (it tends to :math:`F_c\operatorname{sign}\dot d` over a sliding distance
    :math:`F_c/\sigma_0`). :math:`\sigma_2 = 0` is Dahl's original; the viscous term (as in LuGre) lets the
    model meet a damper's post-yield slope. Defaults: the LuGre paper's example values (:math:`\sigma_0 = 10^5`
    N/m, :math:`F_c = 1` N, :math:`\sigma_2 = 0.4` N s/m). ``eps`` smooths |d'|.
    """
    params = (
        _p("sigma0", r"\sigma_{0}", 1e5, 0.0, 1e12, "pre-sliding stiffness", scale=1e5),
        _p("Fc", "F_{c}", 1.0, 1e-12, 1e12, "Coulomb force", scale=1.0),
        _p("sigma2", r"\sigma_{2}", 0.4, -1e9, 1e9, "viscous friction", scale=1.0),
    )
    s0, fc, s2 = (p.symbol for p in params)
    dd = D_DOT.symbol
    return SymbolicModel(
        name="dahl",
        states=(Z,),
        inputs=(D, D_DOT),
        params=params,
        rhs=(s0 * (dd - smooth_abs(dd, eps) * Z / fc),),
        output=Z + s2 * dd,
        output_name="y",
        description=f"Dahl friction (1968) + viscous; |d'| ~ sqrt(d'^2 + {eps:g}^2)",
    )


def lugre(*, eps: float = EPS_V) -> SymbolicModel:
    r"""The LuGre friction model (Canudas de Wit, Olsson, Astrom, Lischinsky 1995, Eq. 2-4).

    .. math:: \dot z = \dot d - \sigma_0\frac{|\dot d|}{g(\dot d)} z, \quad
              g(v) = F_c + (F_s - F_c)e^{-(v/v_s)^2}, \quad y = \sigma_0 z + \sigma_1\dot z + \sigma_2\dot d

    z is the mean bristle deflection. Defaults: the paper's example (:math:`\sigma_0 = 10^5` N/m,
    :math:`\sigma_1 = \sqrt{10^5}` N s/m, :math:`\sigma_2 = 0.4` N s/m, :math:`F_c = 1` N, :math:`F_s = 1.5` N,
    :math:`v_s = 0.001` m/s). The bristle equation is stiff: its rate :math:`\sigma_0|v|/g` is 1e4 1/s at
    0.1 m/s with these values. ``eps`` smooths |d'|.
    """
    params = (
        _p("sigma0", r"\sigma_{0}", 1e5, 1e-12, 1e12, "bristle stiffness", scale=1e5),
        _p("sigma1", r"\sigma_{1}", math.sqrt(1e5), -1e9, 1e9, "bristle damping", scale=300.0),
        _p("sigma2", r"\sigma_{2}", 0.4, -1e9, 1e9, "viscous friction", scale=1.0),
        _p("Fc", "F_{c}", 1.0, 1e-12, 1e12, "Coulomb force", scale=1.0),
        _p("Fs", "F_{s}", 1.5, 1e-12, 1e12, "stiction force", scale=1.0),
        _p("vs", "v_{s}", 1e-3, 1e-9, 1e9, "Stribeck velocity", unit="d unit/s", scale=1e-3),
    )
    s0, s1, s2, fc, fs, vs = (p.symbol for p in params)
    dd = D_DOT.symbol
    g = fc + (fs - fc) * sp.exp(-((dd / vs) ** 2))
    zdot = dd - s0 * smooth_abs(dd, eps) / g * Z
    return SymbolicModel(
        name="lugre",
        states=(Z,),
        inputs=(D, D_DOT),
        params=params,
        rhs=(zdot,),
        output=s0 * Z + s1 * zdot + s2 * dd,
        output_name="y",
        description=f"LuGre friction (Canudas de Wit et al. 1995); |d'| ~ sqrt(d'^2 + {eps:g}^2)",
    )


def bingham(*, eps: float = EPS_V) -> SymbolicModel:
    r"""The Bingham damper (Stanway, Sproston, Stevens 1987): a yield force plus a viscous force.

    .. math:: y = f_c\operatorname{sign}(\dot d) + c_0\dot d + f_0, \qquad
              \operatorname{sign}\dot d \approx \tanh(\dot d/\varepsilon)

    A static law (no memory, so no hysteresis loop in force-velocity beyond the sign switch); it carries the
    decaying carrier state :math:`\dot s = -s` that the output does not read (the module docstring).
    Defaults: the Bingham fit of Spencer et al. 1997 (N, cm): :math:`f_c = 670` N, :math:`c_0 = 50` N s/cm,
    :math:`f_0 = -95` N.
    """
    params = (
        _p("fc", "f_{c}", 670.0, -1e9, 1e9, "yield (Coulomb) force", scale=100.0),
        _p("c0", "c_{0}", 50.0, -1e9, 1e9, "post-yield viscous damping", scale=10.0),
        _p("f0", "f_{0}", -95.0, -1e9, 1e9, "force offset (accumulator)", scale=100.0),
    )
    fc, c0, f0 = (p.symbol for p in params)
    dd = D_DOT.symbol
    return SymbolicModel(
        name="bingham",
        states=(CARRIER,),
        inputs=(D, D_DOT),
        params=params,
        rhs=(-CARRIER,),
        output=fc * smooth_sign(dd, eps) + c0 * dd + f0,
        output_name="y",
        description=f"Bingham damper (Stanway et al. 1987); sign(d') ~ tanh(d'/{eps:g})",
    )


def biviscous(*, eps: float = EPS_V) -> SymbolicModel:
    r"""The nonlinear biviscous damper (Wereley, Pang, Kamath 1998): pre-yield damping :math:`c_{pr}` below the
    yield velocity :math:`v_y = f_y/(c_{pr} - c_{po})`, post-yield :math:`c_{po}` plus the yield force above.

    .. math:: y = c_{po}\dot d + \tfrac{c_{pr} - c_{po}}{2}\left(|\dot d + v_y| - |\dot d - v_y|\right) + f_0

    (equal to :math:`c_{pr}\dot d` for :math:`|\dot d| \le v_y` and :math:`c_{po}\dot d + f_y\operatorname{sign}
    \dot d` above; continuous), with :math:`|a| \approx \sqrt{a^2 + \varepsilon^2}`. Static, with a carrier
    state like :func:`bingham`. Defaults: a Bingham damper of :func:`bingham`'s size with
    :math:`c_{pr} = 20 c_{po}`.
    """
    params = (
        _p("c_pr", "c_{pr}", 1000.0, 1e-9, 1e12, "pre-yield damping", scale=100.0),
        _p("c_po", "c_{po}", 50.0, -1e9, 1e9, "post-yield damping", scale=10.0),
        _p("fy", "f_{y}", 670.0, 1e-9, 1e12, "yield force", scale=100.0),
        _p("f0", "f_{0}", 0.0, -1e9, 1e9, "force offset", scale=100.0),
    )
    cpr, cpo, fy, f0 = (p.symbol for p in params)
    dd = D_DOT.symbol
    vy = fy / (cpr - cpo)
    out = cpo * dd + (cpr - cpo) / 2 * (smooth_abs(dd + vy, eps) - smooth_abs(dd - vy, eps)) + f0
    return SymbolicModel(
        name="biviscous",
        states=(CARRIER,),
        inputs=(D, D_DOT),
        params=params,
        rhs=(-CARRIER,),
        output=out,
        output_name="y",
        description=f"biviscous damper (Wereley et al. 1998); |a| ~ sqrt(a^2 + {eps:g}^2)",
    )


def with_command(model: SymbolicModel, coefficients: Sequence[str], *, eta: float = 190.0) -> SymbolicModel:
    r"""A command-driven variant of a constant-coefficient model: each named coefficient :math:`\theta` becomes
    :math:`\theta + \theta_u u` in a field :math:`\dot u = -\eta(u - i)` (Spencer et al.'s Eq. 16) driven by the
    ``command`` (current or voltage). Name: ``<model>-current``."""
    unknown = [c for c in coefficients if c not in model.param_names]
    if unknown:
        raise ModelError(f"with_command: {model.name} has no parameter(s) {unknown}")
    extra, subs = [], {}
    for name in coefficients:
        spec = model.param(name)
        slope = _p(
            f"{name}_u",
            spec.latex + "^{(u)}",
            0.0,
            -1e9,
            1e9,
            f"change of {name} per command unit",
            scale=spec.typical_scale,
        )
        extra.append(slope)
        subs[spec.symbol] = spec.symbol + slope.symbol * FIELD
    rate = _p(
        "eta", r"\eta", eta, 0.1, 1e5, "rate of the field's first-order lag behind the command", unit="1/s", scale=100.0
    )
    return SymbolicModel(
        name=f"{model.name}-current",
        states=model.states + (FIELD,),
        inputs=model.inputs + (COMMAND,),
        params=model.params + tuple(extra) + (rate,),
        rhs=tuple(e.xreplace(subs) for e in model.rhs) + (-rate.symbol * (FIELD - COMMAND.symbol),),
        output=model.output.xreplace(subs),
        output_name=model.output_name,
        structural=model.structural,
        description=f"{model.description}; {', '.join(coefficients)} linear in a field u' = -eta (u - command)",
    )


def bouc_wen_current(n: float = 2, **kwargs) -> SymbolicModel:
    """:func:`bouc_wen` with c0, k0 and the hysteretic stiffness A linear in the filtered command."""
    return with_command(bouc_wen(n, **kwargs), ("c0", "k0", "A"))


def bingham_current(**kwargs) -> SymbolicModel:
    """:func:`bingham` with fc, c0 and f0 linear in the filtered command (the Bingham model per current)."""
    return with_command(bingham(**kwargs), ("fc", "c0", "f0"))


def biviscous_current(**kwargs) -> SymbolicModel:
    """:func:`biviscous` with c_pr, c_po and fy linear in the filtered command."""
    return with_command(biviscous(**kwargs), ("c_pr", "c_po", "fy"))


#: The classical models by CLI name (merged into :data:`duffsym.model.library.MODELS`).
CLASSICAL_MODELS: dict[str, Callable[..., SymbolicModel]] = {
    "bouc-wen": bouc_wen,
    "bouc-wen-current": bouc_wen_current,
    "spencer": spencer,
    "dahl": dahl,
    "lugre": lugre,
    "bingham": bingham,
    "bingham-current": bingham_current,
    "biviscous": biviscous,
    "biviscous-current": biviscous_current,
}
#: Models that take the structural exponent ``n``.
WITH_EXPONENT = ("bouc-wen", "bouc-wen-current", "spencer")

#: The tuning order of each classical model for :func:`duffsym.identify.initial_guess` (the paper's Fig. 4
#: procedure: pairs scanned over factors of the current values; the first step, A_f there, is empty here).
TUNING_STEPS = {
    "bouc-wen": ((), ("c0", "k0"), ("A", "gamma"), ("beta",)),
    "bouc-wen-current": ((), ("c0", "k0"), ("A", "gamma"), ("beta",)),
    "spencer": ((), ("alpha", "c1"), ("c0", "k0"), ("gamma", "beta"), ("alpha_u", "c1_u")),
    "dahl": ((), ("sigma0", "Fc"), ("sigma2",)),
    "lugre": ((), ("sigma0", "Fc"), ("Fs", "vs"), ("sigma1", "sigma2")),
    "bingham": ((), ("fc", "c0")),
    "bingham-current": ((), ("fc", "c0")),
    "biviscous": ((), ("c_pr", "c_po"), ("fy",)),
    "biviscous-current": ((), ("c_pr", "c_po"), ("fy",)),
}
