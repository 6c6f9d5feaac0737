"""``duffsym simulate``: simulate a model under an excitation (beside :mod:`duffsym.simulate`, which it drives)."""

from __future__ import annotations

import math
import sys

from duffsym.cli.common import (
    CLIError,
    add_model_arguments,
    check_outputs,
    emit_json,
    err,
    parse_assignments,
)


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


def _with_command(model, t, exc, command):
    """The input mapping of a command-driven model: the excitation's channels and the command."""
    chans = {}
    for ch in model.inputs:
        chans[ch.name] = command if ch.signal == "command" else exc.derivative(t, ch.order)
    return chans


#: Most samples ``duffsym simulate`` writes (``--dt 1e-9`` used to fill the memory).
MAX_SIMULATE_SAMPLES = 10_000_000


def _check_excitation_options(args) -> None:
    """One-line errors for excitation options that cannot make a signal."""
    for opt in ("amplitude", "frequency", "f_max", "duration"):
        v = getattr(args, opt)
        if not math.isfinite(v) or (opt != "amplitude" and v <= 0):
            raise CLIError(
                f"--{opt.replace('_', '-')} must be a {'finite' if opt == 'amplitude' else 'positive'} number; got {v}"
            )
    if args.periods is not None and not (math.isfinite(args.periods) and args.periods > 0):
        raise CLIError(f"--periods must be a positive number; got {args.periods}")
    if args.excitation == "multisine":
        if not 1 <= args.lines <= 100_000:
            raise CLIError(f"--lines must be between 1 and 100000; got {args.lines}")
        if args.f_max < args.frequency:
            raise CLIError(
                f"--f-max ({args.f_max:g} Hz) must be at least --frequency ({args.frequency:g} Hz), the "
                "lowest line of the multisine"
            )
    if args.substeps != "auto":
        try:
            sub = int(args.substeps)
        except ValueError:
            raise CLIError(f"--substeps must be 'auto' or a positive integer; got {args.substeps!r}") from None
        if not 1 <= sub <= 100_000:
            raise CLIError(f"--substeps must be between 1 and 100000; got {sub}")


def _command_signal(args, model, t):
    """``(column name, samples)`` of the command for a command-driven model, or ``None`` for the others.

    ``--command`` is a number (held) or a CSV file with a ``time`` column and a ``current`` or
    ``voltage`` column (interpolated linearly onto the simulation's time grid)."""
    import numpy as np

    if "command" not in model.signals:
        if args.command_input is not None:
            raise CLIError(
                f"--command drives the command-driven models (mr-damper-current...); model {model.name} "
                "has no command input: drop --command"
            )
        return None
    if args.command_input is None:
        raise CLIError(
            f"model {model.name} is driven by a command (coil current or voltage): give --command VALUE "
            "(held) or --command FILE.csv (columns time and current or voltage)"
        )
    try:
        level = float(args.command_input)
    except ValueError:
        return _command_file(args.command_input, t)
    if not math.isfinite(level):
        raise CLIError(f"--command must be a finite number or a CSV file; got {args.command_input!r}")
    return "current", np.full(t.size, level)


def _command_file(path, t):
    import numpy as np

    from duffsym._io import read_columns

    cols = read_columns(
        path, {"time": ("time", "t"), "current": ("current",), "voltage": ("voltage",)}, optional=("current", "voltage")
    )
    name = next((n for n in ("current", "voltage") if n in cols), None)
    if name is None:
        raise CLIError(f"{path}: the command file needs a 'current' or a 'voltage' column beside 'time'")
    tc, c = cols["time"], cols[name]
    if tc.size < 2 or np.any(np.diff(tc) <= 0):
        raise CLIError(f"{path}: the 'time' column must increase strictly and have at least two rows")
    if t[-1] > tc[-1] + 1e-12 or t[0] < tc[0] - 1e-12:
        raise CLIError(
            f"{path}: the command covers {tc[0]:g}..{tc[-1]:g} s but the simulation runs "
            f"{t[0]:g}..{t[-1]:g} s; shorten --duration or extend the file"
        )
    return name, np.interp(t, tc, c)


def cmd_simulate(args) -> int:
    import numpy as np

    from duffsym.simulate import simulate

    model, pvec = _simulation_model(args)
    if args.dt <= 0 or not math.isfinite(args.dt):
        raise CLIError(f"--dt must be a positive number of seconds; got {args.dt}")
    _check_excitation_options(args)
    check_outputs(args, [])
    t, duration = _sample_times(args)
    _check_signal_cost(args, t.size, duration)
    exc = _excitation(args, next(s for s in model.signals if s != "command"))
    command = _command_signal(args, model, t)
    inputs = exc if command is None else _with_command(model, t, exc, command[1])
    if command is not None and not any(pvec[i] for i, n in enumerate(model.param_names) if n.endswith("_u")):
        err(
            f"note: every field coefficient of {model.name} (the *_u parameters) is 0 at its defaults, so the command "
            "changes nothing; set them with --param (e.g. c1_u=-4,k2_u=-200,A_f_u=0.8) or fit a record"
        )
    traj = simulate(model, pvec, t, inputs, substeps=args.substeps if args.substeps == "auto" else int(args.substeps))
    in_cols, out_col = _simulation_columns(model)
    if command is not None:
        in_cols = [command[0] if c == "input" and ch.signal == "command" else c for c, ch in zip(in_cols, model.inputs)]
    header = ["time", *in_cols, out_col]
    data = np.column_stack([traj.t, traj.u, traj.y])
    written = _write_simulation(args, model, traj, data, header, duration)
    summary = {
        "model": model.name,
        "params": traj.params,
        "n_samples": int(t.size),
        "dt": args.dt,
        "excitation": args.excitation,
        "status": traj.status,
        "success": traj.success,
        "max_abs_output": float(np.max(np.abs(traj.y))),
        "substeps_total": int(traj.substeps.sum()),
        "files": written,
    }
    if args.json:
        emit_json(summary)
    else:
        if not args.out:
            print(",".join(header))
            np.savetxt(sys.stdout, data, delimiter=",", fmt="%.10g")
        err(f"{traj.summary()}" + (f"; wrote {', '.join(written)}" if written else ""))
    return 0


def _simulation_model(args):
    """``(model, parameter vector)``: ``--model``/``--n`` with the Table 2 row of ``--voltage`` and ``--param``
    on top of the defaults."""
    from duffsym.model.library import get_model
    from duffsym.model.presets import TABLE2_N, table2_params

    n = args.n
    if args.voltage is not None:
        if args.model != "mr-damper":
            raise CLIError("--voltage selects a Table 2 row of the mr-damper model; drop --model or --voltage")
        if n is not None and n != TABLE2_N:
            raise CLIError(f"Table 2 was identified with n = {TABLE2_N}; drop --n or give parameters with --param")
    model = get_model(args.model, n)
    params = table2_params(args.voltage) if args.voltage is not None else {}
    params.update(parse_assignments(args.param, "--param"))
    return model, model.param_vector(params, fill_defaults=True)


#: Most sine evaluations (lines x samples) the excitation of ``duffsym simulate`` may take (the lines are summed one
#: by one: 1e9 evaluations took 96 s on a 2-core machine, with three derivatives).
MAX_SINE_EVALUATIONS = 2e8


def _check_signal_cost(args, n_samples: int, duration: float) -> None:
    """A multisine or random excitation is a sum of lines evaluated at every sample: refuse one that would
    take many minutes (the fuzz test found --excitation random --duration 99999 --f-max 1 --dt 1)."""
    if args.excitation == "sine":
        return
    lines = args.lines if args.excitation == "multisine" else args.f_max * duration
    if lines * n_samples > MAX_SINE_EVALUATIONS:
        raise CLIError(
            f"the {args.excitation} excitation has {lines:.3g} lines at {n_samples:.3g} samples "
            f"({lines * n_samples:.2g} sine evaluations, more than {MAX_SINE_EVALUATIONS:.0e}); use fewer lines "
            "(--lines, or a lower --f-max), a larger --dt or a shorter --duration"
        )


def _sample_times(args):
    """``(t, duration)``: the sample times of ``--duration`` (or ``--periods``) at ``--dt``, within
    :data:`MAX_SIMULATE_SAMPLES`."""
    import numpy as np

    duration = args.duration if args.periods is None else args.periods / args.frequency
    if duration <= 0 or not math.isfinite(duration):
        raise CLIError(f"the duration must be positive; got {duration}")
    n_samples = duration / args.dt
    if n_samples > MAX_SIMULATE_SAMPLES:
        raise CLIError(
            f"--duration {duration:g} s at --dt {args.dt:g} s is {n_samples:.3g} samples, more than "
            f"{MAX_SIMULATE_SAMPLES:.0e}; use a larger --dt or a shorter --duration"
        )
    return np.arange(int(round(n_samples)) + 1) * args.dt, duration


def _write_simulation(args, model, traj, data, header, duration) -> list[str]:
    """Write ``--out`` (the CSV) and ``--plot`` (the loops); the files written."""
    import numpy as np

    written = []
    if args.out:
        from duffsym._io import atomic_write

        with atomic_write(args.out) as fh:  # an interrupt leaves the old file (or none), never a truncated one
            np.savetxt(fh, data, delimiter=",", header=",".join(header), comments="", fmt="%.10g")
        written.append(str(args.out))
    if args.plot:
        from duffsym.plot.loops import plot_loops, save_figure

        period = 1.0 / args.frequency if args.excitation == "sine" else None
        what = f"{args.voltage:g} V row of Table 2" if args.voltage is not None else "given parameters"
        shown = f"last of {duration * args.frequency:.3g} cycles" if period else "whole run"
        fig = plot_loops(
            traj,
            period=period,
            labels=[f"{model.name}"],
            title=f"{model.name}, {what}: {args.excitation} {args.amplitude:g} at "
            f"{args.frequency:g} Hz, {shown} (normalised units)",
        )
        save_figure(fig, args.plot)
        written.append(str(args.plot))
    return written


def register(sub) -> None:
    s = sub.add_parser(
        "simulate",
        help="simulate a model under an excitation; CSV (time, displacement, velocity, "
        "force) and an optional loop plot",
    )
    add_model_arguments(s)
    s.add_argument("--voltage", type=float, default=None, help="use the Table 2 row of this voltage (V)")
    s.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="set parameters (repeat or comma-separate); others keep their defaults",
    )
    s.add_argument("--excitation", choices=("sine", "multisine", "random"), default="sine")
    s.add_argument("--amplitude", type=float, default=1.0, help="sine amplitude (peak) of d; default 1")
    s.add_argument(
        "--frequency", type=float, default=2.0, help="sine frequency in Hz (lowest line of a multisine); default 2"
    )
    s.add_argument("--f-max", type=float, default=5.0, help="highest frequency of multisine/random, Hz")
    s.add_argument("--lines", type=int, default=10, help="multisine lines")
    s.add_argument("--seed", type=int, default=0, help="seed of random phases/signals")
    s.add_argument("--dt", type=float, default=0.005, help="sampling time, s (paper: 0.005)")
    s.add_argument("--duration", type=float, default=5.0, help="duration, s")
    s.add_argument(
        "--periods", type=float, default=None, help="duration in periods of --frequency (overrides --duration)"
    )
    s.add_argument(
        "--command",
        dest="command_input",
        default=None,
        metavar="VALUE|FILE.csv",
        help="the command of a command-driven model (mr-damper-current...): a held value (A or V) or a "
        "CSV with columns time and current (or voltage)",
    )
    s.add_argument("--substeps", default="auto", help="RK4 substeps per sample: auto (from the local stiffness) or N")
    s.add_argument("--out", help="CSV file to write (default: stdout)")
    s.add_argument("--plot", help="loop plot file (PNG/PDF)")
    s.add_argument("--json", action="store_true", help="print a JSON summary on stdout (needs --out for the data)")
    s.set_defaults(func=cmd_simulate)
