"""Measured and synthetic records: validation, loaders, synthetic data.

:class:`Record` is one validated, read-only experiment. Loaders: :func:`read_csv` (the CSV format
of ``docs/contract.md``), :func:`load_mr_damper_utfsm`, :func:`load_silverbox`; third-party data is
found through :func:`external_data_dir`. :func:`synthetic_record` simulates a record with known truth.
"""

from duffsym.data.loaders import (
    SILVERBOX_PARTS,
    UTFSM_VALIDATION_CURRENTS,
    external_data_dir,
    load_bouc_wen,
    load_mr_damper_utfsm,
    load_silverbox,
    parse_utfsm_name,
    read_csv,
    utfsm_sine_files,
    write_csv,
)
from duffsym.data.record import MIN_SAMPLES, Record, savgol_derivative, zero_crossings
from duffsym.data.synthetic import apply_backlash, synthetic_record

__all__ = [
    "Record",
    "read_csv",
    "write_csv",
    "load_mr_damper_utfsm",
    "load_silverbox",
    "external_data_dir",
    "utfsm_sine_files",
    "parse_utfsm_name",
    "synthetic_record",
    "apply_backlash",
    "savgol_derivative",
    "zero_crossings",
    "MIN_SAMPLES",
    "SILVERBOX_PARTS",
    "UTFSM_VALIDATION_CURRENTS",
    "load_bouc_wen",
]
