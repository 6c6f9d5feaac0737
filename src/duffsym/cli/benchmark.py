"""``duffsym benchmark silverbox|bouc-wen``: estimate on the benchmark's estimation data, score its test sets."""

from __future__ import annotations

import sys
from dataclasses import replace

from duffsym.cli.common import CLIError, emit_json


def cmd_benchmark(args) -> int:
    from duffsym._io import check_output_path, write_json_atomic
    from duffsym._json import jsonable
    from duffsym.benchmark import BoucWenOptions, SilverboxOptions, run_bouc_wen, run_silverbox
    from duffsym.data.loaders import external_data_dir

    if args.out:
        check_output_path(args.out)
    folder = external_data_dir() / ("silverbox" if args.name == "silverbox" else "bouc_wen_benchmark")
    say = (lambda m: print(m, file=sys.stderr, flush=True)) if not args.quiet else None
    if args.name == "silverbox":
        sb_opts = SilverboxOptions.smoke() if args.smoke else SilverboxOptions()
        res = run_silverbox(folder, sb_opts, progress=say)
    else:
        opts = BoucWenOptions.smoke() if args.smoke else BoucWenOptions()
        if getattr(args, "element", None):
            if args.element == "rate":
                from duffsym.benchmark.bouc_wen import RATE_RANDOM_STARTS

                opts = replace(opts, direction="", ee_random_starts=RATE_RANDOM_STARTS if opts.ee_random_starts else 0)
            opts = replace(opts, element=args.element)
        if getattr(args, "direction", None):
            if opts.element == "rate" and args.direction != "none":
                raise CLIError("--direction applies to the path element only; drop it or use --element path")
            opts = replace(opts, direction="" if args.direction == "none" else args.direction)
        res = run_bouc_wen(folder, opts, progress=say)
    if args.out:
        write_json_atomic(args.out, jsonable(res.to_dict()))
    if args.json:
        emit_json(res.to_dict())
    else:
        print(res.summary())
    return 0


def register(sub) -> None:
    s = sub.add_parser(
        "benchmark",
        help="score a public benchmark by its own protocol (silverbox, bouc-wen) beside the published figures",
    )
    s.add_argument("name", choices=("silverbox", "bouc-wen"), help="the benchmark")
    s.add_argument("--smoke", action="store_true", help="small settings (seconds; scores not comparable)")
    s.add_argument(
        "--element",
        choices=("path", "rate"),
        default=None,
        help="bouc-wen only: the element in the structure, 'path' (default: the rate-independent "
        "path-time variant of Eq. 12) or 'rate' (Eq. 12 as published)",
    )
    s.add_argument(
        "--direction",
        choices=("velocity", "velocity-quadratic", "position", "none"),
        default=None,
        help="bouc-wen, path element only: its directional damping x'' += -dir_c d' g, g = |x'| "
        "('velocity', the default), |x'| x', |x|, or 'none'",
    )
    s.add_argument("--out", help="also write the result JSON to this file")
    s.add_argument("--quiet", action="store_true", help="no progress on stderr")
    s.add_argument("--json", action="store_true", help="print one JSON object")
    s.set_defaults(func=cmd_benchmark)
