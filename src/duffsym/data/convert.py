"""Records from the files people have: whitespace-separated text, CSV with any column names, MATLAB ``.mat``.

:func:`read_table` reads one of them into a validated :class:`~duffsym.data.Record`, choosing the
columns by position (1-based) or by header name; :func:`convert` also writes the record in the
CSV format of the contract (``docs/contract.md``: time, displacement, velocity, force), which every
command reads. ``duffsym convert`` is the command line of it.

Examples of files it reads (both ship in ``data/``):

- the UTFSM MR damper's ``.txt`` (no header; time, displacement, velocity, force):
  ``columns={"time": "1", "displacement": "2", "velocity": "3", "force": "4"}``;
- a ``.mat`` matrix ``data`` with displacement and force and no time column:
  ``fmt="mat", variable="data", columns={"displacement": "1", "force": "2"}, dt=0.005``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from duffsym.data.loaders import ROLE_KEYS, write_csv
from duffsym.data.record import Record
from duffsym.errors import DataError

FORMATS = ("txt", "csv", "mat")
_SUFFIX = {".txt": "txt", ".dat": "txt", ".asc": "txt", ".csv": "csv", ".mat": "mat"}
_COMMENT = ("#", "%", "//")


def guess_format(path: Path) -> str:
    """``txt``, ``csv`` or ``mat`` from the file's suffix."""
    fmt = _SUFFIX.get(path.suffix.lower())
    if fmt is None:
        raise DataError(
            f"{path}: cannot tell the format from the suffix {path.suffix!r}; give --format {'|'.join(FORMATS)}"
        )
    return fmt


def _split(line: str, fmt: str) -> list[str]:
    if fmt == "txt":
        return line.split()
    delim = max([",", ";", "\t"], key=line.count)
    return [f.strip().strip('"') for f in line.rstrip("\n").split(delim)]


def _number(text: str) -> float | None:
    if text == "":
        return math.nan
    try:
        return float(text)
    except ValueError:
        return None


def _read_text(path: Path, fmt: str) -> tuple[list[str] | None, np.ndarray, dict[int, tuple[int, str]]]:
    """(header or None, numeric matrix, {column: (line, text)} of the first field that is not a number in
    each column that has one); comment lines (# % //) and blank lines skipped. A column of text (an ISO
    date-time, a label) is NaN in the matrix: it is an error only if it is selected (:func:`read_table`)."""
    try:
        lines = path.read_text(encoding="utf-8", errors="strict").splitlines()
    except UnicodeDecodeError as exc:
        raise DataError(f"{path}: not UTF-8 text (byte {exc.start}); give a text file or --format mat") from None
    header: list[str] | None = None
    rows: list[list[float]] = []
    text_cols: dict[int, tuple[int, str]] = {}
    for number, line in enumerate(lines, start=1):
        text = line.strip()
        if not text or text.startswith(_COMMENT):
            continue
        fields = _split(text, fmt)
        while fields and fields[-1] == "":
            fields.pop()
        values = [_number(f) for f in fields]
        bad = [j for j, v in enumerate(values) if v is None]
        if bad and header is None and not rows and 2 * len(bad) > len(values):
            header = fields
            continue
        if bad and len(bad) == len(values):
            raise DataError(
                f"{path}: line {number}: cannot read {text[:60]!r} as numbers; fix or remove the "
                "line (comment lines start with # or %)"
            )
        for j in bad:
            text_cols.setdefault(j, (number, fields[j]))
        rows.append([math.nan if v is None else v for v in values])
        if len(rows[-1]) != len(rows[0]):
            raise DataError(
                f"{path}: line {number} has {len(rows[-1])} fields, the first data line "
                f"{len(rows[0])}; fix the row or remove it"
            )
    if not rows:
        raise DataError(f"{path}: no numeric rows; give a file with one row of numbers per sample")
    return header, np.array(rows, dtype=float), text_cols


def _read_mat(path: Path, variable: str | None) -> np.ndarray:
    from scipy.io import loadmat

    try:
        mat = loadmat(str(path))
    except Exception as exc:  # noqa: BLE001 — scipy raises several types for a bad or v7.3 (HDF5) file
        raise DataError(
            f"{path}: not a readable MATLAB v4-v7.2 file ({type(exc).__name__}: {exc}); save it with "
            "save(..., '-v7') or export a text file"
        ) from None
    arrays = {
        k: v
        for k, v in mat.items()
        if not k.startswith("__") and isinstance(v, np.ndarray) and v.dtype.kind in "fiu" and v.ndim == 2
    }
    if variable is None:
        if len(arrays) != 1:
            raise DataError(f"{path}: give --variable, one of {sorted(arrays) or 'none (no numeric matrix found)'}")
        variable = next(iter(arrays))
    if variable not in arrays:
        raise DataError(f"{path}: no numeric matrix {variable!r}; the file has {sorted(arrays)}")
    data = np.asarray(arrays[variable], dtype=float)
    return data.T if data.shape[0] < data.shape[1] else data


def _column(path: Path, spec: str, role: str, header: list[str] | None, n_cols: int) -> int:
    """0-based index of ``spec``: a 1-based position or a header name."""
    spec = spec.strip()
    if spec.isdigit():
        k = int(spec)
        if not 1 <= k <= n_cols:
            raise DataError(
                f"{path}: column {k} for {role} is out of range; the file has {n_cols} columns (positions count from 1)"
            )
        return k - 1
    names = [h.strip().strip('"') for h in header or []]
    lower = [h.lower() for h in names]
    if spec.lower() in lower:
        return lower.index(spec.lower())
    where = f"its header is {names}" if names else "it has no header row"
    raise DataError(f"{path}: no column {spec!r} for {role}; {where}: give a position (e.g. {role}=2)")


def _roles(path: Path, columns: Mapping[str, str]) -> dict[str, str]:
    out: dict[str, str] = {}
    for key, spec in columns.items():
        role = ROLE_KEYS.get(str(key).strip().lower())
        if role is None:
            raise DataError(
                f"{path}: unknown role {key!r} in --columns; use time, displacement (input), force (output), velocity"
            )
        if role in ("current", "voltage"):
            raise DataError(f"{path}: give the coil {role} of the test as --{role} VALUE, not as a column")
        if role in out:
            raise DataError(f"{path}: role {role!r} given twice in --columns")
        out[role] = str(spec)
    return out


def read_table(
    path,
    *,
    fmt: str | None = None,
    columns: Mapping[str, str],
    dt: float | None = None,
    variable: str | None = None,
    current: float | None = None,
    voltage: float | None = None,
) -> Record:
    """A record from a text, CSV or ``.mat`` file with columns chosen by position or name.

    Parameters
    ----------
    path : the file.
    fmt : ``"txt"`` (whitespace-separated), ``"csv"`` (``,`` ``;`` or tab) or ``"mat"``; default from the suffix.
    columns : role -> column: a 1-based position (``"2"``) or a header name. Roles: ``time``,
        ``displacement`` (``input``), ``force`` (``output``), ``velocity`` (optional).
    dt : sampling step, s, when there is no time column (time = k * dt).
    variable : the matrix of a ``.mat`` file (default: its only numeric matrix).
    current, voltage : the test's constant coil setting, if known.

    Raises
    ------
    DataError
        One line naming the file and the problem (format, column, row), and what to do.
    """
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file; check the path")
    fmt = fmt or guess_format(path)
    if fmt not in FORMATS:
        raise DataError(f"{path}: unknown format {fmt!r}; choose one of {', '.join(FORMATS)}")
    roles = _roles(path, columns)
    for need in ("input", "output"):
        if need not in roles:
            raise DataError(
                f"{path}: --columns must name the {'displacement' if need == 'input' else 'force'} "
                f"column (e.g. --columns time=1,displacement=2,force=3)"
            )
    header, data, text_cols = (None, _read_mat(path, variable), {}) if fmt == "mat" else _read_text(path, fmt)
    index = {role: _column(path, spec, role, header, data.shape[1]) for role, spec in roles.items()}
    for role, j in index.items():
        if j in text_cols:
            line, field = text_cols[j]
            raise DataError(
                f"{path}: line {line}: cannot read {field[:40]!r} in the {role} column ({j + 1}) as a "
                "number; fix the column" + (" or give --dt SECONDS instead of a time column" if role == "time" else "")
            )
    if "time" in index:
        if dt is not None:
            raise DataError(f"{path}: give either a time column or --dt, not both")
        t = data[:, index["time"]]
    elif dt is None or not (math.isfinite(dt) and dt > 0):
        raise DataError(f"{path}: no time column; give --dt SECONDS (a positive sampling step) or map time=N")
    else:
        t = np.arange(data.shape[0]) * float(dt)
    return Record(
        t=t,
        d=data[:, index["input"]],
        y=data[:, index["output"]],
        d_dot=data[:, index["velocity"]] if "velocity" in index else None,
        current=current,
        voltage=voltage,
        source=str(path),
        metadata={"format": fmt, "columns": {r: i + 1 for r, i in index.items()}},
    )


def convert(path, out, **options) -> Record:
    """Read ``path`` with :func:`read_table` (``options``) and write it to ``out`` in the contract's CSV."""
    record = read_table(path, **options)
    write_csv(record, out)  # atomic: temporary file and rename
    return record
