"""The data a fit runs on, as ``duffsym fit`` and ``duffsym validate`` prepare it from a measured record.

Two steps, both reported in one line and in FIT.json:

1. **Sanity** (:mod:`duffsym.data.sanity`): clipped and frozen stretches are left out of the fit and of
   its score (cut off at either end of the record, masked inside it), unless ``keep_invalid``.
2. **Decimation** (:mod:`duffsym.data.decimate`, the variance rule :func:`~duffsym.data.decimate.prepare_for_fit`):
   a record with more than ``DECIMATE_ABOVE`` samples is fitted at the lowest rate its spectrum allows;
   the fitted model is then also run on the record at its own rate (``decimation.nrmse_full_rate``).
   Smaller records are fitted as they are. ``decimate``: ``"auto"`` (this rule),
   ``"off"``, or an int capping the factor (also applied below the size threshold).

:func:`score_valid` gives a validation's error on the valid samples only; :func:`fit_extras` the FIT.json
keys ``training_ranges``, ``decimation`` and ``data_sanity``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from duffsym.data.decimate import Preparation, decimate_mask, prepare_for_fit
from duffsym.data.record import Record
from duffsym.data.sanity import ValidPart, training_ranges, valid_part

#: records with more fitting samples than this are decimated by default
DECIMATE_ABOVE = 4000


@dataclass(frozen=True)
class FitData:
    """``record``: what is fitted (valid part, decimated); ``full``: the valid part at its own rate;
    ``mask``: the samples of ``record`` out of the objective (None: none); ``valid``: the sanity check
    (None when ``keep_invalid``); ``prep``: the decimation (None when not decimated); ``invalid``: the
    invalid samples inside ``record`` (None: none)."""

    record: Record
    full: Record
    mask: np.ndarray | None
    valid: ValidPart | None
    prep: Preparation | None
    invalid: np.ndarray | None = None

    def notes(self) -> list[str]:
        """One line per step that changed the data."""
        out = []
        if self.valid is not None and not self.valid.report.ok:
            out.append(self.valid.report.summary() + "; left out of the fit and its score (--keep-invalid keeps them)")
        if self.prep is not None:
            out.append(self.prep.summary())
        return out


def _decimation(record: Record, decimate) -> tuple[Preparation | None, Record]:
    if decimate in ("off", False, 1, "1"):
        return None, record
    cap = True if decimate in ("auto", True, None) else int(decimate)
    if cap is True and record.n_times <= DECIMATE_ABOVE:
        return None, record
    if not record.is_uniform():
        return None, record
    prep, rec = prepare_for_fit(record, cap)
    return (prep if prep.factor > 1 else None), rec


def prepare_fit_data(record: Record, mask=None, *, keep_invalid: bool = False, decimate="auto") -> FitData:
    """The data to fit from ``record`` and a user mask (see the module docstring)."""
    valid = None if keep_invalid else valid_part(record)
    full = record if valid is None else valid.record
    m = None if mask is None else np.asarray(mask, dtype=bool)
    if valid is not None:
        m = valid.mask if m is None else (m[valid.start : valid.stop] | valid.mask)
        m = m if m.any() else None
    prep, rec = _decimation(full, decimate)
    inside = None if valid is None or not valid.mask.any() else valid.mask
    if prep is not None:
        m = decimate_mask(m, prep.factor, rec.n_times)
        inside = decimate_mask(inside, prep.factor, rec.n_times)
    return FitData(rec, full, m, valid, prep, inside)


def score_valid(val, record: Record, invalid: np.ndarray | None):
    """``val`` (a :class:`~duffsym.identify.ValidationResult` on ``record``) scored on the samples not in
    ``invalid``: nrmse, rmse and r2 replaced; unchanged when nothing is invalid or the run failed."""
    from duffsym.identify.result import nrmse

    if invalid is None or not np.any(invalid) or not val.success:
        return val
    keep = ~np.asarray(invalid, dtype=bool)
    y, y_sim = np.asarray(record.y)[keep], np.asarray(val.y_sim)[keep]
    err = nrmse(y, y_sim)
    rmse = float(np.sqrt(np.mean((y - y_sim) ** 2)))
    return dataclasses.replace(val, nrmse=err, rmse=rmse, r2=1 - err**2)


def full_rate_nrmse(result, data: FitData, model) -> float:
    """The fitted model's free-run NRMSE on the valid record at its own rate (inf when the run fails)."""
    from duffsym.identify.validation import validate

    val = score_valid(validate(result, data.full, model), data.full, None if data.valid is None else data.valid.mask)
    return float(val.nrmse) if val.success else math.inf


def fit_extras(result, data: FitData, model) -> dict:
    """The FIT.json keys ``training_ranges``, ``decimation`` (with ``nrmse_full_rate`` when decimated) and
    ``data_sanity`` (None when not checked) for a fit of ``data``."""
    dec = {"factor": 1, "rate_hz": 1.0 / data.full.dt, "reason": "not decimated"}
    if data.prep is not None:
        dec = {
            **data.prep.to_dict(),
            "rate_hz": data.prep.rate,
            "nrmse_full_rate": full_rate_nrmse(result, data, model),
        }
    return {
        "training_ranges": training_ranges([data.full]),
        "decimation": dec,
        "data_sanity": None if data.valid is None else data.valid.to_dict(),
    }


def finish_fit(result, data: FitData, model):
    """``result`` (a fit of ``data.record``) with its FIT.json extras, and its ``nrmse`` taken over the valid
    samples when invalid ones lie inside the record (the all-sample value kept in ``data_sanity``)."""
    from duffsym.identify.result import nrmse

    extras = fit_extras(result, data, model)
    if data.invalid is not None and result.y_sim and np.all(np.isfinite(result.y_sim[0])):
        keep = ~data.invalid
        err = nrmse(np.asarray(data.record.y)[keep], np.asarray(result.y_sim[0])[keep])
        extras["data_sanity"]["nrmse_all_samples"] = result.nrmse
        result = dataclasses.replace(result, nrmse=err, r2=1 - err**2)
    return result.with_extras(**extras)
