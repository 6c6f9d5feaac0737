"""The ``duffsym`` command line (the stable contract: ``docs/contract.md``).

Thin: this module only builds the parser and turns errors into exit codes. Every subcommand lives
beside the code it drives, in a module listed in :data:`COMMAND_MODULES` that defines
``register(subparsers)``: it adds its parser(s) with ``set_defaults(func=...)``, and ``func(args)``
returns the exit code. Shared helpers (usage errors, JSON output, reading a record, the common
arguments) are in :mod:`duffsym._cli_common`. ``--json`` prints one JSON object on stdout and
nothing else there; messages go to stderr. Bad input exits non-zero with one line, no traceback.
"""
from __future__ import annotations

import argparse
import importlib
import sys

# Re-exported for code that imported the helpers from here before they moved to duffsym._cli_common.
from duffsym._cli_common import (  # noqa: F401
    EXIT_ERROR,
    CLIError,
    _add_file_arguments,
    _add_model_arguments,
    _emit_json,
    _err,
    _fit_model,
    _mask_from_args,
    _parse_assignments,
    _parse_mapping,
    _read_record,
)
from duffsym.errors import DuffsymError

#: Modules that add subcommands, in the order ``duffsym --help`` lists them.
COMMAND_MODULES = (
    "duffsym.model.command",        # models
    "duffsym.derive.command",       # derive
    "duffsym.simulate_command",     # simulate
    "duffsym.identify.command",     # fit, validate
    "duffsym.reproduce_command",    # reproduce
    "duffsym.effects.command",      # effects
    "duffsym.diagnose.command",     # diagnose, ladder
    "duffsym.diagnose.compare_command",  # compare
    "duffsym.uncertainty.command",  # sample
    "duffsym.sindy.command",        # sindy
    "duffsym.data.command",         # convert
    "duffsym.campaign.command",     # batch
    "duffsym.benchmark.command",    # benchmark
    "duffsym.control.command",      # invert
)


def build_parser() -> argparse.ArgumentParser:
    from duffsym import __version__

    p = argparse.ArgumentParser(prog="duffsym", description="Continuous hysteresis models from one symbolic model "
                                "(Tu, Lin & Cheng's Duffing-like equation).")
    p.add_argument("--version", action="version", version=f"duffsym {__version__}")
    p.add_argument("--debug", action="store_true", help="show tracebacks of unexpected errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return p


def main(argv=None) -> int:
    from duffsym.errors import show_notes

    show_notes()  # expected numerical conditions as one-line notes, not Python's two-line warnings
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
    except RecursionError:
        if args.debug:
            raise
        _err(f"duffsym {args.command}: error: input nested too deeply to process; check the input files")
        return EXIT_ERROR
    except MemoryError:
        if args.debug:
            raise
        _err(f"duffsym {args.command}: error: out of memory; use a shorter or decimated record")
        return EXIT_ERROR
    except Exception as exc:  # an unexpected failure: one line, the traceback only on --debug
        if args.debug:
            raise
        _err(f"duffsym {args.command}: internal error: {type(exc).__name__}: {exc} (rerun with --debug for the traceback "
             "and please report it)")
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
