"""The current-driven MR damper model (issue 17, item 1): its equations, parameter recovery from records
made by an independent generator (tests/independent_current_sim.py, numpy only) with a time-varying
command and with several constant currents, the CLI fit/validate with a command column, and one-line
errors for bad command columns."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

import independent_current_sim as gen
from duffsym.cli import main
from duffsym.data import read_csv
from duffsym.data.record import Record
from duffsym.errors import DataError
from duffsym.identify import Problem, fit
from duffsym.model import get_model
from duffsym.model.library import mr_damper

DISP = gen.Sines((0.5, 0.2), (1.0, 2.3), (0.0, 1.0))
SWITCH = gen.Switching(0.1, 0.9, gen.Sines((1.0, 0.7), (0.45, 1.1), (0.3, 2.0)))


def _record(command, *, seed=0, disp=DISP, duration=6.0, name="gen") -> Record:
    g = gen.generate(gen.TRUTH, disp, command, duration=duration, seed=seed)
    c = np.asarray(g["command"])
    if np.ptp(c) == 0:
        return Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], current=float(c[0]), name=name)
    return Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], command=c, command_name="current", name=name)


def _z_scores(res) -> dict[str, float]:
    return {n: (res.params[n] - gen.TRUTH[n]) / res.stderr[n] for n in res.free}


def test_at_constant_command_the_model_is_eq12_with_the_coefficients_at_that_current():
    """Analytic: with u_field = i held, the acceleration equals Eq. 12's with c1 -> c1 + c1_u i, etc., and the
    output is A_f (1 + A_f_u u) x'."""
    m = get_model("mr-damper-current")
    base = mr_damper()
    i = sp.Symbol("i", real=True)
    u, cmd = m.states[2], m.input_symbols[2]
    got = m.rhs[1].xreplace({u: i})
    subs = {base.param(k).symbol: base.param(k).symbol + m.param(k + "_u").symbol * i for k in gen.FIELD}
    assert sp.expand(got - base.rhs[1].xreplace(subs)) == 0
    assert sp.expand(m.rhs[2] - (-m.param("eta").symbol * (u - cmd))) == 0
    assert m.inputs[2].name == "command"
    af, afu = m.param("A_f").symbol, m.param("A_f_u").symbol
    assert sp.expand(m.output - af * (1 + afu * u) * m.states[1]) == 0


def test_field_forms_nest_the_linear_one():
    """Saturating: theta + theta_u u_sat tanh(u/u_sat) -> linear as u_sat -> oo; quadratic adds theta_uu u^2."""
    lin, sat, quad = (
        get_model(n) for n in ("mr-damper-current", "mr-damper-current-saturating", "mr-damper-current-quadratic")
    )
    us = sat.param("u_sat").symbol
    assert sp.expand(sp.limit(sat.rhs[1], us, sp.oo) - lin.rhs[1]) == 0
    zero = {quad.param(k + "_uu").symbol: 0 for k in (*gen.FIELD, "A_f")}
    assert sp.expand(quad.rhs[1].xreplace(zero) - lin.rhs[1]) == 0
    assert sp.expand(quad.output.xreplace(zero) - lin.output) == 0
    assert sp.expand(sp.limit(sat.output, us, sp.oo) - lin.output) == 0


@pytest.mark.slow
@pytest.mark.ci
def test_recovers_the_parameters_from_a_record_with_a_time_varying_command():
    """Independent data (RK4 of the written-out equations, 1 % noise), a smoothly switching current
    0.1-0.9 A: every free parameter (incl. the field lag eta) within 3 standard errors of the truth, and
    the standard errors small (< 8 % of the value), so the check can fail."""
    rec = _record(SWITCH)
    model = get_model("mr-damper-current")
    res = fit(Problem(model, rec, fixed={"A_f": gen.TRUTH["A_f"]}))
    assert res.success, res.message
    z = _z_scores(res)
    assert max(abs(v) for v in z.values()) < 3.0, z
    assert all(res.stderr[n] < 0.08 * abs(gen.TRUTH[n]) for n in res.free), res.stderr
    assert res.nrmse < 0.02


@pytest.mark.slow
@pytest.mark.ci
def test_recovers_the_parameters_from_tests_at_three_constant_currents_fitted_together():
    """A campaign: three records at 0.2, 0.5, 0.8 A (different displacement phases), one parameter set.
    Without a command change inside a record the lag eta is not identifiable: it is held (fixed)."""
    recs = [
        _record(
            gen.constant(c),
            seed=k,
            duration=4.0,
            name=f"{c}A",
            disp=gen.Sines((0.5, 0.2), (1.0, 2.3), (0.3 * k, 1.0 + k)),
        )
        for k, c in enumerate((0.2, 0.5, 0.8))
    ]
    model = get_model("mr-damper-current")
    res = fit(Problem(model, recs, fixed={"A_f": gen.TRUTH["A_f"], "eta": gen.TRUTH["eta"]}))
    assert res.success, res.message
    z = _z_scores(res)
    assert max(abs(v) for v in z.values()) < 3.0, z
    assert all(res.stderr[n] < 0.08 * abs(gen.TRUTH[n]) for n in res.free), res.stderr


#: A damper whose force grows with the current (s12's), a 3 s record sampled at 200 Hz: from the paper's
#: tuning procedure (constant coefficients) the fit ran 306 s and stopped at NRMSE 0.21, eta 689 SE off.
GROWING = dict(
    c1=4.0,
    c2=20.0,
    c3=400.0,
    k1=20.0,
    k2=300.0,
    k3=0.0,
    A_f=1.0,
    c1_u=40.0,
    c2_u=-10.0,
    c3_u=-300.0,
    k1_u=30.0,
    k2_u=100.0,
    A_f_u=0.0,
    eta=100.0,
)


def test_default_start_on_a_short_switching_record_reaches_the_truth():
    """The default start of a command model under a changing command (equation error per trial field rate,
    ranked by free run: ``command_start``): independent data, 3 s, 1 % noise; every parameter within 3
    standard errors, the fit at the noise, and the start itself within 30 % on the main coefficients."""
    from duffsym.identify import initial_guess

    disp = gen.Sines((0.45, 0.25, 0.12), (0.7, 1.6, 2.7), (0.0, 1.0, 2.0))
    switch = gen.Switching(0.05, 0.95, gen.Sines((1.0, 0.7, 0.5), (0.4, 0.9, 1.4), (0.3, 2.0, 4.0)), sharp=2.0)
    g = gen.generate(GROWING, disp, switch, dt=0.005, duration=3.0, seed=3)
    rec = Record(t=g["t"], d=g["d"], y=g["y"], d_dot=g["d_dot"], command=g["command"], command_name="current")
    model = get_model("mr-damper-current")
    start = initial_guess(rec, model, fixed={"A_f": 1.0, "k3": 0.0})
    assert all(abs(start[n] / GROWING[n] - 1) < 0.3 for n in ("c2", "c3", "k2", "c1_u", "c3_u")), start
    res = fit(Problem(model, rec, fixed={"A_f": 1.0}))
    assert res.success, res.message
    z = {n: (res.params[n] - GROWING[n]) / res.stderr[n] for n in res.free if n != "A_f_u"}
    z["A_f_u"] = res.params["A_f_u"] / res.stderr["A_f_u"]
    assert max(abs(v) for v in z.values()) < 3.0, z
    assert res.nrmse < 0.012


def test_linear_parameters_of_the_command_models():
    """Analytic: the velocity equation is affine in the c's, k's and their slopes (curvatures); the
    saturation scale enters through tanh and is not; eta and A_f_u are absent from it."""
    from duffsym.identify.initial import linear_parameters

    coeffs = ["c1", "c2", "c3", "k1", "k2", "k3"]
    slopes = [f"{k}_u" for k in ("c1", "c2", "c3", "k1", "k2")]
    assert linear_parameters(get_model("mr-damper-current")) == coeffs + slopes
    assert linear_parameters(get_model("mr-damper-current-saturating")) == coeffs + slopes
    quad = linear_parameters(get_model("mr-damper-current-quadratic"), exclude=("k3",))
    assert sorted(quad) == sorted(coeffs[:-1] + slopes + [f"{k}_uu" for k in ("c1", "c2", "c3", "k1", "k2")])


# ------------------------------------------------------------------------------------------- CLI
def _csv(path, rec: Record, command: str | None = "current", values=None):
    c = rec.command_signal() if values is None else values
    cols = ["time", "displacement", "velocity", "force"] + ([command] if command else [])
    rows = [
        f"{float(a)!r},{float(b)!r},{float(v)!r},{float(y)!r}" + (f",{ci}" if command else "")
        for a, b, v, y, ci in zip(rec.t, rec.d, rec.d_dot, rec.y, c)
    ]
    path.write_text(",".join(cols) + "\n" + "\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("current")
    train = _csv(tmp / "train.csv", _record(SWITCH))
    out = tmp / "fit.json"
    assert (
        main(
            [
                "fit",
                str(train),
                "--model",
                "mr-damper-current",
                "--af",
                str(gen.TRUTH["A_f"]),
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    return tmp, out


def test_cli_fit_and_validate_on_another_command_history(fitted, capsys):
    """The fit from one record predicts a record with its own (different) command history and input."""
    tmp, out = fitted
    d = json.loads(out.read_text())
    assert d["model"] == "mr-damper-current" and d["success"]
    other = gen.Switching(0.0, 1.0, gen.Sines((1.0, 0.5), (0.3, 0.8), (1.0, 0.1)), sharp=3.0)
    val = _csv(tmp / "val.csv", _record(other, seed=5, disp=gen.Sines((0.4, 0.3), (0.7, 1.9), (0.5, 0.2))))
    capsys.readouterr()
    assert main(["validate", str(out), str(val), "--json"]) == 0
    v = json.loads(capsys.readouterr().out)
    assert v["success"] and v["nrmse"] < 0.03  # the 1 % noise floor is 0.01


def _one_line(code, err, *needles):
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, err


def test_missing_command_column_is_a_one_line_error(fitted, tmp_path, capsys):
    rec = _record(SWITCH)
    bare = _csv(tmp_path / "bare.csv", rec, command=None)
    code = main(["fit", str(bare), "--model", "mr-damper-current", "--quiet"])
    _one_line(code, capsys.readouterr().err, "no current or voltage column", "mr-damper-current")
    code = main(["validate", str(fitted[1]), str(bare)])
    _one_line(code, capsys.readouterr().err, "no current or voltage column")


def test_nan_in_the_command_column_is_a_one_line_error(tmp_path, capsys):
    rec = _record(SWITCH)
    c = np.array(rec.command_signal(), dtype=object)
    c[123] = "nan"
    code = main(["fit", str(_csv(tmp_path / "nan.csv", rec, values=c)), "--model", "mr-damper-current", "--quiet"])
    _one_line(code, capsys.readouterr().err, "row 125", "'current'", "non-finite command")
    c[123] = ""
    with pytest.raises(DataError, match="row 125.*missing or non-finite"):
        read_csv(_csv(tmp_path / "empty.csv", rec, values=c))


def test_constant_command_cannot_identify_the_field_dependence(tmp_path, capsys):
    rec = _record(gen.constant(0.5), duration=3.0)
    path = _csv(tmp_path / "const.csv", rec)
    code = main(["fit", str(path), "--model", "mr-damper-current", "--quiet"])
    _one_line(code, capsys.readouterr().err, "command is constant (0.5 A)", "several currents")


def test_varying_command_refused_by_a_model_without_it(tmp_path, capsys):
    path = _csv(tmp_path / "vary.csv", _record(SWITCH, duration=3.0))
    code = main(["fit", str(path), "--quiet"])
    _one_line(code, capsys.readouterr().err, "current varies", "mr-damper-current")


def test_derive_gives_the_stability_conditions_as_functions_of_the_current():
    """At a held command i the field settles at u = i: the dissipation condition of Eq. 12 becomes one on the
    coefficients at that current, c1(i) + c2(i) >= 0 and c3(i) >= 0 (derived, not typed in)."""
    from duffsym.derive.stability import stability_conditions
    from duffsym.model.library import at_constant_command

    m = get_model("mr-damper-current")
    frozen = at_constant_command(m)
    sc = stability_conditions(frozen)
    i = frozen.param("i").symbol
    P = {n: m.param(n).symbol for n in ("c1", "c2", "c3", "c1_u", "c2_u", "c3_u")}
    c12 = P["c1"] + P["c2"] + (P["c1_u"] + P["c2_u"]) * i
    c3 = P["c3"] + P["c3_u"] * i
    expected = sp.And(c12 >= 0, c3 >= 0)
    got = sc.named()["dV/dt negative semi-definite"]
    vals = [
        {P["c1"]: 1, P["c2"]: 1, P["c3"]: 1, P["c1_u"]: a, P["c2_u"]: 0, P["c3_u"]: b, i: c}
        for a in (-5, 0, 5)
        for b in (-5, 0, 5)
        for c in (0, 0.5, 1)
    ]
    assert all(bool(got.subs(v)) == bool(expected.subs(v)) for v in vals)
    assert at_constant_command(get_model("mr-damper")) is None


def test_certificate_flag_is_checked_over_the_records_command_range():
    """The fit's certificate flag of a command model tests the held-command conditions at every level
    of the records' command range. For the generator's truth, dV/dt <= 0 needs
    c1 + c2 + (c1_u + c2_u) i = 40 - 24 i >= 0, i.e. i <= 5/3 A (analytic): a range up to 2 A fails
    exactly at the grid levels above 5/3, a range up to 1.6 A passes."""
    from duffsym.identify.quality import _outside_certificate

    model = get_model("mr-damper-current")
    assert _outside_certificate(model, [gen.TRUTH], tuple(np.linspace(0.0, 1.6, 11))) == []
    flags = _outside_certificate(model, [gen.TRUTH], tuple(np.linspace(0.0, 2.0, 11)))
    assert len(flags) == 1 and "dV/dt negative semi-definite" in flags[0]["failed"]
    assert flags[0]["command_levels"] == pytest.approx([1.8, 2.0])
    assert "at command 1.8..2" in flags[0]["message"]
    # the level matters: the same parameters at 1.6 A pass, so the flag is not about the parameters alone
    assert _outside_certificate(model, [gen.TRUTH], (1.6,)) == []
