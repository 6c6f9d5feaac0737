"""``duffsym derive``: the paper's derivations for a model (state space, Lyapunov, invariant set, stability,
symmetry)."""

from __future__ import annotations

from duffsym.cli.common import add_model_arguments, emit_json, fit_model


def cmd_derive(args) -> int:
    from duffsym.derive.report import derivation_report

    model = fit_model(args)  # the model with --add effects, so the report shows what they change

    report = derivation_report(model)
    if args.json:
        emit_json(report.to_dict())
    elif args.latex:
        print(report.to_latex())
    else:
        print(report.to_text())
    return 0


def register(sub) -> None:
    s = sub.add_parser(
        "derive",
        help="the paper's derivations for a model: state space, Lyapunov, invariant set, "
        "stability conditions, scaling symmetry",
    )
    add_model_arguments(s)
    s.add_argument(
        "--add",
        help="effects to add to the model first, comma-separated (see duffsym effects): the "
        "report then shows what they do to the Lyapunov argument",
    )
    fmt = s.add_mutually_exclusive_group()
    fmt.add_argument("--latex", action="store_true", help="print LaTeX")
    fmt.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_derive)
