"""``duffsym fit`` and ``duffsym validate``: identify a model from a record, and score a saved fit on another."""

from __future__ import annotations

import dataclasses

from duffsym.cli.common import (
    CLIError,
    CommandResult,
    add_file_arguments,
    add_model_arguments,
    check_outputs,
    err,
    fit_model,
    mask_from_args,
    parse_assignments,
    read_record,
    require_success,
    save_fit,
    show,
)


def _prepared(args, record, mask):
    """The data to fit (sanity check and decimation, :mod:`duffsym.identify.fitdata`), noted on stderr."""
    from duffsym.identify.fitdata import prepare_fit_data

    decimate = getattr(args, "decimate", "off")
    if decimate not in ("auto", "off") and not (decimate.isdigit() and int(decimate) >= 1):
        raise CLIError(f"--decimate must be auto, off or a positive integer (the largest factor); got {decimate!r}")
    data = prepare_fit_data(record, mask, keep_invalid=getattr(args, "keep_invalid", False), decimate=decimate)
    if not args.quiet:
        for line in data.notes():
            err(f"duffsym fit: note: {line}")
    return data


def cmd_fit(args) -> int:
    return show(run_fit(args), args.json)


def run_fit(args) -> CommandResult:
    """``duffsym fit``'s work (files written, notes on stderr), its result not yet printed."""
    from duffsym.identify import fit
    from duffsym.identify.fitdata import finish_fit

    if args.manifest or len(args.data) != 1:  # a campaign: one parameter set for several records
        return _run_fit_campaign(args)
    check_outputs(args, [args.data[0], None if args.mask in (None, "none", "auto") else args.mask])
    full_record = read_record(args, args.data[0])
    model = fit_model(args)
    mask, mask_info = mask_from_args(args.mask, full_record)
    data = _prepared(args, full_record, mask)
    record = data.record
    problem = _problem(args, model, [record], [(data.mask, mask_info)])
    if not args.quiet:
        err(
            f"fitting {model.name}{' + ' + ', '.join(model.effects) if model.effects else ''} to {args.data[0]} "
            f"({record.t.size} samples)"
        )
    result = fit(
        problem,
        n_starts=args.starts,
        rng=args.seed,
        max_wall_time=args.time_limit,
        progress=None if args.quiet else (lambda msg: err(f"  {msg}")),
    ).with_sampling([record])
    result = finish_fit(result, data, model)
    if record.metadata.get("sampling", {}).get("rebuilt") and not args.quiet:
        err(f"duffsym fit: note: {record.metadata['sampling']['rule']}")
    from duffsym.data.record import time_unit_note

    if time_unit_note(record.t) and not args.quiet:
        err(f"duffsym fit: note: {time_unit_note(record.t)}")
    if result.flags:
        err("duffsym fit: note: " + "; ".join(f["message"] for f in result.flags))
    if args.out:
        save_fit(result, args.out, "fit")
    if args.plot:
        _plot_fit(result, record, model, args.plot, transient=args.plot_transient)
    return _report_fit(args, result)


def _fixed_from_args(args) -> dict:
    fixed = parse_assignments(args.fix, "--fix")
    if args.af != "max":
        try:
            fixed["A_f"] = float(args.af)
        except ValueError:
            raise CLIError(f"--af must be 'max' or a number; got {args.af!r}") from None
    return fixed


def _problem(args, model, records, masks, fixed=None):
    """The Problem of ``records`` (one or several) with the options' fixed values and masks."""
    from duffsym.identify import Problem

    fixed = _fixed_from_args(args) if fixed is None else fixed
    if len(records) == 1:
        ((mask, info),) = masks
        return Problem(model, records[0], fixed=fixed, mask=mask, mask_info=info)
    use = any(m is not None for m, _ in masks)
    full = [m if m is not None else [False] * r.n_times for (m, _), r in zip(masks, records)]
    return Problem(
        model, records, fixed=fixed, mask=full if use else None, mask_info=next((i for _, i in masks if i), None)
    )


def _report_fit(args, result) -> CommandResult:
    """The fit's JSON (the contract's keys first) and summary; its success is the exit code."""
    notes = () if result.success else (f"duffsym fit: the fit did not succeed: {result.status}: {result.message}",)
    return CommandResult(
        "fit",
        _contract_fields(result.to_dict()),
        result.summary,
        exit_code=0 if result.success else 1,
        notes=notes,
        value=result,
    )


def _run_fit_campaign(args) -> CommandResult:
    """``duffsym fit A.csv B.csv ...`` or ``--manifest``: one parameter set for every record."""
    from duffsym.cli.fit_campaign import campaign_records, hold_unseen_rates, plot_campaign
    from duffsym.identify import fit

    if args.mask not in (None, "none", "auto"):
        raise CLIError("--mask FILE is for one record; a campaign takes --mask none or auto (found per record)")
    pairs = campaign_records(args, read_record)
    check_outputs(args, [p for p, _ in pairs] + [args.manifest])
    records = [r for _, r in pairs]
    model = fit_model(args)
    fixed, held = hold_unseen_rates(model, records, _fixed_from_args(args), args.quiet)
    problem = _problem(args, model, records, [mask_from_args(args.mask, r) for r in records], fixed)
    if not args.quiet:
        err(
            f"fitting one {model.name}{' + ' + ', '.join(model.effects) if model.effects else ''} parameter set to "
            f"{len(records)} records ({sum(r.n_times for r in records)} samples)"
        )
    result = fit(
        problem,
        n_starts=args.starts,
        rng=args.seed,
        max_wall_time=args.time_limit,
        progress=None if args.quiet else (lambda msg: err(f"  {msg}")),
    ).with_sampling(records)
    if held:
        result = dataclasses.replace(result, defaults_applied={**result.defaults_applied, "eta": held})
    if result.flags:
        err("duffsym fit: note: " + "; ".join(f["message"] for f in result.flags))
    if args.out:
        save_fit(result, args.out, "fit")
    if args.plot:
        plot_campaign(result, records, args.plot)
    return _report_fit(args, result)


def _contract_fields(d: dict) -> dict:
    """The fit JSON with the contract's keys first (model, effects, params, stderr, nrmse, status, success)."""
    head = ("model", "effects", "params", "stderr", "nrmse", "status", "success")
    return {**{k: d[k] for k in head if k in d}, **{k: v for k, v in d.items() if k not in head}}


def _plot_fit(result, record, model, path, transient: bool = False) -> None:
    """Measured and fitted loops: one steady full-stroke cycle where the input repeats, else one window
    (``duffsym.plot.windows.loop_windows``), or the whole record, start-up included, with ``transient``."""
    import numpy as np

    from duffsym.plot.loops import plot_loops, save_figure
    from duffsym.plot.windows import loop_windows
    from duffsym.simulate import Trajectory
    from duffsym.status import Status

    names = tuple(c.name for c in model.inputs)
    u = record.input_matrix(model)
    y_sim = np.asarray(result.y_sim[0], dtype=float)
    windows = None if transient else loop_windows(record.d, count=1)
    sl = windows.slices[0] if windows else slice(0, record.n_times)
    t = np.asarray(record.t)
    shown = (
        "whole record"
        if windows is None
        else (
            f"one steady {windows.describe(t, 0)}"
            if windows.whole_cycles
            else f"one {windows.describe(t, 0)} (the input does not repeat, so no loop closes)"
        )
    )
    common = dict(
        model=model.name,
        t=t[sl],
        x=np.zeros((t[sl].size, 0)),
        u=u[sl],
        params=result.params,
        success=True,
        status=Status.OK,
        message="ok",
        method="data",
        input_names=names,
    )
    measured = Trajectory(y=np.asarray(record.y, dtype=float)[sl], **common)
    fitted = Trajectory(y=y_sim[sl], **common)
    name = f"{record.name or 'record'}{f' ({record.current:g} A)' if record.current is not None else ''}"
    fig = plot_loops(
        [measured, fitted],
        labels=["measured", f"fit, free run (NRMSE {result.nrmse:.3g}, whole record)"],
        styles=[dict(color="0.55", ls="none", marker=".", ms=2.5), dict(color="k", lw=0.9)],
        units=record.units,
        title=f"{name}: measured vs fitted {model.name}\n{shown}",
    )
    if result.mask and np.any(result.mask[0]):
        m = np.zeros(record.n_times, dtype=bool)
        m[sl] = np.asarray(result.mask[0], dtype=bool)[sl]
        axes = fig.axes
        axes[0].plot(u[m, 0], record.y[m], ".", color="tab:red", ms=2, label="masked")
        if len(axes) > 1 and u.shape[1] > 1:
            axes[1].plot(u[m, 1], record.y[m], ".", color="tab:red", ms=2)
        axes[0].legend(fontsize="small")
    save_figure(fig, path)


def cmd_validate(args) -> int:
    return show(run_validate(args), args.json)


def run_validate(args) -> CommandResult:
    """``duffsym validate``'s work (notes on stderr, the figure), its result not yet printed."""
    from duffsym.data.sanity import range_notes, valid_part
    from duffsym.identify import load_result, validate
    from duffsym.identify.fitdata import score_valid

    check_outputs(args, [args.fit, args.data], options=("plot",))
    result = load_result(args.fit)
    require_success(result, args)
    record = read_record(args, args.data)
    valid = None if getattr(args, "keep_invalid", False) else valid_part(record)
    if valid is not None:
        record = valid.record
    val = score_valid(validate(result, record), record, None if valid is None else valid.mask)
    notes = range_notes(result.extras.get("training_ranges", {}), record)
    if valid is not None and not valid.report.ok:
        err(f"duffsym validate: note: {valid.report.summary()}; left out of the score (--keep-invalid keeps them)")
    for note in notes:
        err(f"duffsym validate: note: {note}: an extrapolation")
    if args.plot and _drawable(val, record):  # a poor prediction (R² < 0) is drawn too: that is when it is looked at
        _plot_validation(val, record, args.plot)
    extra = {"range_notes": notes, **({"data_sanity": valid.to_dict()} if valid is not None else {})}
    failed = () if val.success else (f"duffsym validate: the validation did not succeed: {val.message}",)
    return CommandResult(
        "validate", {**val.to_dict(), **extra}, val.summary, exit_code=0 if val.success else 1, notes=failed, value=val
    )


def _positive_seconds(text: str) -> float:
    import argparse
    import math

    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds; got {text!r}")
    return value


def _drawable(val, record) -> bool:
    """Whether the free run of ``val`` covers ``record`` with finite values (it may still be a failed prediction)."""
    import numpy as np

    y = np.asarray(val.y_sim, dtype=float)
    return y.shape == (record.n_times,) and bool(np.all(np.isfinite(y)))


def _plot_validation(val, record, path) -> None:
    """Measured vs predicted over the record, a zoom on the largest error, loops of cycles or windows."""
    from duffsym.plot import save_figure
    from duffsym.plot.prediction import plot_prediction

    level = f" ({record.current:g} A)" if record.current is not None else ""
    fig = plot_prediction(
        record.t,
        record.d,
        record.velocity(),
        record.y,
        val.y_sim,
        units=record.units,
        title=f"{val.model} fit predicting {record.name or 'the record'}{level}",
    )
    save_figure(fig, path)


def register(sub) -> None:
    _register_fit(sub)
    _register_validate(sub)


def _register_fit(sub) -> None:
    s = sub.add_parser("fit", help="identify a model's parameters from a measured record (collocation + IPOPT)")
    s.add_argument(
        "data",
        nargs="*",
        help="CSV with a header: time, displacement, force (+ velocity, current); see "
        "--columns. Several files (or --manifest): one parameter set fitted to all of them, each record "
        "with its own initial state and its labels (a constant current/voltage column)",
    )
    s.add_argument(
        "--manifest",
        help="a CSV/JSON manifest of the records to fit together (as for duffsym batch: file, "
        "name, columns, and labels such as current or voltage)",
    )
    add_model_arguments(s)
    s.add_argument(
        "--fix",
        action="append",
        metavar="NAME=VALUE",
        help="hold parameters fixed (repeat or "
        "comma-separate); k3 = 0 by default (not identifiable from one sine amplitude)",
    )
    s.add_argument(
        "--af",
        default="max",
        help="A_f: 'max' (= max|y|, the paper's choice; the scaling symmetry makes it unidentifiable) or a value",
    )
    s.add_argument(
        "--mask",
        default="none",
        help="none, auto (the deadzone after velocity reversals, paper Fig. 8) "
        "or a file with one 0/1 per sample (1 = leave out of the objective)",
    )
    s.add_argument("--add", help="effects to add to the model, comma-separated (see duffsym.effects)")
    s.add_argument(
        "--decimate",
        default="auto",
        help="auto (default: a record of more than 4000 samples is fitted at "
        "the lowest rate keeping 99.7%% of the force's and displacement's variance; the rate is reported), off, "
        "or the largest factor allowed",
    )
    s.add_argument(
        "--keep-invalid",
        action="store_true",
        help="keep clipped or frozen stretches in the fit and its "
        "score (by default they are found, reported and left out)",
    )
    s.add_argument("--starts", type=int, default=1, help="multistart: number of starts (default 1)")
    s.add_argument("--seed", type=int, default=0, help="seed of the multistart")
    s.add_argument(
        "--time-limit",
        type=_positive_seconds,
        metavar="SECONDS",
        help="wall-clock budget of the "
        "IPOPT solves: past it the fit stops with a message naming the phase (a bound restart that runs "
        "out keeps the converged fit it started from); default none",
    )
    add_file_arguments(s)
    s.add_argument("--out", help="write the fit as JSON (usable by `duffsym validate`)")
    s.add_argument(
        "--plot",
        help="loop plot of measured vs fitted (PNG/PDF): one steady full-stroke cycle where the "
        "input repeats, else one window (a sweep, a random record); several records: one panel each",
    )
    s.add_argument("--plot-transient", action="store_true", help="plot the whole record, start-up included")
    s.add_argument("--json", action="store_true", help="print the fit as one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_fit, run=run_fit)


def _register_validate(sub) -> None:
    s = sub.add_parser("validate", help="free-run error of a saved fit on another record")
    s.add_argument("fit", help="FIT.json written by `duffsym fit --out`")
    s.add_argument("data", help="CSV record to validate on")
    s.add_argument("--force", action="store_true", help="use a fit marked success: false")
    s.add_argument(
        "--keep-invalid",
        action="store_true",
        help="score clipped or frozen stretches too (by default they are found, reported and left out)",
    )
    add_file_arguments(s)
    s.add_argument(
        "--plot",
        help="figure (PNG/PDF): measured vs predicted over time, a zoom on the largest error, "
        "and loops of whole cycles (or of windows, where the input does not repeat)",
    )
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_validate, run=run_validate)
