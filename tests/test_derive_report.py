"""The derivation report: order, content (compared with the paper's results typed here), and the
three output forms."""

import json

import sympy as sp

from duffsym.derive import derivation_report
from duffsym.model import ParamSpec, duffing, duffing_like, get_model, mr_damper

ORDER_MR = [
    "equation",
    "state_space",
    "normalization",
    "lyapunov_state",
    "lyapunov_energy",
    "lyapunov_derivative",
    "invariant_set",
    "stability_conditions",
    "scaling_symmetry",
    "energy",
    "certificate_defaults",
]

x1, x2 = sp.symbols("x1 x2", real=True)
c1, c2, c3, k1, k2, k3, A_f = sp.symbols("c1 c2 c3 k1 k2 k3 A_f", real=True)
NAMES = {str(v): v for v in (x1, x2, c1, c2, c3, k1, k2, k3, A_f)}


def parse(text):
    return sp.sympify(text, locals=NAMES)


def test_mr_damper_report_content_and_order():
    rep = derivation_report(get_model("mr-damper", 5))
    assert [it.key for it in rep.items] == ORDER_MR
    assert rep.item("state_space").equation == "Eq. 13-14"
    A = sp.Matrix(parse(rep.item("state_space").data["A"]))
    assert sp.simplify(A - sp.Matrix([[0, 1], [-k1 - k2, -c1 - c2]])) == sp.zeros(2, 2)  # Eq. 13
    f = sp.Matrix(parse(rep.item("state_space").data["f"]))
    assert sp.simplify(f - sp.Matrix([0, -c3 * x2**5 - k3 * x1**5])) == sp.zeros(2, 1)
    mapping = {k: parse(v) for k, v in rep.item("normalization").data["mapping"].items()}
    assert sp.simplify(mapping["gamma"] - (c1 + c2)) == 0 and sp.simplify(mapping["alpha"] - (k1 + k2)) == 0
    v_paper = (k1 + k2) / 2 * x1**2 + x2**2 / 2 + k3 / 6 * x1**6  # Eq. 6 with alpha = k1 + k2, beta = k3, n = 5
    assert sp.simplify(parse(rep.item("lyapunov_state").data["V"]) - v_paper) == 0
    assert sp.simplify(parse(rep.item("lyapunov_energy").data["V"]) - v_paper) == 0
    assert rep.item("lyapunov_energy").data["identical_to_eq6"] is True
    vdot = parse(rep.item("lyapunov_derivative").data["V_dot"])
    assert sp.simplify(vdot + (c1 + c2) * x2**2 + c3 * x2**6) == 0  # Eq. 7/9
    sym = {k: parse(v) for k, v in rep.item("scaling_symmetry").data["mapping"].items() if k != "s"}
    s = sp.Symbol("s", positive=True)
    assert sp.simplify(sym["A_f"].subs(sp.Symbol("s"), s) - A_f / s) == 0


def test_three_output_forms():
    rep = derivation_report(mr_damper(5))
    text = rep.to_text()
    assert text.startswith("Derivations for model mr-damper")
    for needle in ("[paper Eq. 6]", "[paper Eq. 10]", "gamma = c1 + c2", "A_f -> A_f/s", "x_ddot = "):
        assert needle in text, needle
    tex = rep.to_latex()
    assert tex.count("\\begin{gather*}") == tex.count("\\end{gather*}") == len(rep.items) - 1
    assert tex.count("\\begin{verbatim}") == 1  # the certificate is prose
    assert tex.count("{") == tex.count("}")
    assert "\\dot{x}" in tex and "x_{dot}" not in tex
    assert rep.item("certificate_defaults").data["holds"] is True  # defaults = Table 2, 0.4 V
    data = json.loads(json.dumps(rep.to_dict()))
    assert data["model"] == "mr-damper" and [i["key"] for i in data["items"]] == ORDER_MR


def test_duffing_like_symbolic_n_and_duffing():
    from duffsym.model.library import N_SYMBOL

    rep = derivation_report(duffing_like(N_SYMBOL))
    assert "normalization" not in [it.key for it in rep.items]
    assert "x2**(n + 1)" in rep.item("lyapunov_derivative").text
    rep = derivation_report(duffing())
    assert rep.item("scaling_symmetry").data["exists"] is False
    assert rep.item("equation").equation == "Eq. 1"


def test_extended_model_is_derived_on_the_mechanical_pair():
    base = mr_damper(5)
    mu = ParamSpec("t_mu", r"\mu", 1.0, 0.0, 10.0)
    eps = ParamSpec("t_eps", r"\varepsilon", 0.01, 1e-6, 1.0)
    z = sp.Symbol("z_t", real=True)
    tau = ParamSpec("t_tau", r"\tau", 0.01, 1e-6, 1.0)
    model = base.extend(
        effect="test-friction",
        params=(mu, eps),
        rhs_add={base.velocity: -mu.symbol * sp.tanh(base.velocity / eps.symbol)},
    )
    model = model.extend(effect="test-lag", params=(tau,), states=((z, (model.output - z) / tau.symbol),), output=z)
    rep = derivation_report(model)
    deriv = rep.item("lyapunov_derivative")
    assert "t_mu*x2*tanh(x2/t_eps) <= 0 when t_mu >= 0 (taking t_eps > 0)" in deriv.text
    assert "z_t do not act on the mechanics" in deriv.note
    terms = deriv.data["terms"]
    assert any(t["nonpositive_if"] == "t_mu >= 0" for t in terms)
    assert (
        sp.simplify(parse(rep.item("lyapunov_energy").data["V"]) - ((k1 + k2) / 2 * x1**2 + x2**2 / 2 + k3 / 6 * x1**6))
        == 0
    )
    assert rep.item("equation").text.count("\n") == 3  # three state equations and the output
    json.dumps(rep.to_dict())


def test_latex_text_is_escaped_once_and_verbatim_lines_fit():
    from duffsym.derive.report import _tex_escape, _wrap_verbatim

    assert _tex_escape("A_c^T P, |y| -> {x}") == (
        r"A\_c\textasciicircum{}T P, \textbar{}y\textbar{} -"
        r"\textgreater{} \{x\}"
    )
    assert _tex_escape("a\\b") == r"a\textbackslash{}b"
    long = "[ok] dV/dt negative semi-definite: " + "x " * 60
    assert all(len(line) <= 80 for line in _wrap_verbatim(long).splitlines())
