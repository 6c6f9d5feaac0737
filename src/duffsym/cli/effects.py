"""``duffsym effects``: list the effects catalogue and the extensions outside it (physics, parameters with units and
bounds, residual signature)."""

from __future__ import annotations


def cmd_effects(args) -> int:
    from duffsym.cli.common import emit_json
    from duffsym.effects import CATALOGUE, EXTENSIONS

    rows = [e.describe() for e in CATALOGUE.values()]
    extra = [e.describe() for e in EXTENSIONS.values()]
    if args.json:
        emit_json({"effects": rows, "extensions": extra})
        return 0
    width = max(len(r["effect"]) for r in rows + extra)
    _print_rows(rows, width, args.verbose)
    print("\noutside the catalogue (fit --add takes them; the diagnosis and the ladder never try them):")
    _print_rows(extra, width, args.verbose)
    return 0


def _print_rows(rows: list[dict], width: int, verbose: bool) -> None:
    for r in rows:
        print(f"{r['effect']:<{width}}  {r['physics']}")
        if verbose:
            pad = " " * (width + 2)
            print(f"{pad}form:      {r['form']}")
            for p in r["parameters"]:
                print(
                    f"{pad}param:     {p['name']} [{p['unit']}] in [{p['lower']:g}, {p['upper']:g}], "
                    f"default {p['default']:g}: {p['description']}"
                )
            print(f"{pad}signature: {r['signature']}")
            print(f"{pad}guess:     {r['initial_guess']}")


def register(sub) -> None:
    s = sub.add_parser("effects", help="list the physical effects that can be added to a model (fit --add, ladder)")
    s.add_argument("--json", action="store_true", help="print one JSON object: every effect with its parameters")
    s.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="also show each effect's form, parameters (unit, bounds), residual signature and initial guess",
    )
    s.set_defaults(func=cmd_effects)
