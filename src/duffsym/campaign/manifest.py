"""What a batch runs: records from a folder, a glob or a manifest, each with the options of its command.

A manifest (CSV with a header, or JSON: a list of objects or ``{"records": [...]}``) has one entry
per record with the fields

- ``file`` (required): the record, a CSV file; relative paths are relative to the manifest's folder;
- ``name``: the record's name in the results (default: the file name without suffix);
- ``columns``: the column mapping (``time=t,input=V1,output=V2``, or an object in JSON);
- ``model``, ``effects`` (comma-separated or a JSON list): the model and the effects to add;
- ``fit``: a FIT.json (``validate``, ``sample``, ``diagnose``), or a folder holding ``<name>.json``
  (the results folder of a ``batch --command fit``);
- ``options``: further options of the command, as on its command line (``--starts 3 --seed 1``) or,
  in JSON, an object (``{"starts": 3, "fix": ["k3=0"]}``).

Every other field is a label carried to the summary (e.g. ``current``, ``amplitude``, ``frequency``:
the summary figure plots the parameters against them).
"""

from __future__ import annotations

import csv
import glob
import hashlib
import json
import re
import shlex
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from duffsym.errors import DataError

COMMANDS = ("fit", "validate", "diagnose", "ladder", "sample")
KNOWN_FIELDS = ("file", "name", "columns", "model", "effects", "fit", "options")
#: Options the batch sets itself: results go to the batch's folder, the output is its JSON.
RESERVED = ("--out", "--json", "--quiet", "--report", "--plot", "--chains", "--corner", "--bands", "--fit")
#: Commands whose saved fit is a required input, and those for which it is optional.
NEEDS_FIT = ("validate", "sample")
TAKES_FIT = ("validate", "sample", "diagnose")


@dataclass(frozen=True)
class Job:
    """One record of a batch: its input files, the command-line options of its command and its labels."""

    name: str
    data: Path
    fit: Path | None = None
    argv: tuple[str, ...] = ()
    labels: dict = field(default_factory=dict)

    def input_hash(self, command: str) -> str:
        """SHA-256 of the duffsym version, the command, the options and the bytes of every input file.

        The version is part of it: a result computed by another release is recomputed, not reused.
        """
        from duffsym import __version__

        h = hashlib.sha256()
        h.update(
            json.dumps({"duffsym": __version__, "command": command, "argv": list(self.argv)}, sort_keys=True).encode()
        )
        for path in (self.data, self.fit):
            if path is not None:
                h.update(b"\0file\0")
                h.update(path.read_bytes())
        return h.hexdigest()


def _options_argv(options: Any, where: str) -> list[str]:
    """Options as a command line: a string (split as a shell does) or a mapping ``{name: value}``."""
    if options is None or options == "":
        return []
    if isinstance(options, str):
        try:
            return shlex.split(options)
        except ValueError as exc:
            raise DataError(f"{where}: options {options!r}: {exc}; quote values as on a command line") from None
    if isinstance(options, (list, tuple)):
        return [str(o) for o in options]
    if isinstance(options, Mapping):
        out: list[str] = []
        for key, value in options.items():
            flag = "--" + str(key).lstrip("-").replace("_", "-")
            if value is True:
                out.append(flag)
            elif value is False or value is None:
                continue
            elif isinstance(value, (list, tuple)):
                for v in value:
                    out += [flag, str(v)]
            else:
                out += [flag, str(value)]
        return out
    raise DataError(
        f"{where}: options must be a string (as on the command line) or an object; got {type(options).__name__}"
    )


def _check_reserved(argv: list[str], where: str) -> None:
    for a in argv:
        flag = a.split("=", 1)[0]
        if flag in RESERVED:
            raise DataError(
                f"{where}: option {flag} is set by the batch (results go to --out DIR as JSON; a fit is "
                "given with the manifest's 'fit' field or batch --fit); remove it"
            )


def _joined(value: Any) -> str:
    if isinstance(value, Mapping):
        return ",".join(f"{k}={v}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return ",".join(str(v) for v in value)
    return str(value)


def _label(value: Any) -> Any:
    """A manifest label as a number when it reads as one."""
    if isinstance(value, str):
        try:
            return float(value) if value.strip() else None
        except ValueError:
            return value
    return value


#: Names of the batch's own outputs (``summary.json``, ``summary.csv``, ``summary.png``): a record of such a
#: name gets a ``record_`` prefix, so that its ``<name>.json`` cannot be overwritten by the summary.
RESERVED_NAMES = ("summary",)


def _safe_name(name: str) -> str:
    safe = re.sub(r"[^A-Za-z0-9._+=@-]+", "_", name).strip("._") or "record"
    return f"record_{safe}" if safe.lower() in RESERVED_NAMES else safe


def _resolve_fit(fit: Path | None, name: str, where: str) -> Path | None:
    if fit is None:
        return None
    if fit.is_dir():
        fit = fit / f"{name}.json"
    if not fit.is_file():
        raise DataError(
            f"{where}: fit {fit} not found; give a FIT.json or the folder of a batch fit run (holding <record>.json)"
        )
    return fit


def read_manifest(path) -> list[dict]:
    """The entries of a manifest (CSV or JSON) as dictionaries, checked for a ``file`` field."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"--manifest {path}: no such file; give a CSV or JSON manifest (see duffsym batch --help)")
    text = path.read_text(encoding="utf-8", errors="replace")
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise DataError(f'{path}: not valid JSON ({exc}); give a list of records or {{"records": [...]}}') from None
        entries = data.get("records") if isinstance(data, dict) else data
        if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
            raise DataError(f'{path}: a JSON manifest is a list of objects (or {{"records": [...]}}), one per record')
    else:
        rows = list(csv.DictReader(text.splitlines()))
        entries = [{k.strip(): (v or "").strip() for k, v in row.items() if k} for row in rows]
    if not entries:
        raise DataError(f"{path}: the manifest lists no records; add one line per record (columns file, ...)")
    for i, e in enumerate(entries):
        if not e.get("file"):
            raise DataError(f"{path}: record {i + 1} has no 'file'; every record needs the path of its CSV file")
    return entries


def _from_inputs(inputs: Iterable) -> list[Path]:
    files: list[Path] = []
    for item in inputs:
        p = Path(item)
        if p.is_dir():
            found = sorted(p.glob("*.csv"))
            if not found:
                raise DataError(f"{p}: the folder holds no .csv file; give CSV records, a glob or --manifest")
            files += found
        elif p.is_file():
            files.append(p)
        elif any(c in str(item) for c in "*?["):
            found = sorted(Path(f) for f in glob.glob(str(item)) if Path(f).is_file())
            if not found:
                raise DataError(f"{item}: the pattern matches no file; check the glob")
            files += found
        else:
            raise DataError(f"{item}: no such file or folder; give CSV files, folders, globs or --manifest")
    return files


def collect_jobs(
    inputs: Iterable = (), *, command: str = "fit", manifest=None, fit=None, options: Any = None
) -> list[Job]:
    """The jobs of a batch, from input paths (files, folders of ``*.csv``, globs) and/or a manifest.

    Parameters
    ----------
    inputs : CSV files, folders (their ``*.csv``) and glob patterns.
    command : one of ``COMMANDS``.
    manifest : a CSV or JSON manifest (see the module docstring).
    fit : a FIT.json for every record, or a folder of ``<name>.json`` fits (e.g. a batch fit's results).
    options : options given to every record (a command line string, a list or a mapping), before the
        manifest's own.

    Raises
    ------
    DataError
        No record, an unknown command, a missing file or fit, a reserved option, two records of one name.
    """
    if command not in COMMANDS:
        raise DataError(f"command must be one of {{{', '.join(COMMANDS)}}}; got {command!r}")
    common = _options_argv(options, "--options")
    _check_reserved(common, "--options")
    fit_all = Path(fit) if fit is not None else None
    if fit_all is not None and not fit_all.exists():
        raise DataError(f"--fit {fit_all}: no such file or folder")
    jobs: list[Job] = []
    for f in _from_inputs(inputs):
        jobs.append(Job(name=_safe_name(f.stem), data=f, argv=tuple(common)))
    if manifest is not None:
        mpath = Path(manifest)
        base = mpath.parent
        for i, e in enumerate(read_manifest(mpath)):
            where = f"{mpath} record {i + 1}"
            data = Path(str(e["file"]))
            data = data if data.is_absolute() else base / data
            if not data.is_file():
                raise DataError(f"{where}: file {data} not found; paths are relative to the manifest's folder")
            argv = list(common)
            for key, flag in (("model", "--model"), ("effects", "--add"), ("columns", "--columns")):
                if e.get(key) not in (None, "", [], {}):
                    argv += [flag, _joined(e[key])]
            own = _options_argv(e.get("options"), where)
            _check_reserved(own, where)
            argv += own
            fit_path = e.get("fit") or None
            if fit_path is not None:
                fit_path = Path(str(fit_path))
                fit_path = fit_path if fit_path.is_absolute() else base / fit_path
            labels = {k: _label(v) for k, v in e.items() if k not in KNOWN_FIELDS}
            jobs.append(
                Job(
                    name=_safe_name(str(e.get("name") or data.stem)),
                    data=data,
                    fit=fit_path,
                    argv=tuple(argv),
                    labels=labels,
                )
            )
    if not jobs:
        raise DataError("no records: give CSV files, folders or globs, or --manifest FILE")
    out = []
    for j in jobs:
        where = f"record {j.name}"
        fit_path = _resolve_fit(j.fit if j.fit is not None else fit_all, j.name, where)
        if command not in TAKES_FIT and fit_path is not None:
            raise DataError(f"{where}: {command} takes no fit; drop 'fit' / --fit (it is for {', '.join(TAKES_FIT)})")
        if command in NEEDS_FIT and fit_path is None:
            raise DataError(f"{where}: {command} needs a fit: give --fit FIT.json|DIR or a 'fit' field in the manifest")
        out.append(Job(name=j.name, data=j.data, fit=fit_path, argv=j.argv, labels=j.labels))
    seen: dict[str, Path] = {}
    for j in out:
        if j.name in seen:
            raise DataError(
                f"two records are named {j.name!r} ({seen[j.name]} and {j.data}); give each a 'name' in a manifest"
            )
        seen[j.name] = j.data
    return out
