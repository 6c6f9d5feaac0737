"""``duffsym batch`` and :func:`duffsym.batch` (see the contract): a command on many records, on local
processes or a Dask cluster. Each record is a :class:`~duffsym.engine.Task` running the command's own
function (:mod:`duffsym.cli.batch_worker`); :func:`duffsym.campaign.run_batch` runs them on an engine and
keeps the results."""

from __future__ import annotations


def batch(inputs=(), *, command: str = "fit", out, **options):
    """Run a ``duffsym`` command on every record of folders, globs or a manifest; see
    :func:`duffsym.campaign.run_batch` for the parameters (``manifest``, ``fit``, ``options``, ``run``, and
    :class:`duffsym.campaign.RunOptions`' ``workers``, ``scheduler``, ``engine``, ``retry_failed``,
    ``progress``, ``figure``).

    Returns
    -------
    duffsym.campaign.CampaignResult
        One row per record (status, NRMSE, result file, message, ...), with ``summary()`` and ``to_dict()``.
    """
    from duffsym.campaign import run_batch
    from duffsym.cli.batch_worker import record_task

    return run_batch(inputs, make_task=record_task, command=command, out=out, **options)


def cmd_batch(args) -> int:
    from duffsym.cli.common import CLIError, emit_json

    if args.workers is not None and args.workers < 0:
        raise CLIError(f"--workers must be 0 (in this process) or more; got {args.workers}")
    if not args.inputs and not args.manifest:
        raise CLIError("no records: give CSV files, folders or globs, or --manifest FILE")
    res = batch(
        args.inputs,
        command=args.command,
        out=args.out,
        manifest=args.manifest,
        fit=args.fit,
        options=args.options,
        workers=args.workers,
        scheduler=args.scheduler,
        retry_failed=args.retry_failed,
        progress=not args.quiet,
        figure=not args.no_figure,
    )
    if args.json:
        emit_json(res.to_dict())
    else:
        print(res.summary())
    return 0 if res.all_ok else 1


def register(sub) -> None:
    s = sub.add_parser(
        "batch",
        help="run fit, validate, diagnose, ladder or sample on many records (local processes or a Dask "
        "cluster); one result file per record, resumable, with a summary table and figure",
        description="Run one duffsym command on every record of folders, globs or a manifest. Each record's "
        "result is written atomically to DIR/<record>.json as it finishes (the command's JSON plus a 'batch' "
        "block); a rerun skips records whose result is complete and whose inputs and options are unchanged. "
        "DIR/summary.json, summary.csv and summary.png list every record; a failing record is reported there "
        "and never stops the others. Exit 0 when every record is usable, 1 otherwise, 2 on bad input.",
    )
    s.add_argument("inputs", nargs="*", metavar="INPUTS", help="CSV records, folders (their *.csv) or glob patterns")
    s.add_argument(
        "--command",
        required=True,
        choices=("fit", "validate", "diagnose", "ladder", "sample"),
        help="the duffsym command run on each record",
    )
    s.add_argument("--out", required=True, metavar="DIR", help="results folder")
    s.add_argument(
        "--manifest",
        metavar="FILE",
        help="CSV or JSON: one record per line/object with fields file "
        "(required), name, columns, model, effects, fit, options; other fields (e.g. current, amplitude, "
        "frequency) are labels shown in the summary and its figure",
    )
    s.add_argument(
        "--fit",
        metavar="FIT.json|DIR",
        help="the fit used by validate/sample/diagnose: one file for "
        "every record, or a folder of <record>.json (the --out of a batch fit)",
    )
    s.add_argument(
        "--options",
        metavar="'OPTIONS'",
        help="options of the command for every record, quoted as one argument, e.g. --options '--starts 3 --seed 1'",
    )
    s.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local worker processes (default: the cores available); 0 runs every record in this process",
    )
    s.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="address of a Dask scheduler (tcp://host:8786) or its "
        "scheduler file (.json): run the records on its workers",
    )
    s.add_argument(
        "--retry-failed",
        action="store_true",
        help="rerun records whose stored result failed (default: "
        "keep every complete result whose inputs and options are unchanged)",
    )
    s.add_argument("--no-figure", action="store_true", help="do not draw summary.png")
    s.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    s.set_defaults(func=cmd_batch)
