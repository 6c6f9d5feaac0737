"""``duffsym sample``: emcee posterior of a saved fit on its record (``docs/contract.md``)."""

from __future__ import annotations

import sys
from pathlib import Path


def cmd_sample(args) -> int:
    from duffsym.cli.common import show

    return show(run_sample(args), args.json)


def run_sample(args):
    """``duffsym sample``'s work (chains and figures written, progress on stderr): a :class:`CommandResult`."""
    from duffsym.cli.common import CommandResult, check_outputs, err, read_record, require_success
    from duffsym.identify import load_result

    _check_sample_options(args)
    check_outputs(
        args,
        [args.data, args.fit, None if args.mask in (None, "fit", "none", "auto") else args.mask],
        options=("out", "chains", "corner", "bands"),
    )
    result = load_result(args.fit)
    require_success(result, args)
    record = read_record(args, args.data)
    mask = _sample_mask(args, result, record)
    if not args.quiet:  # stderr: --json keeps stdout to the one JSON object
        err(
            f"sampling {result.model} ({', '.join(result.free)}) on {args.data}: {args.walkers} walkers x "
            f"{args.steps} steps"
        )
    chains, caught = _run_chains(args, result, record, mask)
    out, written = _write_outputs(args, chains, result, record)

    def text() -> str:
        return chains.summary() + (f"\n{out['identifiability']['text']}" if args.identifiability else "")

    notes = [f"wrote {', '.join(written)}"] if written and not args.quiet else []
    notes += [f"warning: {w.message}" for w in caught if not args.quiet and str(w.message) not in chains.warnings]
    return CommandResult("sample", out, text, notes=tuple(notes), value=chains)


def _check_sample_options(args) -> None:
    """The numeric options' ranges (a :class:`CLIError` naming the first out of range)."""
    from duffsym.cli.common import CLIError

    for label, v, least in (("--walkers", args.walkers, 2), ("--steps", args.steps, 2), ("--workers", args.workers, 1)):
        if v is not None and v < least:
            raise CLIError(f"{label} must be at least {least}; got {v}")
    if args.burn is not None and not 0 <= args.burn < args.steps - 1:
        raise CLIError(f"--burn must be in [0, --steps - 1) = [0, {args.steps - 1}); got {args.burn}")
    if not (args.checkpoint_every > 0 and args.checkpoint_every < float("inf")):
        raise CLIError(f"--checkpoint-every must be a positive number of seconds; got {args.checkpoint_every}")
    if args.thin is not None and args.thin < 1:
        raise CLIError(f"--thin must be >= 1; got {args.thin}")


def _sample_mask(args, result, record):
    """The mask of ``--mask`` (None: the fit's own, ``"fit"``), checked against the record's length when the
    fit's stored mask is used."""
    import numpy as np

    from duffsym.cli.common import CLIError

    mask = None
    if args.mask not in ("fit",):
        from duffsym.cli.common import mask_from_args

        mask, _ = mask_from_args(args.mask, record)
    if args.mask in (None, "fit") and result.mask and np.size(result.mask[0]) != record.n_times:
        raise CLIError(
            f"the fit's stored mask has {np.size(result.mask[0])} samples but {args.data} has "
            f"{record.n_times}; sample on the record the fit was made on, or pass --mask none|auto|FILE"
        )
    return mask


def _run_chains(args, result, record, mask):
    """``(chains, caught warnings)``: the emcee run on local workers or a Dask cluster when asked, the steps so
    far kept beside ``--chains`` while it runs."""
    import warnings

    from duffsym.cli.common import CLIError, err
    from duffsym.errors import ConvergenceWarning
    from duffsym.uncertainty.sampler import ChainTooShort, sample

    pool = None
    if (args.workers and args.workers > 1) or args.scheduler:
        from duffsym.engine import Engine  # emcee's pool: local worker processes or a Dask cluster

        pool = Engine(args.workers, scheduler=args.scheduler).start()
    partial = _partial_path(args.chains) if args.chains else None
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            chains = sample(
                result,
                record,
                n_walkers=args.walkers,
                n_steps=args.steps,
                burn=args.burn,
                thin=args.thin,
                noise="ar1" if args.ar1 else "gaussian",
                mask=mask,
                rng=args.seed,
                pool=pool,
                progress=not args.quiet,
                on_short="raise" if args.strict else "warn",
                threads=args.threads,
                moves="stretch" if args.moves == "stretch" else None,
                checkpoint=partial,
                checkpoint_every=args.checkpoint_every,
            )
    except KeyboardInterrupt:
        if partial is not None and partial.exists():
            err(f"interrupted: the steps run so far are in {partial} (duffsym.uncertainty.load_partial_chain)")
        raise
    except ChainTooShort as exc:
        if exc.chains is not None and args.chains:
            exc.chains.save(args.chains)
        raise CLIError(f"{exc} (--strict)") from None
    finally:
        if pool is not None:
            pool.close()
    return chains, caught


def _write_outputs(args, chains, result, record) -> tuple[dict, list[str]]:
    """``(the JSON document, the files written)``: ``--chains``, ``--corner``, ``--bands`` and ``--out``."""
    written = []
    if args.chains:
        written.append(str(chains.save(args.chains)))
        _partial_path(args.chains).unlink(missing_ok=True)
    if args.corner:
        from duffsym.plot.loops import save_figure
        from duffsym.uncertainty.plots import plot_corner

        save_figure(plot_corner(chains), args.corner)
        written.append(args.corner)
    if args.bands:
        from duffsym.plot.loops import save_figure
        from duffsym.uncertainty.plots import plot_bands
        from duffsym.uncertainty.predictive import posterior_predictive

        bands = posterior_predictive(chains, result, record, rng=args.seed)[0]
        try:
            period = record.period
        except (IndexError, ZeroDivisionError, ValueError):
            period = None
        save_figure(plot_bands(bands, period=period, title=f"posterior predictive, {record.name}"), args.bands)
        written.append(args.bands)
    out = chains.to_dict()
    if args.identifiability:
        from duffsym.uncertainty.identifiability import identifiability_report

        out["identifiability"] = identifiability_report(result, record, chains=chains).to_dict()
    out["files"] = written
    if args.out:
        from duffsym._io import write_json_atomic
        from duffsym._json import jsonable

        write_json_atomic(args.out, jsonable(out))
        written.append(args.out)
    return out, written


def _partial_path(chains) -> Path:
    """Where the chain so far is kept while sampling: ``NAME.partial.npz`` beside ``--chains``."""
    p = Path(chains)
    stem = p.name[:-4] if p.name.endswith(".npz") else p.name
    return p.with_name(f"{stem}.partial.npz")


def register(sub) -> None:
    from duffsym.cli.common import add_file_arguments

    s = sub.add_parser(
        "sample",
        help="emcee posterior of a saved fit's free parameters (medians, 90 %% intervals, "
        "tau, ESS, Laplace comparison)",
    )
    s.add_argument("data", help="the CSV record the fit was made on")
    s.add_argument("--fit", required=True, help="FIT.json written by `duffsym fit --out`")
    s.add_argument(
        "--walkers", type=int, default=32, help="number of walkers (default 32; at least 2x the free parameters)"
    )
    s.add_argument(
        "--steps",
        type=int,
        default=8000,
        help="steps per walker (default 8000; emcee wants >= 50 tau "
        "after burn-in, and tau is typically 60-150 steps for a 5-parameter damper fit)",
    )
    s.add_argument("--burn", type=int, default=None, help="steps discarded (default 3 tau, at most a third)")
    s.add_argument(
        "--moves",
        choices=("de", "stretch"),
        default="de",
        help="emcee moves: differential evolution + "
        "snooker (default; shorter tau on correlated posteriors) or the stretch move",
    )
    s.add_argument("--thin", type=int, default=None, help="thinning of the kept chain (default 1)")
    s.add_argument("--seed", type=int, default=0, help="seed of the walker starts and moves")
    s.add_argument("--ar1", action="store_true", help="AR(1) noise instead of white (samples its coefficient)")
    s.add_argument(
        "--mask",
        default="fit",
        help="fit (default: the mask FIT.json stores, if the fit had one), none, auto "
        "(deadzone, as fit --mask auto) or a file of 0/1 per sample",
    )
    s.add_argument(
        "--workers",
        type=int,
        default=None,
        help="evaluate walkers in this many processes (default: all "
        "walkers in one compiled batch call, usually faster)",
    )
    s.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="evaluate walkers on the workers of this Dask scheduler "
        "(for expensive likelihoods: each evaluation is a task)",
    )
    s.add_argument(
        "--threads",
        type=int,
        default=1,
        help="numba threads of the batch call (default 1: on a busy machine waking threads costs more than the work)",
    )
    s.add_argument("--strict", action="store_true", help="fail (exit 2) when the chain is shorter than 50 tau")
    s.add_argument(
        "--chains",
        help="save the chains (.npz; reload with duffsym.uncertainty.load_chains); while "
        "sampling, the steps so far are kept in NAME.partial.npz, which an interrupt leaves behind",
    )
    s.add_argument(
        "--checkpoint-every",
        type=float,
        default=30.0,
        help="seconds between saves of the partial chain (with --chains; default 30)",
    )
    s.add_argument("--force", action="store_true", help="sample around a fit marked success: false")
    s.add_argument("--corner", help="corner plot file (PNG/PDF)")
    s.add_argument("--bands", help="posterior predictive bands on the loops and the time series (PNG/PDF)")
    s.add_argument(
        "--identifiability",
        action="store_true",
        help="add the identifiability report (symmetry, Fisher spectrum, posterior correlations)",
    )
    add_file_arguments(s)
    s.add_argument("--out", help="write the JSON summary to this file")
    s.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    s.add_argument("--quiet", action="store_true", help="no progress bar or messages")
    s.set_defaults(func=cmd_sample, run=run_sample)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(0)
