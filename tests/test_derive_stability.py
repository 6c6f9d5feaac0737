"""Stability conditions derived from the Lyapunov function, against conditions typed from the
paper's argument (Eq. 6-10), and the numeric certificate on Tables 1 and 2."""

import itertools

import numpy as np
import pytest
import sympy as sp

from duffsym import simulate
from duffsym.derive import stability_certificate, stability_conditions
from duffsym.model import duffing_like, mr_damper
from duffsym.model.library import N_SYMBOL
from duffsym.model.presets import TABLE1_BASE, TABLE1_N, TABLE1_SWEEPS, TABLE2, TABLE2_N

gamma, alpha, beta, delta = sp.symbols("gamma alpha beta delta", real=True)
GRID = (-2, -1, 0, 1, 3)


def truth(cond, values):
    return bool(cond.subs(values))


def expected_odd(a, b, g, dl):
    """The conditions for odd n > 1, typed from the argument: V = a/2 x^2 + b/(n+1) x^(n+1) + v^2/2 with
    both powers even, dV/dt = -(g v^2 + dl v^(n+1)), R = a x + b x^n."""
    return {
        "V positive definite": (a > 0 and b >= 0) or (a >= 0 and b > 0),
        "V radially unbounded": b > 0 or (b == 0 and a > 0),
        "dV/dt negative semi-definite": g >= 0 and dl >= 0,
        "dV/dt = 0 only at x' = 0": not (g == 0 and dl == 0) and not (g * dl < 0),
        "R(x) = 0 only at x = 0 (LaSalle)": not (a == 0 and b == 0) and not (a * b < 0),
    }


@pytest.mark.parametrize("n", [3, 5, N_SYMBOL])
def test_odd_n_conditions_on_a_sign_grid(n):
    sc = stability_conditions(duffing_like(n))
    named = sc.named()
    for a, b, g, dl in itertools.product(GRID, GRID, (-1, 0, 2), (-1, 0, 2)):
        vals = {alpha: a, beta: b, gamma: g, delta: dl}
        exp = expected_odd(a, b, g, dl)
        for key, want in exp.items():
            assert truth(named[key], vals) == want, (key, vals)
        assert all(sc.exact[k] for k in exp)


def test_even_n_breaks_positive_definiteness():
    sc = stability_conditions(duffing_like(4, allow_even=True))
    for a, b in itertools.product(GRID, GRID):
        vals = {alpha: a, beta: b}
        # x^5 in V is odd: it changes sign with x, so V > 0 needs beta = 0 (and then alpha > 0)
        assert truth(sc.v_positive_definite, vals) == (b == 0 and a > 0)
        # x^3 in R is odd: x^3 = -alpha/beta always has a real root unless one of them is 0
        assert truth(sc.only_origin, vals) == ((a == 0) != (b == 0))


def test_extra_equilibria_of_the_double_well():
    sc = stability_conditions(duffing_like(3))
    vals = {alpha: -2, beta: 5}
    roots = sorted(float(e.subs(vals)) for e in sc.equilibria)
    assert np.allclose(roots, [-np.sqrt(2 / 5), np.sqrt(2 / 5)], rtol=1e-14)
    assert truth(sc.equilibria_exist, vals)
    sc_n = stability_conditions(duffing_like(N_SYMBOL))
    root = max(float(e.subs(vals).subs(N_SYMBOL, 5)) for e in sc_n.equilibria)
    assert root == pytest.approx((2 / 5) ** 0.25, rel=1e-14)


def test_mr_damper_conditions_use_gamma_c1_plus_c2():
    sc = stability_conditions(mr_damper(5))
    c1, c2, c3 = sp.symbols("c1 c2 c3", real=True)
    for a, b, c in itertools.product((-20, -10, 10), (-30, -10, 10), (0, 100)):
        assert truth(sc.v_dot_nsd, {c1: a, c2: b, c3: c}) == (a + b >= 0)


def table1(panel, value):
    name, _ = TABLE1_SWEEPS[panel]
    return dict(TABLE1_BASE, **{name: value})


def test_table1_negative_c1_fails_on_the_damping():
    cert = stability_certificate(mr_damper(TABLE1_N), table1("a", -20))
    assert not cert.holds
    failed = {c.name for c in cert.failed}
    assert "dV/dt negative semi-definite" in failed
    assert "V positive definite" not in failed
    detail = next(c.detail for c in cert.failed if c.name == "dV/dt negative semi-definite")
    assert "negative" in detail and "limit cycle" in detail
    # gamma = -10, delta = 100: V' > 0 for |x'| < (10/100)^(1/2)
    assert "0.316228" in detail
    assert "unstable" in cert.conclusion


def test_table1_negative_c1_really_has_a_bounded_self_excited_oscillation():
    # what the certificate says physically: the origin repels, the cubic damping bounds the motion
    model = mr_damper(TABLE1_N)
    t = np.arange(0.0, 20.0, 0.005)
    traj = simulate(model, table1("a", -20), t, np.zeros((t.size, 2)), x0=[1e-4, 0.0])
    late = np.abs(traj.x[t > 15.0, 1]).max()
    assert 0.05 < late < 5.0


def test_table1_double_well_and_softening():
    cert = stability_certificate(mr_damper(TABLE1_N), table1("e", -5))  # alpha = 3 - 5 < 0
    failed = {c.name for c in cert.failed}
    assert failed == {"V positive definite", "R(x) = 0 only at x = 0 (LaSalle)"}
    assert "double well" in cert.conditions[0].detail and "0.632456" in cert.conditions[0].detail
    cert = stability_certificate(mr_damper(TABLE1_N), table1("f", -40))  # beta < 0
    failed = {c.name for c in cert.failed}
    assert {"V positive definite", "V radially unbounded"} <= failed
    ru = next(c for c in cert.conditions if c.name == "V radially unbounded")
    assert "locally" in ru.detail and "0.447214" in ru.detail  # sqrt(8/40)
    # k1 = -5 makes alpha = 0 but beta = 5 > 0: still certified (V = 5/4 x^4 + v^2/2)
    assert stability_certificate(mr_damper(TABLE1_N), table1("d", -5)).holds


def test_table2_rows_hold_and_decay():
    model = mr_damper(TABLE2_N)
    for voltage, row in TABLE2.items():
        cert = stability_certificate(model, row)
        assert cert.holds, (voltage, cert.summary())
    t = np.arange(0.0, 3.0, 0.005)
    traj = simulate(model, TABLE2[0.4], t, np.zeros((t.size, 2)), x0=[0.5, 0.0])
    assert np.abs(traj.x[-1]).max() < 1e-6


def test_conservative_case_is_reported():
    cert = stability_certificate(duffing_like(3), {"gamma": 0.0, "delta": 0.0})
    assert not cert.holds
    (failed,) = cert.failed
    assert failed.name == "dV/dt = 0 only at x' = 0" and "conservative" in failed.detail


def test_certificate_needs_numeric_n():
    from duffsym.errors import ModelError

    with pytest.raises(ModelError, match="integer n"):
        stability_certificate(duffing_like(N_SYMBOL), {})
