"""``duffsym sindy DATA [--fit FIT.json] [--json]``: the SINDy cross-check of the recovered terms."""

from __future__ import annotations


def cmd_sindy(args) -> int:
    from duffsym.cli.common import CLIError, emit_json, err, read_record, require_success
    from duffsym.sindy import crosscheck

    fit = None
    model = None
    if args.fit:
        from duffsym.identify import load_result

        fit = load_result(args.fit)
        require_success(fit, args)
        if args.model is not None or args.n is not None:
            raise CLIError("--fit gives the model; drop --model/--n")
    else:
        from duffsym.model.library import get_model

        model = get_model(args.model or "mr-damper", args.n)
    records = [read_record(args, path) for path in args.data]
    if args.models < 2:
        raise CLIError(f"--models must be at least 2 bootstrap fits; got {args.models}")
    if args.window is not None and not args.window > 0:
        raise CLIError(f"--window must be a positive number of seconds; got {args.window}")
    if not args.quiet:
        err(
            f"SINDy cross-check ({args.method} form, {args.models} bootstrap fits) of "
            f"{', '.join(args.data)}" + (f" against {args.fit}" if args.fit else "")
        )
    check = crosscheck(
        records,
        model,
        fit=fit,
        method=args.method,
        window=args.window,
        n_models=args.models,
        max_power=args.max_power,
        selection=args.selection,
        rng=args.seed,
    )
    if args.json:
        emit_json(check.to_dict())
    else:
        print(check.summary())
    return 0


def register(sub) -> None:
    from duffsym.cli.common import add_file_arguments

    s = sub.add_parser(
        "sindy",
        help="SINDy cross-check of the terms of the velocity equation (which terms the data support)",
        description="Sparse regression (weak-form SINDy, pysindy) of the velocity equation x'' = f(x, x', d, d') on "
        "the model's own terms, the effects catalogue's terms and generic powers, with x' = y/A_f and x "
        "its integral. Says which terms the data support, compares them with a fit, and says "
        "'inconclusive' when the library is collinear on the data, the selection is unstable under "
        "bootstrap, or the coefficients depend on the sampling.",
    )
    s.add_argument("data", nargs="+", help="CSV record(s); several are pooled (one integration constant each)")
    s.add_argument("--fit", help="FIT.json (from `duffsym fit --out`): model, A_f and the coefficients to compare with")
    s.add_argument("--force", action="store_true", help="compare with a fit marked success: false")
    s.add_argument(
        "--model", default=None, help="model whose terms are checked when no --fit is given (default mr-damper)"
    )
    s.add_argument("--n", type=int, default=None, help="power n of the model (default 5)")
    s.add_argument(
        "--method",
        choices=("weak", "smoothed"),
        default="weak",
        help="weak form (default; no derivative of the data) or smoothed finite differences",
    )
    s.add_argument("--window", type=float, default=None, help="weak-form window, s (default: a quarter input period)")
    s.add_argument("--models", type=int, default=20, help="bootstrap fits for the inclusion probabilities (default 20)")
    s.add_argument(
        "--selection",
        choices=("best-subset", "ssr", "stlsq"),
        default="best-subset",
        help="support selection: exhaustive best subsets (default), pysindy SSR path, or pysindy STLSQ "
        "(plain SINDy; keeps spurious terms among collinear powers under noise)",
    )
    s.add_argument("--max-power", type=int, default=7, help="highest power of x and x' among the generic terms")
    s.add_argument("--seed", type=int, default=0, help="seed of the bootstrap")
    add_file_arguments(s)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_sindy)
