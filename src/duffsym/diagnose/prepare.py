"""Decimation of a diagnosis's fitting data: the rule and the filter live in :mod:`duffsym.data.decimate`
(moved there so that ``fit`` can use them too); this module re-exports them for the diagnosis."""

from duffsym.data.decimate import (  # noqa: F401
    FLOOR_FACTOR,
    MIN_PER_CYCLE,
    MIN_SAMPLES,
    OVERSAMPLE,
    REL,
    Preparation,
    bandwidth,
    choose_decimation,
    decimate_mask,
    decimate_record,
    prepare_record,
)
