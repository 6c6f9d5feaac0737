"""Start-up (issue 24): ``duffsym --help`` and ``--version`` import none of the heavy packages, the
listed commands and their help are the ones the command modules register, and the facade's names
still resolve (``duffsym.simulate`` stays the function after its submodule is imported)."""

from __future__ import annotations

import argparse
import importlib
import subprocess
import sys

HEAVY = ("sympy", "numpy", "casadi", "numba", "scipy")


def _imported_after(code: str) -> set[str]:
    probe = code + "\nimport sys, json; print(json.dumps(sorted(m for m in sys.modules)))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    import json

    return set(json.loads(out.stdout.strip().splitlines()[-1]))


def test_help_and_version_import_no_heavy_package():
    for argv in (["--help"], ["--version"]):
        mods = _imported_after(
            f"import sys\nfrom duffsym.cli import main\ntry:\n    main({argv!r})\nexcept SystemExit:\n    pass"
        )
        assert not {m.split(".")[0] for m in mods} & set(HEAVY), argv


def test_the_command_table_matches_what_the_modules_register():
    from duffsym.cli import COMMAND_MODULES, COMMANDS

    p = argparse.ArgumentParser()
    sub = p.add_subparsers()
    for m in COMMAND_MODULES:
        importlib.import_module(m).register(sub)
    registered = [(a.dest, a.help) for a in sub._choices_actions]
    assert registered == [(n, h) for n, _, h in COMMANDS]
    owner = {}
    for n, m, _ in COMMANDS:
        q = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(m).register(q)
        owner[n] = n in q.choices
    assert all(owner.values()), owner


def test_a_command_gets_its_full_parser(capsys):
    from duffsym.cli import build_parser

    p = build_parser(["fit", "x.csv", "--time-limit", "5"])
    args = p.parse_args(["fit", "x.csv", "--time-limit", "5"])
    assert args.time_limit == 5.0 and args.func.__name__ == "cmd_fit"


def test_the_facade_names_resolve_lazily():
    import duffsym
    import duffsym.simulate
    from duffsym import Sine, fit, get_model, read_csv, simulate

    assert callable(simulate) and simulate.__name__ == "simulate" and duffsym.simulate is simulate
    assert Sine.__name__ == "Sine" and fit.__name__ == "fit" and callable(get_model) and callable(read_csv)
