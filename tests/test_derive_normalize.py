"""Eq. 11 -> Eq. 12 by coefficient matching, against the paper's braces under Eq. 12."""

import numpy as np
import sympy as sp

from duffsym import Sine, simulate
from duffsym.derive import derive_normalization, duffing_like_parameter_map, to_duffing_like
from duffsym.model import duffing_like, mr_damper
from duffsym.model.library import N_SYMBOL
from duffsym.model.presets import TABLE2, TABLE2_N

c1, c2, c3, k1, k2, k3, m, A_f = sp.symbols("c1 c2 c3 k1 k2 k3 m A_f", real=True)
PAPER = {"gamma": c1 + c2, "alpha": k1 + k2, "beta": k3, "delta": c3, "k1": k1, "c1": c1, "A_f": A_f}


def test_mapping_matches_eq12_for_integer_and_symbolic_n():
    for n in (3, 5, N_SYMBOL):
        res = derive_normalization(n)
        assert set(res.mapping) == set(PAPER)
        for name, expr in PAPER.items():
            assert sp.simplify(res.mapping[name] - expr) == 0, name
            if name != "A_f":
                assert sp.simplify(res.physical[name] - expr / m) == 0, name


def test_parameter_map_of_models():
    got = duffing_like_parameter_map(mr_damper(5))
    for name in ("gamma", "alpha", "beta", "delta"):
        assert sp.simplify(got[name] - PAPER[name]) == 0


def test_to_duffing_like_gives_identical_outputs():
    row = TABLE2[0.4]
    dl = to_duffing_like(row)
    assert dl == {"gamma": 20.0, "alpha": 514.0, "beta": 0.0, "delta": 320.0, "k1": 34.0, "c1": 10.0, "A_f": 1.6}
    t = np.arange(0.0, 2.0, 0.005)
    exc = Sine(1.0, 2.0)
    y_mr = simulate(mr_damper(TABLE2_N), row, t, exc, substeps=4).y
    y_dl = simulate(duffing_like(TABLE2_N), dl, t, exc, substeps=4).y
    assert np.max(np.abs(y_mr - y_dl)) <= 1e-12 * np.max(np.abs(y_mr))
