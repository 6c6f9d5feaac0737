"""``duffsym diagnose`` and ``duffsym ladder`` (``docs/contract.md``)."""

from __future__ import annotations

import time


def _common(args):
    """Record, model, candidates, mask and fixed values from the shared options."""
    from duffsym._io import check_output_dir
    from duffsym.cli.common import CLIError, mask_from_args, parse_assignments, read_record
    from duffsym.effects import CATALOGUE

    inputs = [args.data, getattr(args, "fit", None), None if args.mask in (None, "none", "auto") else args.mask]
    if getattr(args, "out", None):
        from duffsym.cli.common import check_outputs

        check_outputs(args, inputs, options=("out",))
    if args.report:
        check_output_dir(args.report)
    record = read_record(args, args.data)
    cands = None
    if args.candidates:
        cands = [c.strip() for c in args.candidates.split(",") if c.strip()]
        unknown = [c for c in cands if c not in CATALOGUE]
        if unknown:
            raise CLIError(
                f"--candidates: unknown effect(s) {unknown}; choose from {{{', '.join(CATALOGUE)}}} "
                "(duffsym effects lists them)"
            )
    mask, _ = mask_from_args(args.mask, record)
    fixed = parse_assignments(args.fix, "--fix")
    if args.screen != "all":
        try:
            screen = int(args.screen)
        except ValueError:
            raise CLIError(f"--screen must be a positive integer or 'all'; got {args.screen!r}") from None
        if screen < 1:
            raise CLIError(f"--screen must be a positive integer or 'all'; got {args.screen!r}")
    args.screen_n = None if args.screen == "all" else int(args.screen)
    args.decimate_opt = _decimate_option(args.decimate)
    return record, cands, mask, fixed


def _engine(args):
    """The engine fitting the candidates: None (here, one after the other) unless --workers or --scheduler."""
    import contextlib

    if not args.workers and not args.scheduler:
        return contextlib.nullcontext(None)
    from duffsym.engine import Engine

    return Engine(args.workers, scheduler=args.scheduler)


def _decimate_option(text: str):
    """``--decimate auto|off|Q`` -> True, False or the largest factor allowed."""
    from duffsym.cli.common import CLIError

    if text in ("auto", "off"):
        return text == "auto"
    try:
        q = int(text)
    except ValueError:
        q = 0
    if q < 1:
        raise CLIError(f"--decimate must be 'auto', 'off' or a positive integer (the largest factor); got {text!r}")
    return q


def _progress(args):
    """Progress lines on stderr (elapsed time, candidate count, time left), or None with --quiet."""
    from duffsym._progress import Progress

    return None if args.quiet else Progress()


def cmd_diagnose(args) -> int:
    from duffsym.cli.common import show

    return show(run_diagnose(args), args.json)


def run_diagnose(args):
    """``duffsym diagnose``'s work (the report written, progress on stderr): a :class:`CommandResult`."""
    from duffsym.cli.common import CommandResult, fit_model
    from duffsym.diagnose import diagnose

    record, cands, mask, fixed = _common(args)
    fit_result = None
    if args.fit:
        from duffsym.cli.common import require_success
        from duffsym.identify import load_result, model_from_result

        fit_result = load_result(args.fit)
        require_success(fit_result, args)
        model = model_from_result(fit_result)
    else:
        model = fit_model(args)
    budget = _budget(args.budget)
    with _engine(args) as engine:
        dg = diagnose(
            record,
            model,
            fit_result=fit_result,
            candidates=cands,
            fixed=fixed,
            holdout=args.holdout,
            noise=args.noise,
            mask=mask,
            screen=args.screen_n,
            sindy=not args.no_sindy,
            decimate=args.decimate_opt,
            deadline=None if budget is None else time.monotonic() + budget,
            progress=_progress(args),
            engine=engine,
        )
    from duffsym.diagnose.report import write_diagnosis_report

    _report(args, dg, record, write_diagnosis_report)
    return CommandResult("diagnose", dg.to_dict(), dg.summary, value=dg)


def _report(args, obj, record, write_report) -> None:
    """The report of a diagnosis or ladder (``--report DIR``), written before its JSON or text is printed."""
    from duffsym.cli.common import err

    if args.report:
        path = write_report(obj, record, args.report)
        if not args.quiet:
            err(f"report written to {path}")


def _budget(text: str) -> float | None:
    """``--budget SECONDS|none`` -> seconds or None."""
    from duffsym.cli.common import CLIError

    if text.strip().lower() in ("none", "off", "0"):
        return None
    try:
        b = float(text)
    except ValueError:
        b = -1.0
    if not b > 0 or b != b:
        raise CLIError(f"--budget must be a positive number of seconds or 'none'; got {text!r}")
    return b


def _writer(args, record):
    """``on_step`` of the ladder: the report folder (new steps only) and ``--out`` (the last step's fit) after every
    step, so that a stopped run keeps what it did (atomic writes)."""
    from duffsym.diagnose.report import write_ladder_report

    written: set = set()

    def on_step(partial) -> None:
        if args.report:
            write_ladder_report(partial, record, args.report, written=written)
        if args.out and partial.steps[-1].diagnosis.base_fit.success:
            partial.steps[-1].diagnosis.base_fit.with_sampling([record]).save(args.out)

    return on_step, written


def cmd_ladder(args) -> int:
    from duffsym.cli.common import show

    return show(run_ladder(args), args.json)


def run_ladder(args):
    """``duffsym ladder``'s work (steps written as they finish, progress on stderr): a :class:`CommandResult`."""
    from duffsym.cli.common import CommandResult, fit_model
    from duffsym.diagnose import ladder

    record, cands, mask, fixed = _common(args)
    model = fit_model(args)
    budget = _budget(args.budget)
    on_step, written = _writer(args, record)
    with _engine(args) as engine:
        lad = ladder(
            record,
            model,
            max_steps=args.max_steps,
            accept=args.accept,
            candidates=cands,
            fixed=fixed,
            holdout=args.holdout,
            noise=args.noise,
            mask=mask,
            screen=args.screen_n,
            sindy=not args.no_sindy,
            decimate=args.decimate_opt,
            budget=budget,
            on_step=on_step,
            progress=_progress(args),
            engine=engine,
            discover=not args.no_discover,
        )
    if args.out:
        from duffsym.cli.common import save_fit

        save_fit(lad.final_fit.with_sampling([record]), args.out, "ladder")
    from duffsym.diagnose.report import write_ladder_report

    _report(args, lad, record, lambda obj, rec, folder: write_ladder_report(obj, rec, folder, written=written))
    notes = []
    if not lad.complete:
        notes.append(f"duffsym ladder: {lad.stopped}; every finished step is kept")
    if lad.final_note:
        notes.append(f"duffsym ladder: {lad.final_note}")
    ok = lad.final_fit.success
    if not ok:
        notes.append(f"duffsym ladder: the final fit did not succeed: {lad.final_fit.status}: {lad.final_fit.message}")
    return CommandResult("ladder", lad.to_dict(), lad.summary, exit_code=0 if ok else 1, notes=tuple(notes), value=lad)


def _shared(s) -> None:
    from duffsym.cli.common import add_file_arguments, add_model_arguments

    s.add_argument("data", help="CSV record (time, displacement, force, ...; see --columns)")
    add_model_arguments(s)
    s.add_argument("--add", help="effects already in the model, comma-separated (see duffsym effects)")
    s.add_argument("--candidates", help="effects to try, comma-separated (default: the whole catalogue)")
    s.add_argument("--fix", action="append", metavar="NAME=VALUE", help="hold parameters fixed in every fit")
    s.add_argument(
        "--holdout",
        type=float,
        default=0.3,
        help="fraction of the record held out at its end (default 0.3; snapped to whole input cycles)",
    )
    s.add_argument(
        "--noise",
        type=float,
        default=None,
        help="output noise standard deviation if known (default: estimated from the measurement)",
    )
    s.add_argument(
        "--screen",
        default="4",
        help="candidates not converged within the screening budget that continue to the full "
        "budget (the best by free-run error; default 4), or 'all'",
    )
    s.add_argument(
        "--decimate",
        default="auto",
        help="fit on the record decimated where its spectrum allows "
        "(auto, default; the factor is reported), 'off', or the largest factor allowed",
    )
    s.add_argument("--mask", default="none", help="none, auto or a 0/1 file: samples left out of every objective")
    add_file_arguments(s)
    s.add_argument("--no-sindy", action="store_true", help="skip the SINDy cross-check of the base model")
    s.add_argument(
        "--budget",
        default="600",
        metavar="SECONDS",
        help="time budget of the whole run (default 600; "
        "'none': no limit): each fit gets its share and what ran out is said; a ladder stopped by it "
        "(or by Ctrl-C) keeps every finished step, written to --report and --out as each completes",
    )
    s.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="fit the candidates on N local worker "
        "processes (the same fits, in parallel; default: one after the other here)",
    )
    s.add_argument("--scheduler", metavar="ADDRESS", help="fit the candidates on the workers of this Dask scheduler")
    s.add_argument("--report", metavar="DIR", help="write a Markdown report with figures to DIR")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")


def register(sub) -> None:
    s = sub.add_parser("diagnose", help="where the model fails on a record, and which catalogued effect is missing")
    _shared(s)
    s.add_argument("--fit", help="FIT.json of the model to diagnose (its effects included); default: fit it here")
    s.add_argument("--force", action="store_true", help="diagnose around a fit marked success: false")
    s.set_defaults(func=cmd_diagnose, run=run_diagnose)

    s = sub.add_parser(
        "ladder",
        help="base fit, then add the best supported effect and refit, while the evidence "
        "supports it; the error at each step",
    )
    _shared(s)
    s.add_argument("--max-steps", type=int, default=4, help="add at most this many effects (default 4)")
    s.add_argument(
        "--accept",
        choices=("needed", "supported"),
        default="needed",
        help="add an effect when the diagnosis calls it needed (default: it removes at least half of "
        "the excess held-out error) or already when it is supported (dBIC < -10 and >= 10 %% lower "
        "held-out error)",
    )
    s.add_argument("--out", help="save the last step's fit (refitted on the whole record) as JSON for validate")
    s.add_argument(
        "--no-discover",
        action="store_true",
        help="do not look outside the catalogue (by default, when "
        "no catalogued effect is needed, a drifting parameter or a term found by sparse regression of the "
        "residual is tried, and added only if it passes the same held-out evidence)",
    )
    s.add_argument("--discover", action="store_true", help="accepted for compatibility (discovery is on by default)")
    s.set_defaults(func=cmd_ladder, run=run_ladder)
