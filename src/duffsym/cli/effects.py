"""``duffsym effects``: list the effects catalogue (physics, parameters with units and bounds, residual signature)."""

from __future__ import annotations


def cmd_effects(args) -> int:
    from duffsym.cli.common import emit_json
    from duffsym.effects import CATALOGUE

    rows = [e.describe() for e in CATALOGUE.values()]
    if args.json:
        emit_json({"effects": rows})
        return 0
    width = max(len(r["effect"]) for r in rows)
    for r in rows:
        print(f"{r['effect']:<{width}}  {r['physics']}")
        if args.verbose:
            pad = " " * (width + 2)
            print(f"{pad}form:      {r['form']}")
            for p in r["parameters"]:
                print(
                    f"{pad}param:     {p['name']} [{p['unit']}] in [{p['lower']:g}, {p['upper']:g}], "
                    f"default {p['default']:g}: {p['description']}"
                )
            print(f"{pad}signature: {r['signature']}")
            print(f"{pad}guess:     {r['initial_guess']}")
    return 0


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
