"""``duffsym fit`` and ``duffsym validate``: identify a model from a record, and score a saved fit on another."""
from __future__ import annotations

from duffsym._cli_common import (
    CLIError,
    _add_file_arguments,
    _add_model_arguments,
    _emit_json,
    _err,
    _fit_model,
    _check_outputs,
    _mask_from_args,
    _parse_assignments,
    _read_record,
    _require_success,
    _save_fit,
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
            _err(f"duffsym fit: note: {line}")
    return data


def cmd_fit(args) -> int:
    from duffsym.identify import Problem, fit
    from duffsym.identify.fitdata import finish_fit

    _check_outputs(args, [args.data, None if args.mask in (None, "none", "auto") else args.mask])
    full_record = _read_record(args, args.data)
    model = _fit_model(args)
    fixed = _parse_assignments(args.fix, "--fix")
    if args.af != "max":
        try:
            fixed["A_f"] = float(args.af)
        except ValueError:
            raise CLIError(f"--af must be 'max' or a number; got {args.af!r}") from None
    mask, mask_info = _mask_from_args(args.mask, full_record)
    data = _prepared(args, full_record, mask)
    record, mask = data.record, data.mask
    problem = Problem(model, record, fixed=fixed, mask=mask, mask_info=mask_info)
    if not args.quiet:
        _err(f"fitting {model.name}{' + ' + ', '.join(model.effects) if model.effects else ''} to {args.data} "
             f"({record.t.size} samples)")
    result = fit(problem, n_starts=args.starts, rng=args.seed,
                 progress=None if args.quiet else (lambda msg: _err(f"  {msg}"))).with_sampling([record])
    result = finish_fit(result, data, model)
    if record.metadata.get("sampling", {}).get("rebuilt") and not args.quiet:
        _err(f"duffsym fit: note: {record.metadata['sampling']['rule']}")
    if result.flags:
        _err("duffsym fit: note: " + "; ".join(f["message"] for f in result.flags))
    if args.out:
        _save_fit(result, args.out, "fit")
    if args.plot:
        _plot_fit(result, record, model, args.plot, transient=args.plot_transient)
    if args.json:
        _emit_json(_contract_fields(result.to_dict()))
    else:
        print(result.summary())
    if not result.success:
        _err(f"duffsym fit: the fit did not succeed: {result.status}: {result.message}")
        return 1
    return 0


def _contract_fields(d: dict) -> dict:
    """The fit JSON with the contract's keys first (model, effects, params, stderr, nrmse, status, success)."""
    head = ("model", "effects", "params", "stderr", "nrmse", "status", "success")
    return {**{k: d[k] for k in head if k in d}, **{k: v for k, v in d.items() if k not in head}}


def _plot_fit(result, record, model, path, transient: bool = False) -> None:
    """Measured and fitted loops: one steady full-stroke cycle (``duffsym.plot.loops.steady_window``), or the
    whole record, start-up included, with ``transient``."""
    import numpy as np

    from duffsym.plot.loops import plot_loops, save_figure, steady_window
    from duffsym.simulate import Trajectory, input_matrix

    names = tuple(c.name for c in model.inputs)
    u = input_matrix(model, record.t, record.inputs_for(model))
    y_sim = np.asarray(result.y_sim[0], dtype=float)
    window = None if transient else steady_window(record.d)
    sl = window or slice(0, record.n_times)
    t = np.asarray(record.t)
    shown = "whole record" if window is None else f"one steady cycle, t = {t[sl][0]:.3g}-{t[sl][-1]:.3g} s"
    common = dict(model=model.name, t=t[sl], x=np.zeros((t[sl].size, 0)), u=u[sl], params=result.params,
                  success=True, status="ok", message="ok", method="data", input_names=names)
    measured = Trajectory(y=np.asarray(record.y, dtype=float)[sl], **common)
    fitted = Trajectory(y=y_sim[sl], **common)
    name = f"{record.name or 'record'}{f' ({record.current:g} A)' if record.current is not None else ''}"
    fig = plot_loops([measured, fitted], labels=["measured", f"fit, free run (NRMSE {result.nrmse:.3g}, whole record)"],
                     styles=[dict(color="0.55", ls="none", marker=".", ms=2.5), dict(color="k", lw=0.9)],
                     units=record.units, title=f"{name}: measured vs fitted {model.name}, {shown}")
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
    from duffsym.identify import load_result, validate

    from duffsym.data.sanity import range_notes, valid_part
    from duffsym.identify.fitdata import score_valid

    result = load_result(args.fit)
    _require_success(result, args)
    record = _read_record(args, args.data)
    valid = None if getattr(args, "keep_invalid", False) else valid_part(record)
    if valid is not None:
        record = valid.record
    val = score_valid(validate(result, record), record, None if valid is None else valid.mask)
    notes = range_notes(result.extras.get("training_ranges", {}), record)
    if valid is not None and not valid.report.ok:
        _err(f"duffsym validate: note: {valid.report.summary()}; left out of the score (--keep-invalid keeps them)")
    for note in notes:
        _err(f"duffsym validate: note: {note}: an extrapolation")
    if args.json:
        extra = {"range_notes": notes, **({"data_sanity": valid.to_dict()} if valid is not None else {})}
        _emit_json({**val.to_dict(), **extra})
    else:
        print(val.summary())
    if not val.success:
        _err(f"duffsym validate: the free run failed: {val.message}")
        return 1
    return 0


def register(sub) -> None:
    s = sub.add_parser("fit", help="identify a model's parameters from a measured record (collocation + IPOPT)")
    s.add_argument("data", help="CSV with a header: time, displacement, force (+ velocity, current); see --columns")
    _add_model_arguments(s)
    s.add_argument("--fix", action="append", metavar="NAME=VALUE", help="hold parameters fixed (repeat or "
                   "comma-separate); k3 = 0 by default (not identifiable from one sine amplitude)")
    s.add_argument("--af", default="max", help="A_f: 'max' (= max|y|, the paper's choice; the scaling symmetry makes "
                   "it unidentifiable) or a value")
    s.add_argument("--mask", default="none", help="none, auto (the deadzone after velocity reversals, paper Fig. 8) "
                   "or a file with one 0/1 per sample (1 = leave out of the objective)")
    s.add_argument("--add", help="effects to add to the model, comma-separated (see duffsym.effects)")
    s.add_argument("--decimate", default="auto", help="auto (default: a record of more than 4000 samples is fitted at "
                   "the lowest rate keeping 99.7%% of the force's and displacement's variance; the rate is reported), off, "
                   "or the largest factor allowed")
    s.add_argument("--keep-invalid", action="store_true", help="keep clipped or frozen stretches in the fit and its "
                   "score (by default they are found, reported and left out)")
    s.add_argument("--starts", type=int, default=1, help="multistart: number of starts (default 1)")
    s.add_argument("--seed", type=int, default=0, help="seed of the multistart")
    _add_file_arguments(s)
    s.add_argument("--out", help="write the fit as JSON (usable by `duffsym validate`)")
    s.add_argument("--plot", help="loop plot of measured vs fitted (PNG/PDF): one steady full-stroke cycle")
    s.add_argument("--plot-transient", action="store_true", help="plot the whole record, start-up included")
    s.add_argument("--json", action="store_true", help="print the fit as one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_fit)

    s = sub.add_parser("validate", help="free-run error of a saved fit on another record")
    s.add_argument("fit", help="FIT.json written by `duffsym fit --out`")
    s.add_argument("data", help="CSV record to validate on")
    s.add_argument("--force", action="store_true", help="use a fit marked success: false")
    s.add_argument("--keep-invalid", action="store_true", help="score clipped or frozen stretches too (by default "
                   "they are found, reported and left out)")
    _add_file_arguments(s)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_validate)
