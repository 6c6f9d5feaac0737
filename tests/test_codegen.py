"""Generated code agrees with the SymPy model it came from.

Every numeric form (NumPy lambdify, CasADi Function, compiled numba rhs/jac/output) is checked
against an independent evaluation of the SymPy expressions in 30-digit mpmath, at random states,
inputs and parameters (fixed seeds), to 1e-12 relative to the size of the terms (a difference of
large terms that cancel is judged against the terms, not the near-zero result). Jacobians are
checked against central finite differences of the generated right-hand side.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import sympy as sp

from duffsym.codegen._printing import param_jacobian, state_jacobian
from duffsym.codegen.casadi_fn import casadi_functions
from duffsym.codegen.compiled import _power_by_squaring, compiled_module
from duffsym.codegen.numpy_rhs import numpy_model
from duffsym.errors import ModelError
from duffsym.model.library import N_SYMBOL, duffing, duffing_like, mr_damper
from duffsym.model.symbols import ParamSpec, state_symbol

RTOL = 1e-12
N_POINTS = 6


def lag_friction_model():
    """Table 2's model plus a first-order lag state z (rhs (y - z)/tau, output z) and a smooth
    Coulomb-like friction term -mu*tanh(x2/eps): a new state and a non-polynomial term."""
    base = mr_damper(5)
    z = state_symbol("z")
    tau = ParamSpec("lag_tau", r"\tau", 0.02, 1e-6, 10.0, description="sensor lag")
    mu = ParamSpec("fric_mu", r"\mu", 2.0, 0.0, 1e3, description="friction level")
    eps = ParamSpec("fric_eps", r"\epsilon", 0.05, 1e-6, 1.0, description="friction smoothing velocity")
    x2 = base.velocity
    return base.extend(
        effect="lag+friction",
        params=(tau, mu, eps),
        states=((z, (base.output - z) / tau.symbol),),
        rhs_add={x2: -mu.symbol * sp.tanh(x2 / eps.symbol)},
        output=z,
    )


MODELS = {
    "mr-damper-n3": lambda: mr_damper(3),
    "mr-damper-n5": lambda: mr_damper(5),
    "mr-damper-nx3-nv5": lambda: mr_damper(n_x=3, n_v=5),
    "mr-damper-physical": lambda: mr_damper(5, physical=True),
    "duffing-like-n3": lambda: duffing_like(3),
    "duffing-like-nx5-nv3": lambda: duffing_like(n_x=5, n_v=3),
    "duffing": duffing,
    "mr-damper+lag+friction": lag_friction_model,
}


@pytest.fixture(scope="module", params=sorted(MODELS))
def model(request):
    return MODELS[request.param]()


def random_points(model, seed, n=N_POINTS):
    """States, inputs and parameters (all parameters non-zero, positive where the bounds say so)."""
    rng = np.random.default_rng(seed)
    X = rng.uniform(-1.5, 1.5, (n, model.n_states))
    U = rng.uniform(-3.0, 3.0, (n, model.n_inputs))
    P = np.empty((n, model.n_params))
    for j, spec in enumerate(model.params):
        base = spec.default if spec.default != 0 else spec.typical_scale
        P[:, j] = base * rng.uniform(0.5, 1.5, n)
    return X, U, P


def _mp_functions(model, exprs):
    """mpmath evaluations of ``exprs`` and of the sum of the absolute values of their terms."""
    args = [*model.states, *model.input_symbols, *model.param_symbols]
    scales = [sum(sp.Abs(a) for a in sp.Add.make_args(sp.expand(e))) for e in exprs]
    return (sp.lambdify(args, exprs, modules="mpmath"), sp.lambdify(args, scales, modules="mpmath"))


def reference(model, exprs, X, U, P):
    """Values and term scales of ``exprs`` at each point, in 30-digit arithmetic."""
    f, s = _mp_functions(model, exprs)
    vals, scales = [], []
    with mpmath.workdps(30):
        for x, u, p in zip(X, U, P):
            a = [mpmath.mpf(float(v)) for v in (*x, *u, *p)]
            vals.append([float(v) for v in f(*a)])
            scales.append([float(v) for v in s(*a)])
    return np.array(vals), np.array(scales)


def assert_close(got, want, scale, what):
    err = np.abs(np.asarray(got, dtype=float) - want)
    bound = RTOL * np.maximum(scale, 1e-300)
    worst = np.unravel_index(np.argmax(err / bound), err.shape)
    assert np.all(err <= bound), f"{what}: error {err[worst]:.3e} > {bound[worst]:.3e} at {worst}"


def test_numpy_rhs_and_output_match_sympy(model):
    X, U, P = random_points(model, seed=1)
    nm = numpy_model(model)
    want, scale = reference(model, list(model.rhs), X, U, P)
    assert_close(nm.rhs(X, U, P), want, scale, f"{model.name} numpy rhs")
    want, scale = reference(model, [model.output], X, U, P)
    assert_close(nm.output(X, U, P), want[:, 0], scale[:, 0], f"{model.name} numpy output")


def test_numpy_jacobians_match_sympy(model):
    X, U, P = random_points(model, seed=2)
    nm = numpy_model(model)
    jx, jp = state_jacobian(model), param_jacobian(model)
    want, scale = reference(model, list(jx), X, U, P)
    assert_close(nm.jac_states(X, U, P).reshape(len(X), -1), want, scale, f"{model.name} jac_states")
    want, scale = reference(model, list(jp), X, U, P)
    assert_close(nm.jac_params(X, U, P).reshape(len(X), -1), want, scale, f"{model.name} jac_params")


def test_casadi_functions_match_sympy(model):
    X, U, P = random_points(model, seed=3)
    rhs, out = casadi_functions(model)
    got_rhs = np.array([np.asarray(rhs(x, u, p)).ravel() for x, u, p in zip(X, U, P)])
    got_out = np.array([float(out(x, u, p)) for x, u, p in zip(X, U, P)])
    want, scale = reference(model, list(model.rhs), X, U, P)
    assert_close(got_rhs, want, scale, f"{model.name} casadi rhs")
    want, scale = reference(model, [model.output], X, U, P)
    assert_close(got_out, want[:, 0], scale[:, 0], f"{model.name} casadi output")


def test_compiled_rhs_jac_output_match_sympy(model):
    X, U, P = random_points(model, seed=4)
    mod = compiled_module(model)
    n = model.n_states
    got_rhs, got_jac, got_out = [], [], []
    for x, u, p in zip(X, U, P):
        r, J = np.empty(n), np.empty((n, n))
        mod.rhs(x, u, p, r)
        mod.jac(x, u, p, J)
        got_rhs.append(r)
        got_jac.append(J.ravel())
        got_out.append(mod.output(x, u, p))
    want, scale = reference(model, list(model.rhs), X, U, P)
    assert_close(np.array(got_rhs), want, scale, f"{model.name} compiled rhs")
    want, scale = reference(model, list(state_jacobian(model)), X, U, P)
    assert_close(np.array(got_jac), want, scale, f"{model.name} compiled jac")
    want, scale = reference(model, [model.output], X, U, P)
    assert_close(np.array(got_out), want[:, 0], scale[:, 0], f"{model.name} compiled output")


def test_compiled_single_substep_is_one_rk4_step(model):
    """The compiled substep loop (scalar, fast-math) equals a textbook RK4 step on the SymPy rhs."""
    X, U, P = random_points(model, seed=5, n=1)
    x0, u, p = X[0] * 0.3, U[0], P[0]
    nm = numpy_model(model)
    h = 1e-3
    t = np.array([0.0, h])
    Uc = np.vstack([u, u])  # constant input over the step
    k1 = nm.rhs(x0, u, p)
    k2 = nm.rhs(x0 + 0.5 * h * k1, u, p)
    k3 = nm.rhs(x0 + 0.5 * h * k2, u, p)
    k4 = nm.rhs(x0 + h * k3, u, p)
    want = x0 + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    Xo, Y, M = np.empty((2, model.n_states)), np.empty(2), np.zeros(1, dtype=np.int64)
    st, _ = compiled_module(model).integrate(t, Uc, x0, p, 1, 0.5, 10, False, 1e8, Xo, Y, M)
    assert st == 0 and M[0] == 1
    np.testing.assert_allclose(Xo[1], want, rtol=1e-12, atol=1e-12 * np.abs(x0).max())


def _central_difference(f, v, rel=1e-6):
    cols = []
    for j in range(v.size):
        h = rel * max(1.0, abs(v[j]))
        vp, vm = v.copy(), v.copy()
        vp[j] += h
        vm[j] -= h
        cols.append((f(vp) - f(vm)) / (2 * h))
    return np.stack(cols, axis=-1)


def test_jacobians_match_central_differences(model):
    X, U, P = random_points(model, seed=6, n=3)
    nm = numpy_model(model)
    mod = compiled_module(model)
    n = model.n_states
    for x, u, p in zip(X, U, P):
        fd_x = _central_difference(lambda v, u=u, p=p: nm.rhs(v, u, p), x)
        fd_p = _central_difference(lambda v, x=x, u=u: nm.rhs(x, u, v), p)
        Jc = np.empty((n, n))
        mod.jac(x, u, p, Jc)
        for got, fd, what in (
            (nm.jac_states(x, u, p), fd_x, "jac_states"),
            (Jc, fd_x, "compiled jac"),
            (nm.jac_params(x, u, p), fd_p, "jac_params"),
        ):
            tol = 1e-6 * (1.0 + np.abs(fd).max())
            np.testing.assert_allclose(got, fd, rtol=1e-6, atol=tol, err_msg=f"{model.name} {what}")


def test_power_by_squaring_text():
    assert _power_by_squaring("x", 2) == "(x*x)"
    assert _power_by_squaring("x", 5) == "(((x*x)*(x*x))*x)"
    x = 1.37
    for e in range(1, 9):
        assert eval(_power_by_squaring("x", e)) == pytest.approx(x**e, rel=1e-15)


def test_generated_source_uses_no_slow_pow():
    from duffsym.codegen.compiled import generate_source

    src = generate_source(mr_damper(5))
    assert "**" not in src.split("# Fixed-step RK4")[0]


def test_symbolic_power_refused_by_numeric_code():
    model = duffing_like(N_SYMBOL)
    for build in (numpy_model, casadi_functions, compiled_module):
        with pytest.raises(ModelError, match="n_x is symbolic"):
            build(model)


# ---------------------------------------------------------------------------------- LaTeX
@pytest.mark.parametrize(
    "build, rhs_symbols, out_symbols",
    [
        (
            lambda: mr_damper(5),
            [r"\dot{d}", "c_{1}", "c_{2}", "c_{3}", "k_{1}", "k_{2}", "k_{3}", "x_{2}^{5}", "x_{1}^{5}"],
            ["A_{f}", "x_{2}"],
        ),
        (lambda: mr_damper(n_x=3, n_v=5), ["x_{1}^{3}", "x_{2}^{5}", r"\dot{d}"], ["A_{f}"]),
        (
            lambda: duffing_like(3),
            [r"\gamma", r"\alpha", r"\beta", r"\delta", "k_{1}", "c_{1}", r"\dot{d}", "x_{1}^{3}", "x_{2}^{3}"],
            ["A_{f}"],
        ),
        (duffing, [r"\gamma", r"\alpha", r"\beta", "F", "x_{1}^{3}"], ["x_{1}"]),
        (lag_friction_model, [r"\tanh", r"\mu", r"\epsilon", r"\tau", "A_{f}", "c_{3}"], ["z"]),
    ],
)
def test_latex_uses_paper_symbols(build, rhs_symbols, out_symbols):
    model = build()
    texts = [model.latex(e) for e in model.rhs]
    joined = " ".join(texts)
    for sym in rhs_symbols:
        assert sym in joined, f"{sym!r} missing from {joined!r}"
    out = model.latex(model.output)
    for sym in out_symbols:
        assert sym in out, f"{sym!r} missing from {out!r}"
    # code names never leak into the typeset equations
    for p in model.params:
        if p.name != p.latex and "_" in p.name:
            assert p.name not in joined + out
