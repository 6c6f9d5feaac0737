"""Loop metrics against closed forms of elliptic loops and straight lines."""

import math

import numpy as np
import pytest

from duffsym import DataError, Sine, mr_damper, simulate
from duffsym.derive import cycle_energy
from duffsym.model.presets import TABLE2
from duffsym.plot.loops import loop_metrics, signed_area, trajectory_loop_metrics

A, OMEGA, F0 = 0.7, 2 * math.pi * 1.5, 2.3


def ellipse(phi, n=4000):
    """d = A sin(theta), d' = A omega cos(theta), y = F0 sin(theta + phi): a linear viscoelastic loop."""
    theta = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return A * np.sin(theta), A * OMEGA * np.cos(theta), F0 * np.sin(theta + phi)


@pytest.mark.parametrize("phi", [0.3, 1.0, -0.4, 2.5])
def test_elliptic_loop_closed_forms(phi):
    d, v, y = ellipse(phi)
    m = loop_metrics(d, v, y)
    # energy per cycle: oint y dd = pi A F0 sin(phi)
    # (trapezoid over n = 4000 samples: O(1/n^2) error)
    assert m.area_d == pytest.approx(math.pi * A * F0 * math.sin(phi), rel=1e-5)
    # signed d'-y area = oint v dy = pi A omega F0 cos(phi); counter-clockwise when cos(phi) > 0
    assert m.area_v == pytest.approx(math.pi * A * OMEGA * F0 * math.cos(phi), rel=1e-5)
    assert m.orientation == ("counter-clockwise" if math.cos(phi) > 0 else "clockwise")
    # at y = 0 the branches are at d' = +-A omega cos(phi); at d' = 0 at y = +-F0 cos(phi)
    assert m.width_v == pytest.approx(2 * A * OMEGA * abs(math.cos(phi)), rel=1e-5)
    assert m.height_v == pytest.approx(2 * F0 * abs(math.cos(phi)), rel=1e-5)
    assert m.width_d == pytest.approx(2 * A * abs(math.sin(phi)), rel=1e-5)
    assert m.peak == pytest.approx(F0, rel=1e-6)


def test_viscous_line_is_linear_with_unit_sharpness():
    d, v, _ = ellipse(0.0)
    m = loop_metrics(d, v, 1.7 * v)
    assert m.linearity == pytest.approx(1.0, abs=1e-12)
    assert m.pre_yield_slope == pytest.approx(1.7, rel=1e-9)
    assert m.post_yield_slope == pytest.approx(1.7, rel=1e-9)
    assert m.sharpness == pytest.approx(1.0, rel=1e-9)
    # a viscous damper dissipates oint c d' dd = c pi A^2 omega per cycle; its d'-y loop has no area
    assert m.area_d == pytest.approx(1.7 * math.pi * A**2 * OMEGA, rel=1e-5)
    assert m.area_v == pytest.approx(0.0, abs=1e-9)


def test_saturating_loop_is_sharper_than_linear():
    """y = tanh(k d'): the pre-yield slope near d' = 0 exceeds the post-yield slope."""
    d, v, _ = ellipse(0.0)
    m = loop_metrics(d, v, np.tanh(3.0 * v / (A * OMEGA)))
    # mean slope over |y| < peak/2 vs the slope beyond 80 % of the velocity range
    assert m.sharpness > 2.5 and m.linearity < 0.95


def test_shoelace_of_unit_square():
    assert signed_area(np.array([0, 1, 1, 0.0]), np.array([0, 0, 1, 1.0])) == 1.0
    assert signed_area(np.array([0, 0, 1, 1.0]), np.array([0, 1, 1, 0.0])) == -1.0


def test_simulated_loop_area_agrees_with_the_derived_energy_relation():
    """The measured d-y area equals (A_f/c1)(oint W dt + k1 oint x d' dt), the identity derived in duffsym.derive,
    evaluated from the simulated states (another integrand: an independent check of the quadrature)."""
    model = mr_damper()
    t = np.arange(0, 3.0 + 1e-9, 0.0005)
    traj = simulate(model, TABLE2[0.4], t, Sine(1.0, 2.0))
    m = trajectory_loop_metrics(traj, 0.5)
    predicted = cycle_energy(traj, 0.5, model).loop_area_predicted
    assert m.area_d == pytest.approx(predicted, rel=1e-5)
    assert m.area_d > 0  # a passive damper dissipates


def test_bad_cycles_are_rejected():
    d, v, y = ellipse(0.3)
    with pytest.raises(DataError, match="same length"):
        loop_metrics(d, v[:-1], y)
    with pytest.raises(DataError, match="at least 8 samples"):
        loop_metrics(d[:4], v[:4], y[:4])
    y = y.copy()
    y[10] = np.nan
    with pytest.raises(DataError, match="non-finite"):
        loop_metrics(d, v, y)
