"""Problem validation: every bad configuration raises a clear error at construction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym import Sine, duffing, mr_damper
from duffsym.data import synthetic_record
from duffsym.errors import DataError, ModelError
from duffsym.identify import Problem, fit

MODEL = mr_damper()


@pytest.fixture(scope="module")
def rec():
    return synthetic_record(MODEL, None, Sine(1.0, 2.0), dt=0.005, duration=1.0, noise=0.01, rng=3)


def test_defaults_and_reasons(rec):
    p = Problem(MODEL, rec)
    assert p.free == ("c1", "c2", "c3", "k1", "k2")
    assert p.fixed == {"A_f": pytest.approx(np.max(np.abs(rec.y))), "k3": 0.0}
    assert "symmetry" in p.defaults_applied["A_f"] and "ridge" in p.defaults_applied["k3"]
    # explicitly freeing k3 or fixing A_f removes the default
    p2 = Problem(MODEL, rec, free=["c1", "c3", "k3"], fixed={"A_f": 2.0})
    assert p2.free == ("c1", "c3", "k3") and p2.fixed["A_f"] == 2.0 and "A_f" not in p2.defaults_applied
    # parameters neither free nor fixed are held at the default, with a reason
    assert p2.fixed["k1"] == MODEL.param("k1").default and "not listed in free" in p2.defaults_applied["k1"]
    assert "fixed: A_f" in p.summary()


def test_no_defaults_for_models_without_af_or_k3():
    m = duffing()
    r = synthetic_record(m, None, Sine(1.0, 0.5, signal="F"), dt=0.01, duration=6.0, noise=0.0, rng=0)
    p = Problem(m, r)
    assert p.free == ("gamma", "alpha", "beta") and p.defaults_applied == {}


def test_unknown_names(rec):
    with pytest.raises(ModelError, match=r"free: unknown parameter\(s\) \['c9'\]"):
        Problem(MODEL, rec, free=["c1", "c9"])
    with pytest.raises(ModelError, match=r"fixed: unknown parameter\(s\) \['zz'\]"):
        Problem(MODEL, rec, fixed={"zz": 1.0})
    with pytest.raises(ModelError, match=r"bounds: unknown parameter\(s\) \['q'\]"):
        Problem(MODEL, rec, bounds={"q": (0, 1)})


def test_free_and_fixed_overlap(rec):
    with pytest.raises(ModelError, match=r"\['c1'\] are both free and fixed"):
        Problem(MODEL, rec, free=["c1", "c2"], fixed={"c1": 3.0})


def test_bounds_order(rec):
    with pytest.raises(ModelError, match=r"bounds of c1 must satisfy lower < upper; got \(5.0, 1.0\)"):
        Problem(MODEL, rec, bounds={"c1": (5.0, 1.0)})
    with pytest.raises(ModelError, match="bounds of c2 must satisfy"):
        Problem(MODEL, rec, bounds={"c2": (1.0, 1.0)})


def test_fixed_values_finite(rec):
    with pytest.raises(ModelError, match="fixed value of c1 must be finite"):
        Problem(MODEL, rec, fixed={"c1": math.inf})
    with pytest.raises(ModelError, match="fixed value of c1 must be a number"):
        Problem(MODEL, rec, fixed={"c1": "ten"})


def test_nothing_free(rec):
    with pytest.raises(ModelError, match="no free parameter left"):
        Problem(MODEL, rec, fixed=dict.fromkeys(MODEL.param_names, 1.0))


def test_records_checked(rec):
    with pytest.raises(DataError, match="needs at least one record"):
        Problem(MODEL, [])
    with pytest.raises(DataError, match=r"records\[1\] is a dict"):
        Problem(MODEL, [rec, {"t": 1}])


def test_masks_and_weights(rec):
    n = rec.n_times
    with pytest.raises(DataError, match=rf"mask\[0\] has 10 values for record .* of {n} samples"):
        Problem(MODEL, rec, mask=np.zeros(10, bool))
    with pytest.raises(DataError, match=r"give one array per record \(2\)"):
        Problem(MODEL, [rec, rec], mask=[np.zeros(n, bool)] * 3)
    with pytest.raises(DataError, match="weights.*must be finite and >= 0"):
        Problem(MODEL, rec, weights=-np.ones(n))
    with pytest.raises(DataError, match="only 0 sample"):
        Problem(MODEL, rec, mask=np.ones(n, bool))
    w = np.ones(n)
    w[:10] = 0
    p = Problem(MODEL, rec, weights=w, mask=np.r_[np.zeros(n - 5, bool), np.ones(5, bool)])
    assert p.sample_weights(0).sum() == n - 15


def test_fit_arguments_checked(rec):
    p = Problem(MODEL, rec)
    with pytest.raises(ModelError, match=r"x0: initial value of c1 = -5 is outside its bounds"):
        fit(p, {"c1": -5.0})
    with pytest.raises(ModelError, match=r"x0: unknown parameter\(s\) \['foo'\]"):
        fit(p, {"foo": 1.0})
    with pytest.raises(ModelError, match="x0 must give 5 values"):
        fit(p, [1.0, 2.0])
    with pytest.raises(ModelError, match="degree must be a positive integer"):
        fit(p, degree=0)


def test_group_arguments_checked(rec):
    with pytest.raises(DataError, match="groups must be 'current', 'voltage' or one label per record"):
        Problem(MODEL, rec, groups="temperature")
    with pytest.raises(DataError, match="record 0 .* has no current"):
        Problem(MODEL, rec, groups="current")
    with pytest.raises(DataError, match=r"give one label per record \(2\); got 3"):
        Problem(MODEL, [rec, rec], groups=["a", "b", "c"])
    with pytest.raises(ModelError, match="per_group needs groups="):
        Problem(MODEL, rec, per_group=["c3"])
    with pytest.raises(ModelError, match=r"per_group parameter\(s\) \['k3'\] are not free"):
        Problem(MODEL, [rec, rec], groups=["a", "b"], per_group=["k3"])
    p = Problem(MODEL, [rec, rec.replace(current=0.5)], groups=["lo", "hi"], per_group=["c3"])
    assert p.slot_names == ("c1", "c2", "k1", "k2", "c3[lo]", "c3[hi]")
    assert p.slot_index(1) == [0, 1, 5, 2, 3]  # free order c1, c2, c3, k1, k2
    assert p.fixed_value(1, "A_f") == pytest.approx(np.max(np.abs(rec.y)))


def test_constraints_checked(rec):
    p = Problem(MODEL, rec, constraints=[({"k1": 1, "k2": 1}, 0, math.inf)])
    assert p.constraints == (({"k1": 1.0, "k2": 1.0}, 0.0, math.inf),)
    with pytest.raises(ModelError, match=r"constraints\[0\]: \['A_f'\] not free"):
        Problem(MODEL, rec, constraints=[({"A_f": 1}, 0, 1)])
    with pytest.raises(ModelError, match=r"constraints\[0\]: need finite coefficients and lower <= upper"):
        Problem(MODEL, rec, constraints=[({"k1": 1}, 2, 1)])
    with pytest.raises(ModelError, match=r"constraints\[0\] must be \(coefficients by name, lower, upper\)"):
        Problem(MODEL, rec, constraints=[({"k1": 1}, 0)])
