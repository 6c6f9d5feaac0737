"""Readers for measured data: the CSV format of ``docs/contract.md`` and the real third-party data sets.

Third-party data is never copied into the repository; loaders take a path, and
:func:`external_data_dir` finds the shared folder through one setting.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from duffsym.data.record import Record
from duffsym.errors import DataError

#: Roles of the CSV columns and the synonyms accepted for each (first = canonical file column name).
ROLES: dict[str, tuple[str, ...]] = {
    "time": ("time", "t"),
    "input": ("displacement", "input"),
    "output": ("force", "output"),
    "velocity": ("velocity",),
    "current": ("current",),
    "voltage": ("voltage",),
    "pressure": ("pressure",),
}
#: Names a user may use as keys of ``columns`` for each role.
ROLE_KEYS: dict[str, str] = {
    "time": "time",
    "t": "time",
    "input": "input",
    "displacement": "input",
    "d": "input",
    "output": "output",
    "force": "output",
    "y": "output",
    "velocity": "velocity",
    "d_dot": "velocity",
    "current": "current",
    "voltage": "voltage",
    "pressure": "pressure",
}
REQUIRED_ROLES = ("time", "input", "output")
#: Record field of each role, used for units.
_FIELD = {"time": "t", "input": "d", "output": "y", "velocity": "d_dot", "current": "current", "voltage": "voltage"}

ENV_EXTERNAL = "DUFFSYM_EXTERNAL_DATA"
_OBTAIN = (
    "set DUFFSYM_EXTERNAL_DATA to the folder holding mr_damper_utfsm_quiroz2022/ and silverbox/ "
    "(each has a SOURCE.md saying where the files come from), or place it at ../shared/data/external"
)


def external_data_dir() -> Path:
    """The folder of real third-party data (never committed to the repository).

    The environment variable ``DUFFSYM_EXTERNAL_DATA`` if set; otherwise the first existing of
    ``../shared/data/external`` relative to the current directory and relative to the repository.

    Raises
    ------
    DataError
        If the variable points to a missing folder, or no candidate exists; the message says how to
        obtain the data.
    """
    env = os.environ.get(ENV_EXTERNAL)
    if env:
        p = Path(env).expanduser()
        if not p.is_dir():
            raise DataError(f"{ENV_EXTERNAL}={env} is not a folder; {_OBTAIN}")
        return p
    repo = Path(__file__).resolve().parents[3]
    candidates = [Path.cwd() / ".." / "shared" / "data" / "external", repo / ".." / "shared" / "data" / "external"]
    for c in candidates:
        if c.is_dir():
            return c.resolve()
    tried = ", ".join(str(c) for c in candidates)
    raise DataError(f"external data folder not found (tried {tried}); {_OBTAIN}")


# ---------------------------------------------------------------------------- CSV
#: Most data rows a CSV record may hold (a fit of 10^6 samples already needs gigabytes).
MAX_ROWS = 5_000_000
SAMPLING_POLICIES = ("strict", "resample", "as-given")
_NUMBER = re.compile(r"^[-+]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|(?i:nan|inf|infinity))$", re.ASCII)
_DECIMAL_COMMA = re.compile(r"^[-+]?\d+,\d+$")


def _show(text, limit: int = 60) -> str:
    """``repr`` of ``text`` cut to about ``limit`` characters (a 5 MB "line" is never echoed whole)."""
    text = str(text)
    return repr(text) if len(text) <= limit else repr(text[:limit]) + f"... ({len(text)} characters)"


def _check_file(path: Path) -> bytes:
    """The first 8 kB of ``path``, after checking it is a regular, sized, non-empty UTF-8 text file."""
    from duffsym._io import check_input_file

    check_input_file(path)
    with path.open("rb") as fh:
        head = fh.read(8192)
    if head.startswith(b"\xef\xbb\xbf"):
        head = head[3:]
    if not head.strip():
        raise DataError(f"{path}: the file is empty; give a CSV with a header row and one row per sample")
    if b"\x00" in head:
        hint = " (UTF-16 text? save it as UTF-8)" if head[:2] in (b"\xff\xfe", b"\xfe\xff") else ""
        raise DataError(f"{path}: looks like a binary file (NUL bytes){hint}; give a text CSV with a header row")
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        # a multi-byte character cut at the 8 kB boundary is fine; anything earlier is not text
        if exc.start < len(head) - 4:
            line = head[: exc.start].count(b"\n") + 1
            raise DataError(f"{path}: row {line}: not UTF-8 text (byte {exc.start}); save the file as UTF-8") from None
    return head


def _resolve_columns(path: Path, header: list[str], columns: Mapping[str, str] | None) -> dict[str, int]:
    """Map each role to a column index of ``header``."""
    chosen: dict[str, str] = {}
    for key, col in (columns or {}).items():
        role = ROLE_KEYS.get(str(key).strip().lower())
        if role is None:
            raise DataError(
                f"{path}: unknown column role {key!r} in the column mapping; use one of "
                f"{{{', '.join(sorted(set(ROLE_KEYS)))}}}"
            )
        if role in chosen:
            raise DataError(f"{path}: role {role!r} mapped twice in the column mapping ({chosen[role]!r}, {col!r})")
        chosen[role] = str(col).strip()
    lower = {h.lower(): i for i, h in enumerate(header)}
    index: dict[str, int] = {}
    for role, synonyms in ROLES.items():
        if role in chosen:
            name = chosen[role]
            if name in header:
                index[role] = header.index(name)
            elif name.lower() in lower:
                index[role] = lower[name.lower()]
            else:
                raise DataError(
                    f"{path}: missing column {name!r} (for {role}); the file has {header}; "
                    "fix the header or the column mapping (e.g. --columns time=t,input=V1,output=V2)"
                )
            continue
        for syn in synonyms:
            if syn in lower:
                index[role] = lower[syn]
                break
        else:
            if role in REQUIRED_ROLES:
                raise DataError(
                    f"{path}: missing column {synonyms[0]!r} (the {role}); the file has {header}; "
                    f"rename it or map it (e.g. --columns {role}=YOUR_NAME)"
                )
    used: dict[int, str] = {}
    for role, i in index.items():
        if i in used:
            raise DataError(f"{path}: column {header[i]!r} used for both {used[i]} and {role}; map distinct columns")
        used[i] = role
    return index


def read_csv(
    path,
    columns: Mapping[str, str] | None = None,
    units: Mapping[str, str] | None = None,
    *,
    nan_policy: str = "raise",
    delimiter: str | None = None,
    sampling: str = "strict",
) -> Record:
    """Read a record from a CSV file with a header row (the format of ``docs/contract.md``).

    Parameters
    ----------
    path : the CSV file (UTF-8, with or without a byte-order mark).
    columns : role -> file column name, e.g. ``{"time": "t", "input": "V1", "output": "V2"}``.
        Roles: ``time``, ``input`` (synonym ``displacement``), ``output`` (synonym ``force``),
        ``velocity``, ``current``, ``voltage``. Unmapped roles use the default file columns
        ``time``, ``displacement`` (or ``input``), ``force`` (or ``output``), ``velocity``,
        ``current``, ``voltage`` (matched case-insensitively); the last three are optional.
    units : role -> unit text, stored in the record (``{"input": "mm", "output": "N"}``).
    nan_policy : ``"raise"`` or ``"omit"``; empty fields count as NaN.
    delimiter : field separator; sniffed from the header (``,`` ``;`` tab) when None.
    sampling : what to do with a time column that is not uniform: ``"strict"`` (default) accepts
        uniform steps and a uniform grid printed with rounding (rebuilt, see
        :func:`~duffsym.data.record.rebuild_rounded_grid`) and rejects anything else;
        ``"resample"`` interpolates every signal linearly onto a uniform grid at the median step;
        ``"as-given"`` keeps the stamps as they are. The record's ``metadata["sampling"]`` says
        what was done.

    Raises
    ------
    DataError
        One line naming the file and the problem: empty file, header only, binary or non-UTF-8
        file, missing, empty or duplicate column name, unparsable value or decimal comma (with its
        row and column), ragged row, non-uniform time, too many rows, or any :class:`Record`
        validation failure.
    """
    path = Path(path)
    if sampling not in SAMPLING_POLICIES:
        raise DataError(f"sampling must be one of {set(SAMPLING_POLICIES)}; got {sampling!r}")
    head = _check_file(path)
    if delimiter is None:
        first = head.decode("utf-8", errors="replace").splitlines()[0]
        delimiter = max([",", ";", "\t"], key=first.count) if any(c in first for c in ",;\t") else ","
    try:
        header, index, data = _read_table(path, columns, delimiter)
    except UnicodeDecodeError as exc:
        raise DataError(
            f"{path}: not UTF-8 text ({exc.reason} at byte {exc.start} of a row); save the file as UTF-8"
        ) from None
    arr = np.array(data, dtype=float)
    roles = list(index)
    sig = {r: arr[:, i] for i, r in enumerate(roles)}
    scalars, command = _command_columns(path, sig, header, index, nan_policy)
    unit_map = {}
    for key, u in (units or {}).items():
        role = ROLE_KEYS.get(str(key).strip().lower())
        if role is None or role not in _FIELD:
            raise DataError(f"unknown role {key!r} in units; use one of {{{', '.join(sorted(set(_FIELD)))}}}")
        unit_map[_FIELD[role]] = str(u)
    rec = Record(
        t=sig["time"],
        d=sig["input"],
        y=sig["output"],
        d_dot=sig.get("velocity"),
        current=scalars.get("current"),
        voltage=scalars.get("voltage"),
        units=unit_map,
        command=command[1] if command else None,
        command_name=command[0] if command else "",
        metadata={
            "columns": {r: header[i] for r, i in index.items()},
            "format": "csv",
            **({"sampling": {"keep_stamps": True}} if sampling == "as-given" else {}),
        },
        source=str(path),
        nan_policy=nan_policy,
    )
    return _apply_sampling(rec, sampling, path)


def _command_columns(path: Path, sig: dict, header: list[str], index: dict[str, int], nan_policy: str):
    """The constant current/voltage values and the varying command history ``(name, values)`` or None.

    A constant column is the record's ``current``/``voltage`` label; a varying one is its command history; a
    ``pressure`` column (a measured chamber pressure: a pneumatic seal's friction follows it) is always a history.
    NaN/inf in a command column is an error unless ``nan_policy="omit"`` (then those rows are dropped).
    """
    scalars: dict[str, float | None] = {}
    command = None
    present = [r for r in ("current", "voltage", "pressure") if r in sig]
    if len(present) >= 2:
        raise DataError(
            f"{path}: columns {[header[index[r]] for r in present]} are all commands ({', '.join(present)}); "
            "a record has one command: drop or rename all but one"
        )
    for r in present:
        col = sig[r]
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size and nan_policy != "omit":
            raise DataError(
                f"{path}: row {int(bad[0]) + 2}, column {header[index[r]]!r} ({r}): {bad.size} missing or non-finite "
                f"command value(s); fill them or drop those rows (--nan-policy omit)"
            )
        v = col[np.isfinite(col)]
        if v.size == 0:
            raise DataError(f"{path}: column {header[index[r]]!r} ({r}) holds no number; fill it or remove the column")
        if r == "pressure" or bad.size or np.ptp(v) > 1e-9 * max(1.0, float(np.max(np.abs(v)))):
            command = (r, col)
        else:
            scalars[r] = float(v[0])
    return scalars, command


def _read_table(path: Path, columns, delimiter: str) -> tuple[list[str], dict[str, int], list[list[float]]]:
    """Header, role -> column index and the numeric rows of the CSV, checked field by field."""
    with path.open("r", encoding="utf-8-sig", errors="strict", newline="") as fh:
        reader = csv.reader(fh, delimiter=delimiter)
        try:
            header, index = _read_header(path, reader, columns)
            return header, index, _read_rows(path, reader, header, index)
        except csv.Error as exc:
            raise DataError(
                f"{path}: row {max(reader.line_num, 1)}: not a readable CSV row ({_show(exc, 80)}); fix the "
                "row (an unclosed quote, a NUL byte, a field longer than 128 kB)"
            ) from None


def _read_header(path: Path, reader, columns) -> tuple[list[str], dict[str, int]]:
    header = next(reader, None)
    # a byte-order mark is read as one by utf-8-sig; a second one (files joined together) is stripped too
    header = [h.replace("\ufeff", "").strip().strip('"').strip() for h in (header or [])]
    while header and header[-1] == "":  # trailing delimiter, as in the Silverbox files
        header.pop()
    if not header:
        raise DataError(f"{path}: the file is empty; give a CSV with a header row and one row per sample")
    numeric_header = True
    for h in header:
        try:
            float(h)
        except ValueError:
            numeric_header = False
    if numeric_header:
        raise DataError(
            f"{path}: the first row {_show(header, 80)} is numeric, not a header; add a header row naming the "
            "columns (time,displacement,force)"
        )
    for j, h in enumerate(header):
        if h == "":
            raise DataError(f"{path}: row 1, column {j + 1}: the header has an empty column name; name every column")
    seen: dict[str, int] = {}
    for j, h in enumerate(header):
        if h.lower() in seen:
            raise DataError(
                f"{path}: row 1, columns {seen[h.lower()] + 1} and {j + 1}: duplicate column name "
                f"{_show(h)}; give every column its own name"
            )
        seen[h.lower()] = j
    return header, _resolve_columns(path, header, columns)


def _read_rows(path: Path, reader, header: list[str], index: dict[str, int]) -> list[list[float]]:
    cols = list(index.values())
    width = len(header)
    data: list[list[float]] = []
    for row in reader:
        line = reader.line_num
        if not row or all(not f.strip() for f in row):
            continue
        if len(row) == width + 1 and row[-1].strip() == "":
            row = row[:-1]  # trailing delimiter
        if len(row) != width:
            hint = ""
            if len(row) > width and any(_DECIMAL_COMMA.match(f"{a.strip()},{b.strip()}") for a, b in zip(row, row[1:])):
                hint = " (a decimal comma? use '.' as the decimal point)"
            raise DataError(
                f"{path}: row {line} has {len(row)} field(s) but the header has {width}{hint}; fix the row or remove it"
            )
        vals = []
        for c in cols:
            f = row[c].strip().strip('"').strip()
            if f == "":
                vals.append(math.nan)
                continue
            try:
                if not _NUMBER.match(f):  # float() also takes "1_000" and non-ASCII digits ("١٢" = 12)
                    raise ValueError
                vals.append(float(f))
            except ValueError:
                hint = (
                    "a decimal comma: use '.' as the decimal point"
                    if _DECIMAL_COMMA.match(f)
                    else ("fix the value (use '.' as decimal point) or remove the row")
                )
                raise DataError(
                    f"{path}: row {line}, column {header[c]!r}: cannot read {_show(f, 40)} as a number; {hint}"
                ) from None
        data.append(vals)
        if len(data) > MAX_ROWS:
            raise DataError(
                f"{path}: more than {MAX_ROWS} data rows; split or decimate the record (a fit of "
                "that many samples does not fit in memory)"
            )
    if not data:
        raise DataError(f"{path}: the file has a header but no data rows; add one row per sample")
    return data


def _apply_sampling(rec: Record, policy: str, path: Path) -> Record:
    """``rec`` as the ``sampling`` policy of :func:`read_csv` wants it (see there)."""
    info = dict(rec.metadata["sampling"])
    if info["uniform"] or policy == "as-given":
        return rec
    t = np.asarray(rec.t)
    steps = np.diff(t)
    dt = float(np.median(steps))
    whole = np.round(steps / dt)
    if policy == "strict" and np.all(np.abs(steps - whole * dt) <= 1e-6 * dt):
        # a uniform grid with missing samples (omitted NaN rows, dropped frames): the stamps are exact
        info["rule"] = (
            f"uniform grid at {dt:.9g} s ({1.0 / dt:.8g} Hz) with {int(np.sum(whole - 1))} missing "
            f"sample(s) in {int(np.sum(whole > 1))} gap(s), kept as given"
        )
        return rec.replace(metadata={**rec.metadata, "sampling": info})
    if policy == "strict":
        raise DataError(
            f"{path}: the time column is not uniformly sampled ({info['rule']}); resample it (--sampling resample: "
            "linear interpolation onto a uniform grid at the median step) or use the stamps as they are "
            "(--sampling as-given)"
        )
    n = int(math.floor((t[-1] - t[0]) / dt * (1 + 1e-12))) + 1
    grid = t[0] + np.arange(n) * dt

    def on(x):
        return None if x is None else np.interp(grid, t, np.asarray(x))

    info = {
        "rate_hz": 1.0 / dt,
        "dt": dt,
        "uniform": True,
        "rebuilt": True,
        "resampled": True,
        "rule": f"resampled (--sampling resample): {info['rule']}; signals interpolated linearly onto "
        f"t = {t[0]:.9g} + k * {dt:.9g} s ({1.0 / dt:.8g} Hz), {n} samples",
    }
    return rec.replace(
        t=grid,
        d=on(rec.d),
        y=on(rec.y),
        d_dot=on(rec.d_dot),
        command=on(rec.command),
        metadata={**rec.metadata, "sampling": info},
    )


def write_csv(record: Record, path) -> Path:
    """Write a record in the CSV format of ``docs/contract.md`` (time, displacement, velocity,
    force[, current/voltage])."""
    path = Path(path)
    cols = {"time": record.t, "displacement": record.d}
    if record.d_dot is not None:
        cols["velocity"] = record.d_dot
    cols["force"] = record.y
    if record.current is not None:
        cols["current"] = np.full(record.n_times, record.current)
    if record.voltage is not None:
        cols["voltage"] = np.full(record.n_times, record.voltage)
    if record.command is not None:
        cols[record.command_name] = record.command
    mat = np.column_stack(list(cols.values()))
    from duffsym._io import atomic_write

    with atomic_write(path) as fh:
        np.savetxt(fh, mat, delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return path


# ---------------------------------------------------------------------------- MR damper, UTFSM (Quiroz 2022)
_UTFSM_NAME = re.compile(r"^(?P<amp>\d+(?:x\d+)?)mm(?P<freq>\d+(?:x\d+)?)Hz(?P<cur>\d+(?:x\d+)?)A$")
#: Coil currents (A) of the force columns 2..6 of ``validacion.mat``.
UTFSM_VALIDATION_CURRENTS = (0.2, 0.4, 0.6, 0.8, 1.0)
UTFSM_VALIDATION_DT = 0.001
VELOCITY_CHOICES = ("file", "derive")


def _number(text: str) -> float:
    return float(text.replace("x", "."))


def parse_utfsm_name(name: str) -> dict[str, float]:
    """Amplitude (mm), frequency (Hz) and current (A) from a name such as ``25mm0x1Hz0x75A``."""
    m = _UTFSM_NAME.match(Path(name).stem)
    if not m:
        raise DataError(
            f"{name}: file name does not follow <amp>mm<freq>Hz<current>A (x = decimal point), e.g. 25mm0x1Hz0x75A.txt"
        )
    return {"amplitude_mm": _number(m["amp"]), "frequency_hz": _number(m["freq"]), "current_a": _number(m["cur"])}


def load_mr_damper_utfsm(path, *, current: float | None = None, velocity: str = "file") -> Record:
    """Read one test of the UTFSM MR damper data set (Quiroz 2022; see its SOURCE.md).

    Two kinds of file:

    - ``sinusoidal_preprocessed/<amp>mm<freq>Hz<current>A.txt``: whitespace-separated columns time (s),
      displacement (mm, mean removed), velocity (mm/s), force (N, mean removed); the nominal amplitude,
      frequency and the coil current come from the file name. The authors smoothed displacement and force
      with the same moving average (a tenth of the period) and took the velocity as a one-sided difference of
      the displacement, which lags by half a sample; ``velocity="derive"`` drops it and uses the record's
      centred Savitzky–Golay derivative instead.
    - ``earthquake_validation/validacion.mat``: variable ``data`` (64648, 6) at dt = 0.001 s: column 1 the
      common displacement (mm), columns 2..6 the force (N) at 0.2, 0.4, 0.6, 0.8 and 1.0 A, all smoothed by a
      0.3 s moving average. There is no time or velocity column: time is ``k * 0.001`` s and the velocity is
      derived. ``current`` selects the force column and is required.

    Parameters
    ----------
    path : one of the files above.
    current : coil current (A) for the ``.mat`` file; one of 0.2, 0.4, 0.6, 0.8, 1.0.
    velocity : ``"file"`` (use the file's velocity column) or ``"derive"``.

    Raises
    ------
    DataError
        A missing or unreadable file, a name that does not follow the pattern, an unknown current.
    """
    path = Path(path)
    if velocity not in VELOCITY_CHOICES:
        raise DataError(f"velocity must be one of {set(VELOCITY_CHOICES)}; got {velocity!r}")
    if not path.is_file():
        raise DataError(f"{path}: no such file; get the UTFSM MR damper data ({_OBTAIN})")
    units = {"t": "s", "d": "mm", "d_dot": "mm/s", "y": "N"}
    if path.suffix.lower() == ".mat":
        from scipy.io import loadmat

        try:
            mat = loadmat(str(path))
        except Exception as exc:  # noqa: BLE001 — scipy raises several types for a bad file
            raise DataError(f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc})") from None
        if "data" not in mat or np.ndim(mat["data"]) != 2 or mat["data"].shape[1] != 6:
            raise DataError(f"{path}: expected a variable 'data' of shape (n, 6) (displacement + 5 forces)")
        if current is None or not any(abs(float(current) - c) < 1e-9 for c in UTFSM_VALIDATION_CURRENTS):
            raise DataError(
                f"{path}: give current= one of {UTFSM_VALIDATION_CURRENTS} A to choose the force column; got {current}"
            )
        j = 1 + [abs(float(current) - c) < 1e-9 for c in UTFSM_VALIDATION_CURRENTS].index(True)
        data = np.asarray(mat["data"], dtype=float)
        t = np.asarray(np.arange(data.shape[0]) * UTFSM_VALIDATION_DT, dtype=np.float64)
        return Record(
            t=t,
            d=data[:, 0],
            y=data[:, j],
            current=float(current),
            units=units,
            metadata={
                "dataset": "mr_damper_utfsm_quiroz2022",
                "kind": "earthquake",
                "column": j,
                "smoothing": "0.3 s moving average on displacement and force (authors' preprocessing)",
            },
            source=str(path),
            name=f"validacion_{float(current):g}A",
        )
    info = parse_utfsm_name(path.name)
    if current is not None and abs(float(current) - info["current_a"]) > 1e-9:
        raise DataError(f"{path}: the file name says {info['current_a']:g} A but current={current} was given")
    try:
        raw = np.loadtxt(path, ndmin=2)
    except ValueError as exc:
        raise DataError(
            f"{path}: cannot read the numeric columns ({exc}); expected time, displacement, velocity, "
            "force separated by spaces"
        ) from None
    if raw.shape[1] != 4:
        raise DataError(f"{path}: expected 4 columns (time, displacement, velocity, force); found {raw.shape[1]}")
    return Record(
        t=raw[:, 0],
        d=raw[:, 1],
        y=raw[:, 3],
        d_dot=raw[:, 2] if velocity == "file" else None,
        current=info["current_a"],
        units=units,
        metadata={
            "dataset": "mr_damper_utfsm_quiroz2022",
            "kind": "sine",
            **info,
            "velocity": "file: one-sided difference of d (half-sample lag)"
            if velocity == "file"
            else "derived: centred Savitzky-Golay",
        },
        source=str(path),
    )


def utfsm_sine_files(folder=None) -> list[Path]:
    """The 30 ``sinusoidal_preprocessed`` files, sorted (default folder: under :func:`external_data_dir`)."""
    folder = (
        Path(folder)
        if folder is not None
        else (external_data_dir() / "mr_damper_utfsm_quiroz2022" / "sinusoidal_preprocessed")
    )
    files = sorted(p for p in folder.glob("*.txt") if _UTFSM_NAME.match(p.stem))
    if not files:
        raise DataError(f"{folder}: no <amp>mm<freq>Hz<current>A.txt files; {_OBTAIN}")
    return files


# ---------------------------------------------------------------------------- Silverbox
SILVERBOX_FS = 1e7 / 2**14
#: Official split of SNLS80mV (0-based, half-open rows), from the nonlinear_benchmarks loader.
SILVERBOX_PARTS: dict[str, tuple[int, int]] = {
    "arrow_full": (100, 40575),
    "arrow_no_extrapolation": (100, 32100),
    "multisine_train": (40650, 40650 + 65062),
    "multisine_test": (127400 - 21688, 127400),
}


def load_silverbox(path, *, part: str | None = None) -> Record:
    """Read the Silverbox benchmark (input V1 -> ``d``, output V2 -> ``y``, volts).

    Parameters
    ----------
    path : ``SNLS80mV.csv`` or ``Schroeder80mV.csv`` (header row, columns ``V1``, ``V2``).
    part : a part of the official split of ``SNLS80mV.csv``: one of ``SILVERBOX_PARTS``
        (``arrow_full``, ``arrow_no_extrapolation``, ``multisine_train``, ``multisine_test``),
        or None for the whole file. Time is ``k / fs`` with fs = 1e7/2**14 Hz, k the file row.
    """
    path = Path(path)
    if part is not None and part not in SILVERBOX_PARTS:
        raise DataError(f"part must be one of {{{', '.join(SILVERBOX_PARTS)}}} or None; got {part!r}")
    _check_file(path)
    with path.open() as fh:
        header = [h.strip().strip('"') for h in fh.readline().split(",")]
    if "V1" not in header or "V2" not in header:
        raise DataError(f"{path}: missing column 'V1' or 'V2' (header {header}); give a Silverbox CSV file")
    cols = (header.index("V1"), header.index("V2"))
    arr = np.loadtxt(path, delimiter=",", skiprows=1, usecols=cols, ndmin=2)
    k = np.arange(arr.shape[0])
    if part is not None:
        a, b = SILVERBOX_PARTS[part]
        arr, k = arr[a:b], k[a:b]
    return Record(
        t=k / SILVERBOX_FS,
        d=arr[:, 0],
        y=arr[:, 1],
        units={"t": "s", "d": "V", "y": "V"},
        metadata={"dataset": "silverbox", "part": part, "fs": SILVERBOX_FS, "first_row": int(k[0])},
        source=str(path),
        name=f"{path.stem}" + (f"[{part}]" if part else ""),
    )


# ---------------------------------------------------------------------------- Bouc-Wen
BOUC_WEN_FS = 750.0
#: (file, group) of each part of the Bouc-Wen hysteretic benchmark (HDF5 files of forgi86/dynonet).
BOUC_WEN_PARTS: dict[str, tuple[str, str]] = {
    "train": ("train.h5", "multisine"),
    "multisine": ("test.h5", "multisine"),
    "sinesweep": ("test.h5", "sinesweep"),
}


def load_bouc_wen(folder=None, *, part: str = "multisine", unit: str = "m") -> Record:
    """A part of the Bouc-Wen hysteretic benchmark: input force u [N] -> ``d``, output displacement -> ``y``.

    Parameters
    ----------
    folder : the folder holding ``train.h5`` and ``test.h5`` (default ``external_data_dir()/bouc_wen_benchmark``).
    part : ``"train"`` (the generated 5-period training multisine), ``"multisine"`` or ``"sinesweep"``
        (the official validation signals).
    unit : the output's unit, ``"m"`` (as stored) or ``"mm"`` (scaled by 1e3: O(1) numbers for the fit).
    Needs ``h5py``.
    """
    if part not in BOUC_WEN_PARTS:
        raise DataError(f"part must be one of {{{', '.join(BOUC_WEN_PARTS)}}}; got {part!r}")
    if unit not in ("m", "mm"):
        raise DataError(f"unit must be 'm' or 'mm'; got {unit!r}")
    folder = Path(folder) if folder is not None else external_data_dir() / "bouc_wen_benchmark"
    name, group = BOUC_WEN_PARTS[part]
    path = folder / name
    from duffsym._io import check_input_file

    check_input_file(path, what="Bouc-Wen HDF5 file")
    try:
        import h5py
    except ImportError:  # pragma: no cover - h5py is a dependency
        raise DataError(f"{path}: reading HDF5 needs h5py; pip install h5py") from None
    try:
        with h5py.File(path, "r") as h:
            u = np.asarray(h[group]["u"], dtype=float).reshape(-1)
            y = np.asarray(h[group]["y"], dtype=float).reshape(-1)
    except (OSError, KeyError) as exc:
        raise DataError(
            f"{path}: not a Bouc-Wen benchmark file with group {group!r} ({exc}); get it as its SOURCE.md says"
        ) from None
    scale = 1e3 if unit == "mm" else 1.0
    k = np.arange(u.size)
    return Record(
        t=k / BOUC_WEN_FS,
        d=u,
        y=y * scale,
        units={"t": "s", "d": "N", "y": unit},
        metadata={"dataset": "bouc_wen", "part": part, "fs": BOUC_WEN_FS},
        source=str(path),
        name=f"bouc_wen[{part}]",
    )


# ---------------------------------------------------------------------------- friction damper (JSON)
#: Columns of the BRFD friction damper's JSON ``data`` rows (ARTS Lab, SOURCE.md of friction_damper_brfd_artslab).
BRFD_COLUMNS = ("time", "displacement", "friction force", "velocity", "actuator force 1", "actuator force 2")


def load_friction_damper_json(path) -> Record:
    """A record from the friction damper's JSON (``data`` rows: time s, displacement in, friction force kip,
    velocity in/s, two actuator forces lb; ``dt``): displacement -> ``d``, friction force -> ``y``, the file's
    velocity -> ``d_dot``. One-line :class:`DataError` on a file that is not of this layout.
    ``duffsym diagnose``/``ladder``/``fit`` read such a file directly (a ``.json`` data argument)."""
    import json

    path = Path(path)
    _check_file(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DataError(f"{path}: not a JSON record ({exc}); give the friction damper's JSON or a CSV") from None
    rows = doc.get("data") if isinstance(doc, dict) else None
    try:
        arr = np.asarray(rows, dtype=float)
    except (TypeError, ValueError):
        arr = np.empty((0, 0))
    if arr.ndim != 2 or arr.shape[0] < 2 or arr.shape[1] < 4:
        raise DataError(
            f"{path}: expected a JSON object whose 'data' is a list of rows [time, displacement, "
            "friction force, velocity, ...]; give the friction damper's JSON or a CSV"
        )
    units = {
        "t": str(doc.get("time units", "s")),
        "d": str(doc.get("displacement units", "")),
        "y": str(doc.get("friction force units", "")),
    }
    return Record(
        t=arr[:, 0],
        d=arr[:, 1],
        y=arr[:, 2],
        d_dot=arr[:, 3],
        units={k: v for k, v in units.items() if v},
        metadata={
            "dataset": "friction_damper_brfd_artslab",
            "format": "json",
            "columns": dict(zip(("time", "input", "output", "velocity"), BRFD_COLUMNS)),
        },
        source=str(path),
        name=path.stem,
    )
