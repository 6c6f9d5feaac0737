"""``duffsym compare DATA... --models a,b,c`` (``docs/contract.md``): the models fitted on the same records and
scored on held-out data (:func:`duffsym.diagnose.compare.compare`)."""

from __future__ import annotations

import sys


def cmd_compare(args) -> int:
    from duffsym.cli.common import CLIError, check_outputs, emit_json, parse_assignments, read_record
    from duffsym.diagnose.compare import compare, plot_comparison

    models = [m.strip() for m in (args.models or "").split(",") if m.strip()]
    if not models:
        raise CLIError(
            "--models: give at least one model name, e.g. --models mr-damper-current,spencer,bouc-wen "
            "(duffsym models lists them)"
        )
    validate_files = [v for v in (args.validate or "").split(",") if v.strip()]
    check_outputs(args, list(args.data) + validate_files)
    records = [read_record(args, p) for p in args.data]
    held = [read_record(args, p) for p in validate_files] or None
    say = None if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    result = compare(
        records,
        models,
        validate=held,
        holdout=args.holdout,
        n_starts=args.starts,
        start_spread=args.spread,
        rng=args.seed,
        max_iter=args.max_iter,
        progress=say,
        fixed=parse_assignments(args.fix, "--fix"),
    )
    if args.out:
        from duffsym._io import write_json_atomic
        from duffsym._json import jsonable

        write_json_atomic(args.out, jsonable(result.to_dict()))
    if args.plot:
        plot_comparison(result, args.plot)
    if args.json:
        emit_json(result.to_dict())
    else:
        print(result.summary())
    return 0 if any(s.success for s in result.scores) else 1


def register(sub) -> None:
    from duffsym.cli.common import add_file_arguments

    s = sub.add_parser("compare", help="fit several models on the same records and score them on held-out data")
    s.add_argument("data", nargs="+", help="CSV records to fit (see --columns)")
    s.add_argument(
        "--models",
        required=True,
        help="comma-separated model names, NAME:n for an exponent/power "
        "(e.g. mr-damper-current:5,spencer,bouc-wen:1; duffsym models lists them)",
    )
    s.add_argument("--validate", help="comma-separated held-out CSV files; default: the last --holdout of each record")
    s.add_argument("--holdout", type=float, default=0.3, help="fraction of each record held out, its end (default 0.3)")
    s.add_argument("--starts", type=int, default=4, help="IPOPT starts per model (default 4)")
    s.add_argument(
        "--spread", type=float, default=3.0, help="random starts: log-uniform factors in [1/s, s] (default 3)"
    )
    s.add_argument("--seed", type=int, default=0, help="seed of the random starts")
    s.add_argument(
        "--fix",
        action="append",
        metavar="NAME=VALUE",
        help="hold a parameter in every model that has "
        "it (repeat or comma-separate), e.g. eta=100 for records at constant currents",
    )
    s.add_argument("--max-iter", type=int, default=500, help="IPOPT iteration limit per start")
    add_file_arguments(s)
    s.add_argument("--out", help="write the comparison as JSON")
    s.add_argument("--plot", help="figure (PNG/PDF): held-out error per record, fit time and starts, simulation cost")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_compare)
