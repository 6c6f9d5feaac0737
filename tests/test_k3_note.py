"""The k3 note says "single-amplitude sine" only when the records are one (issue 24); relative standard
errors are printed with two significant digits, never as 0.00 %."""

from __future__ import annotations

import numpy as np
import pytest

from duffsym.data.record import Record
from duffsym.identify import Problem
from duffsym.identify.problem import single_sine
from duffsym.identify.result import IdentificationResult
from duffsym.model import get_model

T = np.arange(0, 6, 0.005)


def _tri(t, f):
    ph = (t * f) % 1.0
    return 4 * np.abs(ph - 0.5) - 1  # a triangle wave, written out


@pytest.mark.parametrize(
    "d, sine",
    [
        (np.sin(2 * np.pi * 2 * T), True),
        (np.sin(2 * np.pi * 2 * T) + 0.01 * np.random.default_rng(0).standard_normal(T.size), True),
        (_tri(T, 2.0), False),  # 98.6 % of its variance at the fundamental
        (np.sin(2 * np.pi * 0.7 * T) + 0.5 * np.sin(2 * np.pi * 1.9 * T + 1), False),
        (np.cumsum(np.random.default_rng(1).standard_normal(T.size)) * 0.01, False),  # a wandering trajectory
    ],
)
def test_single_sine(d, sine):
    assert single_sine(d) is sine


def test_the_k3_note_names_the_excitation():
    model = get_model("mr-damper", 5)
    y = np.cos(2 * np.pi * 2 * T)
    sine = Problem(model, Record(t=T, d=np.sin(2 * np.pi * 2 * T), y=y)).defaults_applied["k3"]
    tri = Problem(model, Record(t=T, d=_tri(T, 2.0), y=y)).defaults_applied["k3"]
    assert "single-amplitude sine" in sine and "single-amplitude sine" not in tri and "several amplitudes" in tri


def test_tiny_relative_standard_errors_keep_their_digits():
    res = IdentificationResult(
        model="m",
        params={"a": 2.0, "b": 1.0},
        free=("a", "b"),
        fixed={},
        stderr={"a": 6e-7, "b": 0.011},
        covariance=np.eye(2),
        cost=1.0,
        nrmse=0.5,
        r2=0.75,
        status="Solve_Succeeded",
        success=True,
        message="ok",
        n_iter=3,
        timings={},
    )
    text = res.summary()
    assert "(3e-05%)" in text and "(1.10%)" in text and "0.00%" not in text
