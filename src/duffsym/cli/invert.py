"""``duffsym invert FIT.json --displacement D.csv --force F.csv [--limits LO,HI] [--rate R] --out CMD.csv [--json]``:
the command history that makes a fitted command-driven model produce a desired force."""

from __future__ import annotations

import csv
import math

import numpy as np

from duffsym._io import read_columns
from duffsym.errors import DataError

_TIME = ("time", "t")
_DISP = ("displacement", "input", "d")
_VEL = ("velocity", "d_dot")
_FORCE = ("force", "output", "y")


def _parse_limits(text: str) -> tuple[float, float]:
    from duffsym.cli.common import CLIError

    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise CLIError(f"--limits must be LO,HI (two numbers, e.g. 0,2); got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise CLIError(f"--limits must be finite with LO < HI; got {text!r}")
    return lo, hi


def load_motion_and_force(model, disp_path: str, force_path: str, lo: float):
    """Time, the model's input matrix (command column at ``lo``) and the desired force from the two files."""
    from duffsym.data.record import Record

    dcols = read_columns(disp_path, {"time": _TIME, "displacement": _DISP, "velocity": _VEL}, optional=("velocity",))
    fcols = read_columns(force_path, {"time": _TIME, "force": _FORCE})
    t = dcols["time"]
    if fcols["time"].shape != t.shape or not np.allclose(fcols["time"], t, rtol=0, atol=1e-9 * max(1.0, abs(t[-1]))):
        raise DataError(
            f"{force_path}: its time column must equal that of {disp_path} ({t.size} samples); give the "
            "desired force at the displacement's sample times"
        )
    rec = Record(
        t=t, d=dcols["displacement"], y=fcols["force"], d_dot=dcols.get("velocity"), current=lo, source=str(disp_path)
    )
    return rec.t, rec.input_matrix(model), np.asarray(rec.y)


def write_command(res, path: str) -> None:
    from duffsym._io import atomic_write

    with atomic_write(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["time", res.command_name, "force_desired", "force_model", "unreachable"])
        for row in zip(res.t, res.command, res.force_desired, res.force_model, res.unreachable):
            w.writerow(
                [repr(float(row[0])), repr(float(row[1])), repr(float(row[2])), repr(float(row[3])), int(bool(row[4]))]
            )


def cmd_invert(args) -> int:
    from duffsym.cli.common import CLIError, check_outputs, emit_json, err
    from duffsym.control.inverse import command_index, invert
    from duffsym.identify import load_result
    from duffsym.identify.validation import model_from_result

    check_outputs(args, [args.fit, args.displacement, args.force], options=("out",))
    lo, hi = _parse_limits(args.limits)
    if args.rate is not None and not (math.isfinite(args.rate) and args.rate > 0):
        raise CLIError(f"--rate must be a positive number (command units per second); got {args.rate}")
    fit = load_result(args.fit)
    if not fit.success:  # not require_success: here --force is the desired force, --force-fit the override
        if not args.force_fit:
            raise CLIError(
                f"{args.fit} is a failed fit (status {str(fit.status)!r}); refit, or pass --force-fit to use it"
            )
        err(f"warning: using the failed fit {args.fit} (--force-fit): {fit.status}")
    model = model_from_result(fit)
    command_index(model)
    t, U, force = load_motion_and_force(model, args.displacement, args.force, lo)
    if not args.quiet:
        err(
            f"inverting {model.name} for {t.size} samples of desired force (command in [{lo:g}, {hi:g}]"
            + (f", rate <= {args.rate:g}/s)" if args.rate else ")")
        )
    res = invert(model, fit.params, t, U, force, limits=(lo, hi), rate=args.rate, command_name=args.name)
    write_command(res, args.out)
    if args.json:
        emit_json({**res.to_dict(), "out": str(args.out)})
    else:
        print(res.summary())
        print(f"  command written to {args.out}")
    return 0 if res.success else 1


def register(sub) -> None:
    s = sub.add_parser(
        "invert",
        help="the command (current/voltage) history that makes a fitted model produce a desired force",
        description="Solve for the command history, within its range and rate, that makes a fitted command-driven "
        "model (e.g. mr-damper-current) produce the desired force for the given displacement: a CasADi "
        "collocation NLP on the model's own equations, checked by a free run. Reports where the desired "
        "force is unreachable and why (command at a limit, rate limit, or a force that would supply "
        "power: an MR damper can only dissipate). Exit 1 when no usable command was found.",
    )
    s.add_argument("fit", help="FIT.json of a command-driven model (duffsym fit --model mr-damper-current --out ...)")
    s.add_argument("--displacement", required=True, help="CSV with columns time, displacement (optional velocity)")
    s.add_argument("--force", required=True, help="CSV with columns time, force: the desired force at the same times")
    s.add_argument("--limits", default="0,1", help="command range LO,HI in the command's units (default 0,1)")
    s.add_argument("--rate", type=float, default=None, help="largest |d command/dt| in command units per second")
    s.add_argument(
        "--name",
        choices=("current", "voltage"),
        default="current",
        help="column name of the command in the output (default current)",
    )
    s.add_argument("--out", required=True, help="CSV to write: time, command, force_desired, force_model, unreachable")
    s.add_argument("--force-fit", dest="force_fit", action="store_true", help="use a fit marked success: false")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_invert)
