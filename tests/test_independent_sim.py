"""The independent generator (tests/independent_sim.py) checked against duffsym's simulator on the
base model, against itself at a finer step, and for its independence (it must not import duffsym)."""

import ast
from pathlib import Path

import numpy as np
import pytest

import independent_sim as gen
from duffsym.excitation import Sine
from duffsym.model.library import mr_damper
from duffsym.simulate import simulate


def test_generator_imports_no_duffsym():
    tree = ast.parse(Path(gen.__file__).read_text())
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    names += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    assert names and not any(x.split(".")[0] == "duffsym" for x in names), names


@pytest.mark.parametrize("volt", [0.0, 0.4, 0.8])
def test_generator_matches_duffsym_on_the_base_model(volt):
    # dt = 1 ms: duffsym reconstructs the sampled input linearly between samples (error ~ (w dt)^2/8,
    # 5e-4 at 5 ms), the generator evaluates it exactly; at 1 ms the two must agree to 1e-4 of the peak
    p = gen.table2(volt)
    t = 0.001 * np.arange(2001)
    y, _ = gen.simulate_device(p, gen.Physics(), gen.SumOfSines((1.0,), (2.0,), (0.0,)), t)
    m = mr_damper()
    ref = simulate(m, {k: p[k] for k in m.param_names}, t, Sine(1.0, 2.0), method="radau").y
    assert np.max(np.abs(ref - y)) < 1e-4 * np.max(np.abs(y))


@pytest.mark.parametrize("lag, tol", [(0.0, 5e-4), (0.01, 5e-3)])
def test_generator_converged_in_its_step_with_every_effect(lag, tol):
    # with play, p' and p'' jump at each engagement; Eq. 12 is integrated in u = x' - c1 p (forcing p,
    # continuous), so only the load-cell lag sees a jump (of the seal friction and inertia terms), located
    # within a substep: an error ~ jump * h / tau (0.3 % of the peak here, below the 1 % noise); the steep
    # internal friction (eps = 0.005) costs 3e-4
    p = gen.table2(0.4)
    inp = gen.make_input("multisine", np.random.default_rng(1))
    phys = gen.Physics(
        backlash=0.03,
        internal_friction=15,
        seal_friction=0.1,
        inertia=0.002,
        gas_preload=0.05,
        gas_stiffness=0.2,
        asymmetry=0.1,
        lag=lag,
        delay=0.01,
        offset=0.1,
    )
    t = 0.005 * np.arange(401)
    y20, _ = gen.simulate_device(p, phys, inp, t, substeps=20)
    y80, _ = gen.simulate_device(p, phys, inp, t, substeps=80)
    assert np.max(np.abs(y20 - y80)) < tol * np.max(np.abs(y80))


def test_exact_play_and_noise_level():
    a = np.sin(np.linspace(0, 4 * np.pi, 2001))
    p, eng = gen.play(a, 0.1)
    assert np.max(np.abs(a - p)) == pytest.approx(0.1, abs=1e-12)
    assert 0.2 < np.mean(eng) < 0.95
    g = gen.scenario("clean", 1)
    assert g.noise_std == pytest.approx(0.01 * np.std(g.y_clean), rel=0.15)
    f = gen.scenario("clean", 1, filter_kind="movavg", filter_width=5)
    assert f.noise_std < 0.6 * g.noise_std  # a 5-sample average leaves about 1/sqrt(5) of white noise
