"""Excitations: exact derivatives, input matrices for a model, and bad arguments."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym.errors import DataError
from duffsym.excitation import BandLimitedRandom, Multisine, Sine
from duffsym.model.library import mr_damper


def _spectral_derivative_check(exc, order, t):
    """Compare derivative(order) with a 6th-order central difference of derivative(order - 1)."""
    h = 1e-3
    f = lambda s: exc.derivative(s, order - 1)  # noqa: E731
    fd = (-f(t - 3 * h) + 9 * f(t - 2 * h) - 45 * f(t - h) + 45 * f(t + h) - 9 * f(t + 2 * h) + f(t + 3 * h)) / (60 * h)
    return np.abs(exc.derivative(t, order) - fd).max() / np.abs(fd).max()


@pytest.mark.parametrize(
    "exc",
    [
        Sine(1.3, 2.0, 0.4),
        Multisine((1.0, 0.5, 0.2), (0.5, 1.7, 3.1), (0.0, 1.0, 2.0)),
        Multisine.random_phase(rms=0.8, f_min=0.2, f_max=4.0, n_lines=7, rng=3),
        BandLimitedRandom(rms=1.0, f_max=3.0, duration=4.0, seed=5),
    ],
)
@pytest.mark.parametrize("order", [1, 2])
def test_derivatives_are_exact(exc, order):
    t = np.linspace(0.0, 4.0, 301)
    assert _spectral_derivative_check(exc, order, t) < 1e-9


def test_sine_channels_match_closed_form():
    model = mr_damper(5)
    t = np.linspace(0.0, 1.0, 11)
    a, f, ph = -0.7, 2.5, 0.3
    U = Sine(a, f, ph).channels(t, model)
    w = 2 * math.pi * f
    np.testing.assert_allclose(U[:, 0], a * np.sin(w * t + ph), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(U[:, 1], a * w * np.cos(w * t + ph), rtol=1e-14, atol=1e-14)
    # every order through the shared sine/cosine equals the one-order formula
    for k in range(5):
        np.testing.assert_allclose(
            Sine(a, f, ph)._derivatives(t, [k])[:, 0], Sine(a, f, ph).derivative(t, k), rtol=1e-13, atol=1e-12 * w**k
        )


def test_rms_of_random_excitations():
    t = np.arange(0.0, 4.0, 1e-3)
    ms = Multisine.random_phase(rms=0.8, f_min=0.25, f_max=4.0, n_lines=16, rng=1)
    assert np.sqrt(np.mean(ms(t) ** 2)) == pytest.approx(0.8, rel=1e-2)
    blr = BandLimitedRandom(rms=1.5, f_max=5.0, duration=4.0, seed=2)
    assert np.sqrt(np.mean(blr(t) ** 2)) == pytest.approx(1.5, rel=1e-9)  # lines are periodic in 4 s
    np.testing.assert_array_equal(blr(t), BandLimitedRandom(rms=1.5, f_max=5.0, duration=4.0, seed=2)(t))
    assert not np.allclose(blr(t), BandLimitedRandom(rms=1.5, f_max=5.0, duration=4.0, seed=3)(t))


def test_bad_excitations():
    with pytest.raises(DataError, match="frequency \\(Hz\\) must be a positive finite number; got 0"):
        Sine(1.0, 0.0)
    with pytest.raises(DataError, match="amplitude must be finite"):
        Sine(math.inf, 1.0)
    with pytest.raises(DataError, match="as many amplitudes as frequencies"):
        Multisine((1.0,), (1.0, 2.0))
    with pytest.raises(DataError, match="phases must match"):
        Multisine((1.0, 1.0), (1.0, 2.0), (0.0,))
    with pytest.raises(DataError, match="rms must be a positive"):
        BandLimitedRandom(rms=-1.0)
    with pytest.raises(DataError, match="needs input signal 'd'.*provides 'F'"):
        Sine(1.0, 1.0, signal="F").channels(np.zeros(3), mr_damper(5))
