"""What every subcommand module shares: the usage error, stderr/JSON output, reading a record, the model
with ``--add`` effects, ``--mask`` and the common arguments.

The command modules (``*/command.py``, ``simulate_command.py``, ``reproduce_command.py``) import from
here; :mod:`duffsym.cli` only builds the parser from them and turns errors into exit codes.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

from duffsym.errors import DuffsymError

EXIT_ERROR = 2


class CLIError(DuffsymError):
    """A command-line usage problem found after parsing."""


def _err(msg: str) -> None:
    print(msg, file=sys.stderr)


def _emit_json(obj) -> None:
    from duffsym._json import jsonable

    print(json.dumps(jsonable(obj), indent=2, allow_nan=False, default=str))


def _parse_assignments(items, what: str) -> dict[str, float]:
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


def _parse_mapping(text: str | None, what: str) -> dict[str, str]:
    out: dict[str, str] = {}
    for part in (text or "").split(","):
        if not part:
            continue
        if "=" not in part:
            raise CLIError(f"{what} {part!r} must look like ROLE=NAME (e.g. time=t,input=V1,output=V2)")
        key, value = part.split("=", 1)
        out[key.strip()] = value.strip()
    return out


def _read_record(args, path):
    from duffsym.data import read_csv

    return read_csv(path, columns=_parse_mapping(args.columns, "--columns") or None,
                    units=_parse_mapping(args.units, "--units") or None, nan_policy=args.nan_policy)


def _fit_model(args):
    from duffsym.model.library import get_model

    model = get_model(args.model, args.n)
    effects = [e.strip() for e in (args.add or "").split(",") if e.strip()]
    if effects:
        from duffsym.effects import CATALOGUE, apply_effects

        unknown = [e for e in effects if e not in CATALOGUE]
        if unknown:
            raise CLIError(f"unknown effect(s) {unknown}; choose from {{{', '.join(sorted(CATALOGUE))}}}")
        model = apply_effects(model, [CATALOGUE[e] for e in effects])
    return model


def _mask_from_args(spec: str | None, record):
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
    try:
        mask = np.loadtxt(mask_path, dtype=float).astype(bool).reshape(-1)
    except ValueError as exc:
        raise CLIError(f"--mask {spec}: not a column of 0/1 values ({exc})") from None
    return mask, {"rule": f"user mask from {spec}"}


def _add_model_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--model", default="mr-damper", help="model name (see `duffsym models`; default mr-damper)")
    s.add_argument("--n", type=int, default=None, help="the odd power n (default: the model's, 5 for mr-damper)")


def _add_file_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--columns", help="map roles to the file's columns, e.g. time=t,input=V1,output=V2 "
                   "(roles: time, displacement/input, force/output, velocity, current, voltage)")
    s.add_argument("--units", help="record units, e.g. input=mm,output=N")
    s.add_argument("--nan-policy", choices=("raise", "omit"), default="raise",
                   help="samples with NaN/inf: raise an error (default) or omit them (with a warning)")
