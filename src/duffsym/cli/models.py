"""``duffsym models``: the model library (names, parameters, inputs, output)."""

from __future__ import annotations

from duffsym.cli.common import emit_json


def cmd_models(args) -> int:
    from duffsym.model.library import MODELS, get_model

    rows = []
    for name in MODELS:
        m = get_model(name)
        rows.append(
            {
                "model": name,
                "name": name,
                "description": m.description,
                "params": list(m.param_names),
                "inputs": [c.name for c in m.inputs],
                "output": m.output_name,
            }
        )
    if args.json:
        emit_json({"models": rows})
    else:
        w = max(14, *(len(r["model"]) for r in rows))
        for r in rows:
            print(f"{r['model']:<{w}} {r['description']}")
            print(f"{'':<{w}} inputs {', '.join(r['inputs'])} -> output {r['output']}; params {', '.join(r['params'])}")
    return 0


def register(sub) -> None:
    s = sub.add_parser("models", help="list the models")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_models)
