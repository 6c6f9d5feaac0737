"""What every subcommand module shares: the usage error, stderr/JSON output, reading a record, the model
with ``--add`` effects, ``--mask`` and the common arguments.

The command modules (``duffsym/cli/<topic>.py``) import from here; :mod:`duffsym.cli` only builds the
parser from them and turns errors into exit codes.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from duffsym.errors import DuffsymError

EXIT_ERROR = 2


class CLIError(DuffsymError):
    """A command-line usage problem found after parsing."""


def err(msg: str) -> None:
    print(msg, file=sys.stderr)


def emit_json(obj) -> None:
    from duffsym._json import jsonable

    print(json.dumps(jsonable(obj), indent=2, allow_nan=False, default=str))


@dataclass(frozen=True)
class CommandResult:
    """What a command computed, before anything is printed: ``to_dict()`` is its ``--json`` object,
    ``summary()`` its text, ``exit_code`` its exit code and ``notes`` the stderr lines that follow the output
    (e.g. "the fit did not succeed"). ``value`` is the library's own result object (an
    :class:`~duffsym.identify.IdentificationResult`, a validation, a diagnosis, a ladder, a posterior), kept in
    this process only: ``duffsym batch`` gets the rest back from its workers (:meth:`portable`).

    ``text`` is the summary, or a function making it (the text is made only when printed, as before).
    """

    command: str
    data: dict
    text: str | Callable[[], str] = ""
    exit_code: int = 0
    notes: tuple[str, ...] = ()
    value: Any = None

    def to_dict(self) -> dict:
        return self.data

    def summary(self) -> str:
        return self.text() if callable(self.text) else self.text

    @property
    def success(self) -> bool:
        return self.exit_code == 0

    def portable(self) -> CommandResult:
        """This result with its JSON made JSON-safe and without the library object or a text not yet made:
        small and picklable (what a batch worker returns; the batch stores ``to_dict()``)."""
        from dataclasses import replace

        from duffsym._json import jsonable

        return replace(
            self, data=_plain(jsonable(self.data)), value=None, text="" if callable(self.text) else self.text
        )


def _plain(obj):
    """JSON types only, as ``json.dumps(..., default=str)`` writes them: any other object as its ``str``."""
    if isinstance(obj, dict):
        return {k: _plain(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_plain(v) for v in obj]
    if obj is None or isinstance(obj, (str, bool, int, float)):
        return obj
    return str(obj)


def show(result: CommandResult, as_json: bool) -> int:
    """Print a command's result (its JSON with ``--json``, else its text), then its notes on stderr; the exit code."""
    if as_json:
        emit_json(result.to_dict())
    else:
        print(result.summary())
    for line in result.notes:
        err(line)
    return result.exit_code


def parse_assignments(items, what: str) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items or ():
        for part in item.split(","):
            if not part:
                continue
            if "=" not in part:
                raise CLIError(f"{what} {part!r} must look like NAME=VALUE (e.g. c3=300)")
            name, value = part.split("=", 1)
            try:
                number = float(value)
            except ValueError:
                raise CLIError(f"{what} {name}={value!r}: {value!r} is not a number") from None
            if not math.isfinite(number):
                raise CLIError(f"{what} {name}={value}: the value must be finite")
            out[name.strip()] = number
    return out


def parse_mapping(text: str | None, what: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for part in (text or "").split(","):
        if not part:
            continue
        if "=" not in part:
            raise CLIError(f"{what} {part!r} must look like ROLE=NAME (e.g. time=t,input=V1,output=V2)")
        key, value = part.split("=", 1)
        out[key.strip()] = value.strip()
    return out


def read_record(args, path):
    from duffsym.data import read_csv

    if str(path).lower().endswith(".json"):  # the friction damper's JSON layout (data/loaders.py)
        from duffsym.data.loaders import load_friction_damper_json

        return load_friction_damper_json(path)
    return read_csv(
        path,
        columns=parse_mapping(args.columns, "--columns") or None,
        units=parse_mapping(args.units, "--units") or None,
        nan_policy=args.nan_policy,
        sampling=getattr(args, "sampling", "strict"),
    )


def check_outputs(args, inputs, options=("out", "plot")) -> None:
    """Before any work: each output option names a writable file that is none of the inputs."""
    from duffsym._io import check_output_path

    for opt in options:
        value = getattr(args, opt, None)
        if value:
            check_output_path(value, inputs=[i for i in inputs if i], option=f"--{opt.replace('_', '-')}")


def failed_path(path) -> Path:
    """Where a failed fit is written instead of ``--out``: ``NAME.failed.json`` beside it."""
    path = Path(path)
    return path.with_name(f"{path.stem}.failed{path.suffix or '.json'}")


def save_fit(result, out: str, command: str) -> None:
    """Write a fit to ``--out``; a failed fit goes to ``NAME.failed.json`` and never replaces ``--out``."""
    if result.success:
        result.save(out)
        return
    failed = failed_path(out)
    result.save(failed)
    err(f"duffsym {command}: {out} left unchanged; the failed fit is in {failed}")


def require_success(result, args) -> None:
    """Refuse a fit marked ``success: false`` unless ``--force``."""
    if result.success:
        return
    if not getattr(args, "force", False):
        raise CLIError(
            f"{args.fit} is a failed fit (status {str(result.status)!r}: {str(result.message)[:120]}); refit, "
            "or pass --force to use it anyway"
        )
    err(f"warning: using the failed fit {args.fit} (--force): {result.status}")


def fit_model(args):
    from duffsym.model.library import get_model

    model = get_model(args.model, args.n)
    effects = [e.strip() for e in (args.add or "").split(",") if e.strip()]
    if effects:
        from duffsym.effects import ADDABLE, CATALOGUE, EXTENSIONS, apply_effects

        unknown = [e for e in effects if e not in ADDABLE]
        if unknown:
            raise CLIError(
                f"unknown effect(s) {unknown}; choose from {{{', '.join(sorted(CATALOGUE))}}} or, outside the "
                f"catalogue, {{{', '.join(sorted(EXTENSIONS))}}} (duffsym effects lists them)"
            )
        model = apply_effects(model, [ADDABLE[e] for e in effects])
    return model


def mask_from_args(spec: str | None, record):
    """``--mask none|auto|FILE`` -> (mask or None, info or None)."""
    import numpy as np

    from duffsym.identify import auto_mask

    if spec in (None, "none"):
        return None, None
    if spec == "auto":
        return auto_mask(record)
    mask_path = Path(spec)
    if not mask_path.is_file():
        raise CLIError(f"--mask {spec}: no such file; give none, auto or a file of 0/1 per sample")
    from duffsym._io import check_input_file

    check_input_file(mask_path, what="mask file", limit=512 * 1024**2)
    try:
        values = np.loadtxt(mask_path, dtype=float, ndmin=1).reshape(-1)
    except ValueError as exc:
        raise CLIError(f"--mask {spec}: not a column of 0/1 values ({str(exc)[:80]})") from None
    bad = np.flatnonzero((values != 0) & (values != 1))
    if bad.size:
        raise CLIError(
            f"--mask {spec}: value {values[bad[0]]:g} at sample {bad[0]} ({bad.size} value(s) not 0 or 1); "
            "give 1 to leave a sample out of the objective and 0 to keep it"
        )
    return values.astype(bool), {"rule": f"user mask from {spec}"}


def add_model_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--model", default="mr-damper", help="model name (see `duffsym models`; default mr-damper)")
    s.add_argument("--n", type=int, default=None, help="the odd power n (default: the model's, 5 for mr-damper)")


def add_file_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument(
        "--columns",
        help="map roles to the file's columns, e.g. time=t,input=V1,output=V2 "
        "(roles: time, displacement/input, force/output, velocity, current, voltage)",
    )
    s.add_argument("--units", help="record units, e.g. input=mm,output=N")
    s.add_argument(
        "--nan-policy",
        choices=("raise", "omit"),
        default="raise",
        help="samples with NaN/inf: raise an error (default) or omit them (with a warning)",
    )
    s.add_argument(
        "--sampling",
        choices=("strict", "resample", "as-given"),
        default="strict",
        help="a time column that is not uniform: strict (default: a uniform grid printed with rounding is "
        "rebuilt and reported, anything else is an error), resample (interpolate onto a uniform grid at "
        "the median step) or as-given (use the stamps as they are)",
    )
