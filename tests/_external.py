"""Paths of the real third-party records (``../shared/data/external``) for the tests; skip when absent."""

from __future__ import annotations

from pathlib import Path

import pytest

from duffsym.data import external_data_dir
from duffsym.errors import DataError

DYKE_CSV = ("mr_damper_dyke_nees1996", "ranran_50_converted.csv")
#: the friction damper with linkage play (SOURCE.md there) and its four records
BRFD = "friction_damper_brfd_artslab"
BRFD_RECORDS = (
    "0.5Hz30lbtension1amplitude",
    "0.5Hz36lbtension1amplitude",
    "0.5Hz30lbtension0.5amplitude",
    "0.25Hz30lbtension1amplitude",
)


def external_file(*parts: str) -> Path:
    """The file under the external-data folder; the test is skipped (with why) when it is not there."""
    try:
        path = external_data_dir().joinpath(*parts)
    except DataError as exc:
        pytest.skip(f"external data not available: {exc}")
    if not path.is_file():
        pytest.skip(f"{path} not available")
    return path
