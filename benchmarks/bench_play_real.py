"""The play of the real friction damper (issue 22): the play candidates on each BRFD record.

For every record in ``$DUFFSYM_EXTERNAL_DATA/friction_damper_brfd_artslab`` (read by
:func:`duffsym.data.loaders.load_friction_damper_json`): the diagnosis with the play candidates (``backlash``: the
play on the element's input; ``contact-gap``: the gap in series with the element) and ``--mask auto``'s deadzone
mask (``NOMASK=1``: none), the fitted half-width with its standard error
(:func:`duffsym.diagnose.verdict.play_half_width`), the plateau half-width the data show
(:func:`duffsym.effects.inputs.plateau_half_width`), held-out NRMSE before (base model) and after, time.

    NOMASK=1 python benchmarks/bench_play_real.py --model mr-damper-path [--n 5] [--files NAME ...] [--report DIR]

Results (2026-11-27, load ~1.5 on 2 cores), held-out NRMSE base -> contact-gap, h (plateau):
``play_real.json`` (mr-damper-path, no mask): 0.180 -> 0.082, 0.096 +- 0.005 in (0.101); 36 lb 0.197 -> 0.147,
0.090 +- 0.003 (0.113); 0.5 in 0.300 -> 0.117, 0.099 +- 0.007 (0.105); 0.25 Hz 0.184 -> 0.096, 0.095 +- 0.003
(0.106); 9-30 s each. ``play_real_mask.json``: the same with the mask. ``play_real_mr5.json`` / ``_mr11.json``: the
rate-dependent mr-damper (n = 5, 11): the gap helps on two records of four and hurts on the others.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from _provenance import stamp  # benchmarks/ is on sys.path (the script's folder)

HERE = Path(__file__).resolve().parent


def run(path: Path, budget: float | None, candidates, report: Path | None, n: int | None = None,
        model: str = "mr-damper") -> dict:
    import numpy as np

    from duffsym.data.loaders import load_friction_damper_json
    from duffsym.diagnose import diagnose
    from duffsym.effects.inputs import plateau_half_width
    from duffsym.identify.initial import auto_mask

    rec = load_friction_damper_json(path)
    mask, info = auto_mask(rec)
    if os.environ.get("NOMASK") == "1":  # the diagnosis without the deadzone mask (the plain command's default)
        mask = None
    t0 = time.perf_counter()
    from duffsym.model.library import get_model

    dg = diagnose(rec, get_model(model, n), candidates=candidates, mask=mask, sindy=False,
                  deadline=None if budget is None else time.monotonic() + budget, progress=print)
    secs = time.perf_counter() - t0
    if report is not None:
        from duffsym.diagnose.report import write_diagnosis_report

        write_diagnosis_report(dg, rec, report / path.stem)
    from duffsym.diagnose.verdict import play_half_width

    plays = {}
    for c in dg.candidates:
        if c.effect in ("backlash", "contact-gap"):
            h, se = play_half_width(c, rec, dg.y_candidates.get(c.effect))
            plays[c.effect] = dict(nrmse_heldout=c.nrmse_after, success=bool(c.success), message=c.message, h=h,
                                   h_se=se, params=c.params, stderr=c.stderr, seconds=c.seconds)
    return dict(record=path.stem, n=rec.n_times, seconds=secs, nrmse_heldout_base=dg.nrmse_heldout, plays=plays,
                plateau_half_width=plateau_half_width(rec), mask_width=info["median_displacement_width"],
                needed=list(dg.needed), verdict=dg.verdict,
                prepare=dg.prepare.summary() if dg.prepare else "",
                base_check=dg.base_check.to_dict() if dg.base_check else {},
                candidates=[dict(effect=x.effect, nrmse_after=x.nrmse_after, params=x.params, stderr=x.stderr,
                                 success=x.success, message=x.message, seconds=x.seconds) for x in dg.candidates],
                noise=dg.noise, load=os.getloadavg()[0], stroke=float(np.ptp(rec.d)))


def main(argv=None) -> int:
    from duffsym.data import external_data_dir

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--budget", type=float, default=600.0)
    ap.add_argument("--files", nargs="*", default=None)
    ap.add_argument("--candidates", default="backlash,contact-gap")
    ap.add_argument("--n", type=int, default=None, help="the MR-damper power n of the base model")
    ap.add_argument("--model", default="mr-damper", help="the base model (mr-damper-path: rate-independent)")
    ap.add_argument("--report", default=None)
    ap.add_argument("--out", default=str(HERE / "results" / "play_real.json"))
    args = ap.parse_args(argv)
    folder = external_data_dir() / "friction_damper_brfd_artslab"
    files = sorted(folder.glob("*.json")) if not args.files else [folder / f"{f}.json" for f in args.files]
    rows = []
    for p in files:
        r = run(p, args.budget, args.candidates.split(","), Path(args.report) if args.report else None, args.n,
                args.model)
        rows.append(r)
        plays = "; ".join(f"{e}: {p['nrmse_heldout']} h = {p['h']} ± {p['h_se']} {p['message']}"
                          for e, p in r["plays"].items())
        print(f"{r['record']}: base held-out {r['nrmse_heldout_base']:.4g}; {plays} (plateau "
              f"{r['plateau_half_width']:.3g}, mask width {r['mask_width']:.3g})  {r['seconds']:.0f} s", flush=True)
        out = Path(args.out)
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(stamp(dict(runs=rows, budget=args.budget), args), indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())
