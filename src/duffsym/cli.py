"""The ``duffsym`` command line (see docs: the stable contract).

Thin: every subcommand calls the public Python API. ``--json`` prints one JSON object on stdout
and nothing else there; messages go to stderr. Bad input exits non-zero with one line, no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

from duffsym.errors import DuffsymError

EXIT_ERROR = 2

#: Modules that add subcommands: each defines ``register(subparsers)``, which adds its parser(s)
#: with ``set_defaults(func=...)``; ``func(args)`` returns the exit code. They reuse this module's
#: helpers (``_err``, ``_emit_json``, ``_read_record``, ``_add_file_arguments``, ``CLIError``).
COMMAND_MODULES = (
    "duffsym.effects.command",      # effects
    "duffsym.diagnose.command",     # diagnose, ladder
    "duffsym.uncertainty.command",  # sample
    "duffsym.sindy.command",        # sindy
)


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


# ---------------------------------------------------------------------------------------- models
def cmd_models(args) -> int:
    from duffsym.model.library import MODELS, get_model

    rows = []
    for name in MODELS:
        m = get_model(name)
        rows.append({"model": name, "description": m.description, "params": list(m.param_names),
                     "inputs": [c.name for c in m.inputs], "output": m.output_name})
    if args.json:
        _emit_json({"models": rows})
    else:
        for r in rows:
            print(f"{r['model']:<14} {r['description']}")
            print(f"{'':<14} inputs {', '.join(r['inputs'])} -> output {r['output']}; params {', '.join(r['params'])}")
    return 0


# ---------------------------------------------------------------------------------------- derive
def cmd_derive(args) -> int:
    from duffsym.derive.report import derivation_report

    model = _fit_model(args)  # the model with --add effects, so the report shows what they change

    report = derivation_report(model)
    if args.json:
        _emit_json(report.to_dict())
    elif args.latex:
        print(report.to_latex())
    else:
        print(report.to_text())
    return 0


# ---------------------------------------------------------------------------------------- simulate
def _excitation(args, signal: str):
    from duffsym.excitation import BandLimitedRandom, Multisine, Sine

    rms = args.amplitude / math.sqrt(2)  # --amplitude is the peak of a sine; multisine/random get the same RMS
    if args.excitation == "sine":
        return Sine(args.amplitude, args.frequency, signal=signal)
    if args.excitation == "multisine":
        return Multisine.random_phase(rms, args.frequency, args.f_max, args.lines, rng=args.seed, signal=signal)
    return BandLimitedRandom(rms=rms, f_max=args.f_max, duration=args.duration, seed=args.seed, signal=signal)


def _simulation_columns(model):
    """CSV column names per the contract: time, displacement, velocity, force for the damper models."""
    names = {"d": "displacement", "d_dot": "velocity", "d_ddot": "acceleration"}
    inputs = [names.get(c.name, "input" if c.order == 0 else f"input_{c.name}") for c in model.inputs]
    output = "force" if model.output_name == "y" and "d" in model.signals else "output"
    return inputs, output


def cmd_simulate(args) -> int:
    import numpy as np

    from duffsym.model.library import get_model
    from duffsym.model.presets import TABLE2_N, table2_params
    from duffsym.simulate import simulate

    n = args.n
    if args.voltage is not None:
        if args.model != "mr-damper":
            raise CLIError("--voltage selects a Table 2 row of the mr-damper model; drop --model or --voltage")
        if n is not None and n != TABLE2_N:
            raise CLIError(f"Table 2 was identified with n = {TABLE2_N}; drop --n or give parameters with --param")
    model = get_model(args.model, n)
    params = table2_params(args.voltage) if args.voltage is not None else {}
    params.update(_parse_assignments(args.param, "--param"))
    pvec = model.param_vector(params, fill_defaults=True)
    if args.dt <= 0 or not math.isfinite(args.dt):
        raise CLIError(f"--dt must be a positive number of seconds; got {args.dt}")
    duration = args.duration if args.periods is None else args.periods / args.frequency
    if duration <= 0 or not math.isfinite(duration):
        raise CLIError(f"the duration must be positive; got {duration}")
    t = np.arange(int(round(duration / args.dt)) + 1) * args.dt
    exc = _excitation(args, next(iter(model.signals)))
    traj = simulate(model, pvec, t, exc, substeps=args.substeps if args.substeps == "auto" else int(args.substeps))
    in_cols, out_col = _simulation_columns(model)
    header = ["time", *in_cols, out_col]
    data = np.column_stack([traj.t, traj.u, traj.y])
    written = []
    if args.out:
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savetxt(out, data, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
        written.append(str(out))
    if args.plot:
        from duffsym.plot.loops import plot_loops, save_figure

        period = 1.0 / args.frequency if args.excitation == "sine" else None
        fig = plot_loops(traj, period=period, labels=[f"{model.name}"])
        save_figure(fig, args.plot)
        written.append(str(args.plot))
    summary = {"model": model.name, "params": traj.params, "n_samples": int(t.size), "dt": args.dt,
               "excitation": args.excitation, "status": traj.status, "success": traj.success,
               "max_abs_output": float(np.max(np.abs(traj.y))), "substeps_total": int(traj.substeps.sum()),
               "files": written}
    if args.json:
        _emit_json(summary)
    else:
        if not args.out:
            print(",".join(header))
            np.savetxt(sys.stdout, data, delimiter=",", fmt="%.10g")
        _err(f"{traj.summary()}" + (f"; wrote {', '.join(written)}" if written else ""))
    return 0


# ---------------------------------------------------------------------------------------- fit / validate
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


def cmd_fit(args) -> int:
    from duffsym.identify import Problem, fit

    record = _read_record(args, args.data)
    model = _fit_model(args)
    fixed = _parse_assignments(args.fix, "--fix")
    if args.af != "max":
        try:
            fixed["A_f"] = float(args.af)
        except ValueError:
            raise CLIError(f"--af must be 'max' or a number; got {args.af!r}") from None
    mask, mask_info = _mask_from_args(args.mask, record)
    problem = Problem(model, record, fixed=fixed, mask=mask, mask_info=mask_info)
    if not args.quiet:
        _err(f"fitting {model.name}{' + ' + ', '.join(model.effects) if model.effects else ''} to {args.data} "
             f"({record.t.size} samples)")
    result = fit(problem, n_starts=args.starts, rng=args.seed)
    if args.out:
        result.save(args.out)
    if args.plot:
        _plot_fit(result, record, model, args.plot)
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


def _plot_fit(result, record, model, path) -> None:
    import numpy as np

    from duffsym.plot.loops import plot_loops, save_figure
    from duffsym.simulate import Trajectory, input_matrix

    names = tuple(c.name for c in model.inputs)
    u = input_matrix(model, record.t, record.inputs_for(model))
    y_sim = np.asarray(result.y_sim[0], dtype=float)
    common = dict(model=model.name, t=record.t, x=np.zeros((record.t.size, 0)), u=u, params=result.params,
                  success=True, status="ok", message="ok", method="data", input_names=names)
    measured = Trajectory(y=np.asarray(record.y, dtype=float), **common)
    fitted = Trajectory(y=y_sim, **common)
    fig = plot_loops([measured, fitted], labels=["measured", f"fit, free run (NRMSE {result.nrmse:.3g})"],
                     styles=[dict(color="0.55", ls="none", marker=".", ms=2.5), dict(color="k", lw=0.9)])
    if result.mask and np.any(result.mask[0]):
        m = np.asarray(result.mask[0], dtype=bool)
        axes = fig.axes
        axes[0].plot(u[m, 0], record.y[m], ".", color="tab:red", ms=2, label="masked")
        if len(axes) > 1 and u.shape[1] > 1:
            axes[1].plot(u[m, 1], record.y[m], ".", color="tab:red", ms=2)
        axes[0].legend(fontsize="small")
    save_figure(fig, path)


def cmd_validate(args) -> int:
    from duffsym.identify import load_result, validate

    result = load_result(args.fit)
    record = _read_record(args, args.data)
    val = validate(result, record)
    if args.json:
        _emit_json(val.to_dict())
    else:
        print(val.summary())
    if not val.success:
        _err(f"duffsym validate: the free run failed: {val.message}")
        return 1
    return 0


# ---------------------------------------------------------------------------------------- reproduce
def _find_studies(start: Path) -> Path | None:
    for folder in (start, *start.parents):
        candidate = folder / "studies" / "run_all.py"
        if candidate.is_file():
            return candidate
    return None


def cmd_reproduce(args) -> int:
    runner = Path(args.studies) / "run_all.py" if args.studies else _find_studies(Path.cwd())
    if runner is None or not runner.is_file():
        raise CLIError("no studies/run_all.py found from the current folder upwards; run `duffsym reproduce` "
                       "inside a duffsym checkout or pass --studies PATH/TO/studies")
    cmd = [sys.executable, str(runner)] + (["--smoke"] if args.smoke else [])
    _err(f"running {' '.join(cmd)}")
    proc = subprocess.run(cmd, cwd=runner.parent.parent, env={**os.environ, "MPLBACKEND": "Agg"})
    if proc.returncode != 0:
        raise CLIError(f"the studies failed (exit {proc.returncode}); see the messages above")
    return 0


# ---------------------------------------------------------------------------------------- parser
def _add_model_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--model", default="mr-damper", help="model name (see `duffsym models`; default mr-damper)")
    s.add_argument("--n", type=int, default=None, help="the odd power n (default: the model's, 5 for mr-damper)")


def _add_file_arguments(s: argparse.ArgumentParser) -> None:
    s.add_argument("--columns", help="map roles to the file's columns, e.g. time=t,input=V1,output=V2 "
                   "(roles: time, displacement/input, force/output, velocity, current, voltage)")
    s.add_argument("--units", help="record units, e.g. input=mm,output=N")
    s.add_argument("--nan-policy", choices=("raise", "omit"), default="raise",
                   help="samples with NaN/inf: raise an error (default) or omit them (with a warning)")


def build_parser() -> argparse.ArgumentParser:
    from duffsym import __version__

    p = argparse.ArgumentParser(prog="duffsym", description="Continuous hysteresis models from one symbolic model "
                                "(Tu, Lin & Cheng's Duffing-like equation).")
    p.add_argument("--version", action="version", version=f"duffsym {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    s = sub.add_parser("models", help="list the models")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_models)

    s = sub.add_parser("derive", help="the paper's derivations for a model: state space, Lyapunov, invariant set, "
                       "stability conditions, scaling symmetry")
    _add_model_arguments(s)
    s.add_argument("--add", help="effects to add to the model first, comma-separated (see duffsym effects): the "
                   "report then shows what they do to the Lyapunov argument")
    fmt = s.add_mutually_exclusive_group()
    fmt.add_argument("--latex", action="store_true", help="print LaTeX")
    fmt.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_derive)

    s = sub.add_parser("simulate", help="simulate a model under an excitation; CSV (time, displacement, velocity, "
                       "force) and an optional loop plot")
    _add_model_arguments(s)
    s.add_argument("--voltage", type=float, default=None, help="use the Table 2 row of this voltage (V)")
    s.add_argument("--param", action="append", metavar="NAME=VALUE", help="set parameters (repeat or comma-separate); "
                   "others keep their defaults")
    s.add_argument("--excitation", choices=("sine", "multisine", "random"), default="sine")
    s.add_argument("--amplitude", type=float, default=1.0, help="sine amplitude (peak) of d; default 1")
    s.add_argument("--frequency", type=float, default=2.0, help="sine frequency in Hz (lowest line of a multisine); "
                   "default 2")
    s.add_argument("--f-max", type=float, default=5.0, help="highest frequency of multisine/random, Hz")
    s.add_argument("--lines", type=int, default=10, help="multisine lines")
    s.add_argument("--seed", type=int, default=0, help="seed of random phases/signals")
    s.add_argument("--dt", type=float, default=0.005, help="sampling time, s (paper: 0.005)")
    s.add_argument("--duration", type=float, default=5.0, help="duration, s")
    s.add_argument("--periods", type=float, default=None, help="duration in periods of --frequency (overrides --duration)")
    s.add_argument("--substeps", default="auto", help="RK4 substeps per sample: auto (from the local stiffness) or N")
    s.add_argument("--out", help="CSV file to write (default: stdout)")
    s.add_argument("--plot", help="loop plot file (PNG/PDF)")
    s.add_argument("--json", action="store_true", help="print a JSON summary on stdout (needs --out for the data)")
    s.set_defaults(func=cmd_simulate)

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
    s.add_argument("--starts", type=int, default=1, help="multistart: number of starts (default 1)")
    s.add_argument("--seed", type=int, default=0, help="seed of the multistart")
    _add_file_arguments(s)
    s.add_argument("--out", help="write the fit as JSON (usable by `duffsym validate`)")
    s.add_argument("--plot", help="loop plot of measured vs fitted (PNG/PDF)")
    s.add_argument("--json", action="store_true", help="print the fit as one JSON object")
    s.add_argument("--quiet", action="store_true", help="no progress messages")
    s.set_defaults(func=cmd_fit)

    s = sub.add_parser("validate", help="free-run error of a saved fit on another record")
    s.add_argument("fit", help="FIT.json written by `duffsym fit --out`")
    s.add_argument("data", help="CSV record to validate on")
    _add_file_arguments(s)
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_validate)

    s = sub.add_parser("reproduce", help="run the studies and regenerate every figure and number")
    s.add_argument("--smoke", action="store_true", help="quick run with small settings (for CI)")
    s.add_argument("--studies", help="path of the studies folder (default: found from the current folder upwards)")
    s.set_defaults(func=cmd_reproduce)

    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return p


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except DuffsymError as exc:
        _err(f"duffsym {args.command}: error: {exc}")
        return EXIT_ERROR
    except (OSError, ValueError) as exc:
        if args.debug:
            raise
        _err(f"duffsym {args.command}: error: {exc}")
        return EXIT_ERROR
    except KeyboardInterrupt:
        _err("interrupted")
        return 130
    except Exception as exc:  # an unexpected failure: one line, the traceback only on --debug
        if args.debug:
            raise
        _err(f"duffsym {args.command}: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback "
             "and please report it)")
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
