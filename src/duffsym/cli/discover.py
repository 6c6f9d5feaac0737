"""``duffsym discover DATA... --validate FILES`` (``docs/contract.md``): what one parameter set misses across a
campaign, and what it follows (:func:`duffsym.diagnose.campaign.discover_campaign`)."""

from __future__ import annotations

import sys

HELP = "what one parameter set misses across several records (a campaign), found outside the catalogue"


def cmd_discover(args) -> int:
    from duffsym.cli.common import CLIError, check_outputs, emit_json, fit_model, parse_assignments, read_record
    from duffsym.diagnose.campaign import discover_campaign

    held_files = [v.strip() for v in (args.validate or "").split(",") if v.strip()]
    if not held_files:
        raise CLIError(
            "--validate: name the held-out record(s), e.g. --validate test_5bar.csv: a discovery is judged on "
            "records it never fitted, chosen before it runs"
        )
    check_outputs(args, list(args.data) + held_files)
    records = [read_record(args, p) for p in list(args.data) + held_files]
    names = [r.name for r in records]
    if len(set(names)) < len(names):
        raise CLIError(f"records with the same name {sorted({n for n in names if names.count(n) > 1})}: rename files")
    say = None if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    result = discover_campaign(
        records,
        fit_model(args),
        [r.name for r in records[len(args.data) :]],
        fixed=parse_assignments(args.fix, "--fix"),
        progress=say,
    )
    if args.out:
        from duffsym._io import write_json_atomic
        from duffsym._json import jsonable

        write_json_atomic(args.out, jsonable(result.to_dict()))
    if args.json:
        emit_json(result.to_dict())
    else:
        print(result.summary())
    return 0


def register(sub) -> None:
    from duffsym.cli.common import add_file_arguments, add_model_arguments

    s = sub.add_parser("discover", help=HELP)
    s.add_argument("data", nargs="+", help="CSV records fitted together with one parameter set (see --columns)")
    s.add_argument("--validate", help="comma-separated held-out CSV files: judged, never fitted (required)")
    add_model_arguments(s)
    s.add_argument("--add", help="effects already in the model, comma-separated (see duffsym effects)")
    s.add_argument(
        "--fix", action="append", metavar="NAME=VALUE", help="hold parameters fixed in every fit (e.g. eta=100)"
    )
    add_file_arguments(s)
    s.add_argument("--out", help="write the result as JSON")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_discover)
