"""The ``duffsym`` command line (the stable contract: ``docs/contract.md``).

Thin: this module only builds the parser and turns errors into exit codes. Every subcommand lives
beside the code it drives, in a module listed in :data:`COMMAND_MODULES` that defines
``register(subparsers)``: it adds its parser(s) with ``set_defaults(func=...)``, and ``func(args)``
returns the exit code. Shared helpers (usage errors, JSON output, reading a record, the common
arguments) are in :mod:`duffsym.cli.common`. ``--json`` prints one JSON object on stdout and
nothing else there; messages go to stderr. Bad input exits non-zero with one line, no traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys
import threading
from collections.abc import Iterator

from duffsym.cli.common import EXIT_ERROR, err
from duffsym.errors import DuffsymError

#: Modules that add subcommands, in the order ``duffsym --help`` lists them.
COMMAND_MODULES = (
    "duffsym.cli.models",  # models
    "duffsym.cli.derive",  # derive
    "duffsym.cli.simulate",  # simulate
    "duffsym.cli.fit",  # fit, validate
    "duffsym.cli.reproduce",  # reproduce
    "duffsym.cli.effects",  # effects
    "duffsym.cli.diagnose",  # diagnose, ladder
    "duffsym.cli.compare",  # compare
    "duffsym.cli.discover",  # discover
    "duffsym.cli.sample",  # sample
    "duffsym.cli.sindy",  # sindy
    "duffsym.cli.convert",  # convert
    "duffsym.cli.batch",  # batch
    "duffsym.cli.benchmark",  # benchmark
    "duffsym.cli.invert",  # invert
)


#: Each command, the module that registers it and its one-line help (the same text as the module's own
#: parser, checked by tests/test_cli.py): ``duffsym --help`` lists them without importing any of the
#: modules (their packages pull in SymPy, CasADi and numba: ~1.5 s), and ``duffsym COMMAND`` imports only
#: the module of COMMAND.
COMMANDS = (
    ("models", "duffsym.cli.models", "list the models"),
    (
        "derive",
        "duffsym.cli.derive",
        "the paper's derivations for a model: state space, Lyapunov, invariant "
        "set, stability conditions, scaling symmetry",
    ),
    (
        "simulate",
        "duffsym.cli.simulate",
        "simulate a model under an excitation; CSV (time, displacement, velocity, force) and an optional loop plot",
    ),
    ("fit", "duffsym.cli.fit", "identify a model's parameters from a measured record (collocation + IPOPT)"),
    ("validate", "duffsym.cli.fit", "free-run error of a saved fit on another record"),
    ("reproduce", "duffsym.cli.reproduce", "run the studies and regenerate every figure and number"),
    ("effects", "duffsym.cli.effects", "list the physical effects that can be added to a model (fit --add, ladder)"),
    ("diagnose", "duffsym.cli.diagnose", "where the model fails on a record, and which catalogued effect is missing"),
    (
        "ladder",
        "duffsym.cli.diagnose",
        "base fit, then add the best supported effect and refit, while the "
        "evidence supports it; the error at each step",
    ),
    ("compare", "duffsym.cli.compare", "fit several models on the same records and score them on held-out data"),
    (
        "discover",
        "duffsym.cli.discover",
        "what one parameter set misses across several records (a campaign), found outside the catalogue",
    ),
    (
        "sample",
        "duffsym.cli.sample",
        "emcee posterior of a saved fit's free parameters (medians, 90 %% intervals, tau, ESS, Laplace comparison)",
    ),
    (
        "sindy",
        "duffsym.cli.sindy",
        "SINDy cross-check of the terms of the velocity equation (which terms the data support)",
    ),
    (
        "convert",
        "duffsym.cli.convert",
        "turn a text/CSV/.mat data file into a duffsym CSV record (time, displacement, velocity, force)",
    ),
    (
        "batch",
        "duffsym.cli.batch",
        "run fit, validate, diagnose, ladder or sample on many records (local "
        "processes or a Dask cluster); one result file per record, resumable, with a summary table and figure",
    ),
    (
        "benchmark",
        "duffsym.cli.benchmark",
        "score a public benchmark by its own protocol (silverbox, bouc-wen) beside the published figures",
    ),
    (
        "invert",
        "duffsym.cli.invert",
        "the command (current/voltage) history that makes a fitted model produce a desired force",
    ),
)


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The parser. With ``argv`` (what :func:`main` parses) only the module of the command named in it is
    imported, the others are listed by :data:`COMMANDS`; without, every command module registers its own."""
    from duffsym import __version__

    p = argparse.ArgumentParser(
        prog="duffsym",
        description="Continuous hysteresis models from one symbolic model (Tu, Lin & Cheng's Duffing-like equation).",
    )
    p.add_argument("--version", action="version", version=f"duffsym {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    # not "command": `batch --command fit` has an option of that name, which would rename the command
    sub = p.add_subparsers(dest="subcommand", metavar="COMMAND")
    sub.required = True
    if argv is None:
        for name in COMMAND_MODULES:
            importlib.import_module(name).register(sub)
        return p
    wanted = {module for name, module, _ in COMMANDS if name in argv}
    for name, module, text in COMMANDS:
        if module in wanted:
            wanted.discard(module)
            importlib.import_module(module).register(sub)
        elif name not in sub.choices:
            sub.add_parser(name, help=text)
    return p


def main(argv=None) -> int:
    """Run the command line; Ctrl-C at any point (imports, a cluster starting) is one line and exit 130."""
    try:
        with interrupts_reach_main():
            return _main(argv)
    except KeyboardInterrupt:
        _quiet_dask_shutdown()
        err("interrupted")
        return 130


@contextlib.contextmanager
def interrupts_reach_main() -> Iterator[None]:
    """Within the block, a Ctrl-C that Python would swallow is delivered again to the main thread.

    A ``KeyboardInterrupt`` that lands inside a garbage-collector callback or a ``__del__`` (Dask's
    ``GCDiagnosis`` is one) cannot propagate: Python prints "Exception ignored in ..." with a traceback and
    carries on, so a batch interrupted at that instant ran to its end and exited 0. Such an interrupt is
    raised again in the main thread 50 ms later, once the swallowing code has returned (a timer thread sends
    SIGINT, which also wakes a blocking wait; one swallowed again is delivered again), or when the block ends,
    whichever comes first; nothing is printed for it.
    """
    previous = sys.unraisablehook
    timers: list[threading.Timer] = []

    def redeliver() -> None:
        timer = threading.Timer(0.05, signal.pthread_kill, (threading.main_thread().ident, signal.SIGINT))
        timer.daemon = True
        timers.append(timer)
        timer.start()

    def hook(unraisable) -> None:
        try:
            if isinstance(unraisable.exc_value, KeyboardInterrupt):
                redeliver()
            else:
                previous(unraisable)
        except KeyboardInterrupt:  # the interrupt arrived while this hook ran: deliver it after
            redeliver()

    sys.unraisablehook = hook
    _unblock_sigint()
    handler = _interrupting_handler()
    try:
        yield
    finally:
        sys.unraisablehook = previous
        if handler is not None:
            signal.signal(signal.SIGINT, handler)
        for timer in timers:  # a signal already sent raises here; one not yet sent must not outlive the block
            timer.cancel()
            timer.join()
    if timers:
        raise KeyboardInterrupt


def _unblock_sigint() -> None:
    """Let SIGINT reach the main thread: a library that left it blocked there (a thread start that masks signals
    and does not restore the mask) would keep Ctrl-C, and the redelivery of :func:`interrupts_reach_main`, pending
    until the work ends. Measured once in a full CI rehearsal: the redelivered interrupt did not cut a 30 s sleep
    short, while the same test passed alone and after its neighbouring test files (cause not confirmed)."""
    if threading.current_thread() is threading.main_thread() and hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def _interrupting_handler():
    """Make SIGINT raise KeyboardInterrupt in the main thread (Python's default handler) if something left another
    handler installed (ignored, or a handler that only sets a flag); returns the handler to put back, or None.
    Without it a redelivered interrupt (:func:`interrupts_reach_main`) would not cut a blocking wait short."""
    if threading.current_thread() is not threading.main_thread():
        return None
    current = signal.getsignal(signal.SIGINT)
    if current is signal.default_int_handler:
        return None
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return current if current is not None else signal.default_int_handler


def _quiet_dask_shutdown() -> None:
    """After Ctrl-C, a Dask cluster interrupted while starting logs its shutdown (tracebacks of
    ``Status.init``): silence its loggers if it was imported."""
    import logging

    if "distributed" in sys.modules:
        for name in ("distributed", "tornado", "asyncio"):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)
    spec = sys.modules.get("distributed.deploy.spec")
    if spec is not None and hasattr(spec, "close_clusters"):
        # distributed closes its clusters at exit; one interrupted while starting raises there, and Python
        # prints that as "Exception ignored in atexit callback" with a traceback: close them quietly instead
        import atexit

        atexit.unregister(spec.close_clusters)
        atexit.register(_close_quietly, spec.close_clusters)


def _close_quietly(close) -> None:
    import contextlib
    import io

    with contextlib.suppress(BaseException), contextlib.redirect_stderr(io.StringIO()):
        close()


def _main(argv=None) -> int:
    from duffsym.errors import show_notes

    show_notes()  # expected numerical conditions as one-line notes, not Python's two-line warnings
    parser = build_parser(sys.argv[1:] if argv is None else list(argv))
    args = parser.parse_args(argv)
    value, code = guarded(args, lambda: int(args.func(args) or 0))
    return value if code is None else code


def guarded(args, work):
    """Run ``work()`` for the parsed command ``args`` as the command line does: ``(its value, None)``, or, when
    it raises, ``(None, exit code)`` with the error as one line on stderr (``duffsym NAME: error: ...``; the
    traceback only with ``--debug``). ``duffsym batch`` runs each record's work through this too."""
    name, debug = args.subcommand, getattr(args, "debug", False)
    try:
        return work(), None
    except DuffsymError as exc:
        err(f"duffsym {name}: error: {exc}")
        return None, EXIT_ERROR
    except (OSError, ValueError) as exc:
        if debug:
            raise
        err(f"duffsym {name}: error: {_describe(exc)}")
        return None, EXIT_ERROR
    except KeyboardInterrupt:
        _quiet_dask_shutdown()
        err("interrupted")
        return None, 130
    except RecursionError:
        if debug:
            raise
        err(f"duffsym {name}: error: input nested too deeply to process; check the input files")
        return None, EXIT_ERROR
    except MemoryError:
        if debug:
            raise
        err(f"duffsym {name}: error: out of memory; use a shorter or decimated record")
        return None, EXIT_ERROR
    except Exception as exc:  # an unexpected failure: one line, the traceback only on --debug
        if debug:
            raise
        err(
            f"duffsym {name}: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback "
            "and please report it)"
        )
        return None, 1


def _describe(exc: Exception) -> str:
    """One line for an OS error: the path it concerns (when it has one) and the system's reason."""
    if isinstance(exc, OSError) and exc.strerror:
        where = exc.filename if exc.filename is not None else None
        return f"{where}: {exc.strerror}" if where is not None else exc.strerror
    return str(exc)
