"""``duffsym effects``: list the effects catalogue."""
from __future__ import annotations


def cmd_effects(args) -> int:
    from duffsym.cli import _emit_json
    from duffsym.effects import CATALOGUE

    rows = [{"effect": name, "physics": e.physics, "signature": e.signature} for name, e in CATALOGUE.items()]
    if args.json:
        _emit_json({"effects": rows})
    else:
        width = max(len(r["effect"]) for r in rows)
        for r in rows:
            print(f"{r['effect']:<{width}}  {r['physics']}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("effects", help="list the physical effects that can be added to a model (fit --add, ladder)")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_effects)
