"""``duffsym convert``: a record from a text, CSV or ``.mat`` file, written in the contract's CSV format."""

from __future__ import annotations


def cmd_convert(args) -> int:
    from duffsym.cli.common import CLIError, emit_json, err, parse_mapping
    from duffsym.data.convert import convert

    columns = parse_mapping(args.columns, "--columns")
    if not columns:
        raise CLIError(
            "--columns is required, e.g. --columns time=1,displacement=2,force=3 (positions from 1 or header names)"
        )
    record = convert(
        args.input,
        args.out,
        fmt=args.format,
        columns=columns,
        dt=args.dt,
        variable=args.variable,
        current=args.current,
        voltage=args.voltage,
    )
    summary = {
        "input": str(args.input),
        "out": str(args.out),
        "n_samples": record.n_times,
        "dt": record.dt,
        "duration": record.duration,
        "columns": dict(record.metadata["columns"]),
        "format": record.metadata["format"],
        "velocity": record.d_dot is not None,
    }
    from duffsym.data.record import time_unit_note

    notes = [n for n in (time_unit_note(record.t), _stamp_note(record)) if n]
    if notes:
        summary["notes"] = notes
    if args.json:
        emit_json(summary)
    elif not args.quiet:
        err(
            f"wrote {args.out}: {record.n_times} samples, dt {record.dt:g} s, {record.duration:g} s "
            f"(time, displacement{', velocity' if record.d_dot is not None else ''}, force)"
        )
    if not args.quiet:
        for note in notes:
            err(f"duffsym convert: note: {note}")
    return 0


def _stamp_note(record) -> str | None:
    """The time column's non-uniform (or rebuilt) stamps, said once (the CSV keeps them as read)."""
    info = record.metadata.get("sampling", {})
    if info.get("uniform") and not info.get("rebuilt"):
        return None
    return f"time stamps: {info.get('rule', 'not uniform')}"


def register(sub) -> None:
    s = sub.add_parser(
        "convert", help="turn a text/CSV/.mat data file into a duffsym CSV record (time, displacement, velocity, force)"
    )
    s.add_argument("input", help="the data file (.txt whitespace-separated, .csv, .mat)")
    s.add_argument(
        "--format", choices=("txt", "csv", "mat"), default=None, help="file format (default: from the suffix)"
    )
    s.add_argument(
        "--columns",
        help="ROLE=COLUMN pairs, a 1-based position or a header name, e.g. "
        "time=1,displacement=2,velocity=3,force=4 (roles: time, displacement/input, force/output, "
        "velocity)",
    )
    s.add_argument("--dt", type=float, default=None, help="sampling step in s, when the file has no time column")
    s.add_argument("--variable", help="the matrix of a .mat file (default: its only numeric matrix)")
    s.add_argument("--current", type=float, default=None, help="the test's coil current, A (written as a column)")
    s.add_argument("--voltage", type=float, default=None, help="the test's coil voltage, V (written as a column)")
    s.add_argument("--out", required=True, help="the CSV to write (atomically)")
    s.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    s.add_argument("--quiet", action="store_true", help="no message")
    s.set_defaults(func=cmd_convert)
