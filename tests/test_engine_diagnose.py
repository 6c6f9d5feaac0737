"""The diagnosis on an engine's workers computes what it computes in one process, bit for bit (issue 23's speed
for device records): the base fit here while the plain-fit reference runs on a worker, and discovery's term sets
fitted at the same time. The record is the independent RK4 one of ``test_diagnose_discover`` (no duffsym import in
its making): the MR damper of Eq. 12 with a piston seal friction on the measured force, 1 % noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from duffsym.engine import Engine


def _fail(text: str, *, twice: bool) -> float:
    return 2 * float(text) if twice else float(text)


@pytest.mark.parametrize("workers", [0, 1])
def test_submit_returns_the_value_or_raises_the_error(workers):
    with Engine(workers) as engine:
        assert engine.submit(math.sqrt, 6.25).result() == 2.5
        assert engine.submit(_fail, "1.5", twice=True).result() == 3.0
        with pytest.raises(ValueError, match="could not convert"):
            engine.submit(_fail, "not a number", twice=False).result()


@pytest.fixture(scope="module")
def seal_record():
    from test_diagnose_discover import _record

    return _record(n=800)[0]


def test_diagnosis_and_discovery_on_workers_equal_one_process(seal_record):
    from duffsym.diagnose import diagnose
    from duffsym.diagnose.discover import discover_term, on_engine
    from duffsym.model import get_model

    model = get_model("mr-damper")
    kw = dict(candidates=["force-offset", "inertia"], sindy=False)
    here = diagnose(seal_record, model, **kw)
    with Engine(2) as engine:
        there = diagnose(seal_record, model, engine=engine, **kw)
        assert there.base_check.reference == "a plain fit of the record"
        said_there: list[str] = []
        with on_engine(engine):
            found_there = discover_term(seal_record, model, here, progress=said_there.append)
    assert dict(there.base_fit.params) == dict(here.base_fit.params)
    assert there.base_check == here.base_check
    assert [(c.effect, c.nrmse_after, c.params) for c in there.candidates] == [
        (c.effect, c.nrmse_after, c.params) for c in here.candidates
    ]
    assert there.verdict == here.verdict
    found_here = discover_term(seal_record, model, here)
    # several term sets were fitted (the engine's path), and the same one won with the same numbers
    on_workers = [m for m in said_there if " term sets on Engine" in m]
    assert on_workers and int(on_workers[0].split()[1]) >= 2, said_there
    assert found_there.effect == found_here.effect
    assert found_there.nrmse_after == found_here.nrmse_after and np.isfinite(found_here.nrmse_after)
