"""The one status vocabulary (duffsym.status): values are the strings the JSON contract carries."""

import json

from duffsym.simulate import STATUS_MESSAGES
from duffsym.status import MESSAGES, Status


def test_status_is_its_json_string():
    assert json.dumps({"s": Status.ACCEPTABLE}) == '{"s": "Solved_To_Acceptable_Level"}'
    assert Status.BLOW_UP == "blow-up" and str(Status.TOO_STIFF) == "too stiff"
    assert f"{Status.SOLVED}" == "Solve_Succeeded"


def test_simulation_statuses_are_members():
    assert {Status(v) for v in STATUS_MESSAGES.values()} == {Status.OK, Status.BLOW_UP, Status.TOO_STIFF}


def test_parse_and_flags():
    assert Status.parse("Restoration_Failed") is Status.RESTORATION_FAILED
    assert Status.parse("something IPOPT added later") is Status.UNKNOWN
    assert [s for s in Status if s.success] == [Status.SOLVED, Status.ACCEPTABLE, Status.RIDGE, Status.OK]
    assert Status.TIME_LIMIT.out_of_time and not Status.MAX_ITER.out_of_time
    assert "iteration limit" in Status.MAX_ITER.message
    assert Status.DIVERGING.message == "the run ended with status Diverging_Iterates"
    assert set(MESSAGES) <= set(Status)
