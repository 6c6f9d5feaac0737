"""Study s13 — hysteresis as a component: the Duffing-like element inside a structure, on the public benchmarks.

Bouc–Wen hysteretic benchmark (``duffsym benchmark bouc-wen`` with its defaults,
:mod:`duffsym.benchmark.bouc_wen`): a mass with a cubic and quintic spring whose restoring force
includes the rate-independent variant of the paper's MR-damper element (Eq. 12, n = 3, its time the
path of the mass's displacement, :func:`duffsym.model.library.path_time`) with a directional damping
(``directional-damping``, :class:`duffsym.effects.mechanical.DirectionalDamping`: x'' += -dir_c d' |x'|),
driven by the mass's own motion (:mod:`duffsym.model.structure`), estimated on the training multisine
only (equation-error start by variable projection, then the output-error collocation fit), scored by
RMSE in metres on the validation multisine (periodic steady state: two periods of the same input are
run before the scored one) and the sine sweep (from rest). Three more rows, estimated and scored the
same way in the same run: the path element without the directional damping (``direction=""``, the
previous default), the paper's rate-dependent Eq. 12 element with a cubic spring
(``BoucWenOptions(element="rate", powers=(3,), direction="", ee_random_starts=32)``, the default
before that), and a
**reference** that is not a duffsym model: the benchmark's own Bouc–Wen law (nu = 1) as the element,
equation-error start only. With the directional damping and its springs at zero the path element *is*
a Bouc–Wen element of exponent 1 (and the fit lands there: k1 = k2 = c3 = 0); the reference row shows
what the benchmark's law reaches with the equation-error start alone. The loop figure drives the path
element and Eq. 12 alone by d = sin(2 pi f t) at 1 Hz and 30 Hz: the path element's loops coincide.

Silverbox (the three official scores, :mod:`duffsym.benchmark.silverbox`): the model is study
``s10``'s (Eq. 1 + the effects its ladder chose, refitted on the estimation data only); its saved
parameters (``data/derived/s10_silverbox.json``, the last step within the ladder's rule) are scored
here on ``multisine_test``, ``arrow_full`` and ``arrow_no_extrapolation``, first 50 samples skipped.
Without s10's derived file the study runs ``duffsym benchmark silverbox`` (the same effects, estimated
stepwise; ~150 s).

Files: ``data/derived/s13_structure_benchmarks.{npz,json}``; figures
``paper/figures/s13_structure_benchmarks_bouc_wen.png`` (multisine test: measured and simulated
displacement, and the error) and ``..._scores.png`` (duffsym's scores beside the published ones);
numbers ``paper/output/s13_*.tex``. Without the data the study prints how to get them and exits 0.
"""
from __future__ import annotations

import json
import sys
import time
from dataclasses import asdict, dataclass, field

import numpy as np

import _common as C
import paths

STUDY = "s13_structure_benchmarks"


@dataclass(frozen=True)
class Config:
    """Settings of study s13: the benchmark options (defaults = the CLI's) and the Silverbox source."""

    bouc_wen: dict = field(default_factory=dict)     # BoucWenOptions overrides ({}: the CLI defaults)
    silverbox: dict = field(default_factory=dict)    # SilverboxOptions overrides (when s10's file is absent)
    silverbox_from_s10: bool = True
    compare: bool = True                             # also the rate-dependent element and the Bouc-Wen reference
    reference_samples: int = 8192                    # samples of the reference's equation-error start
    reference_random_starts: int = 4

    @classmethod
    def smoke(cls) -> "Config":
        from duffsym.benchmark import BoucWenOptions, SilverboxOptions

        return cls(bouc_wen=asdict(BoucWenOptions.smoke()), silverbox=asdict(SilverboxOptions.smoke()),
                   silverbox_from_s10=False, reference_samples=2000, reference_random_starts=0)

    def summary(self) -> str:
        return f"s13 config: bouc-wen {self.bouc_wen or 'CLI defaults'}; silverbox from s10: {self.silverbox_from_s10}"


def _data(name: str):
    from duffsym.data import external_data_dir
    from duffsym.errors import DataError

    try:
        folder = external_data_dir() / name
    except DataError:
        return None
    return folder if folder.is_dir() else None


def _bouc_wen(cfg):
    from duffsym.benchmark import BoucWenOptions
    from duffsym.benchmark.bouc_wen import RATE_RANDOM_STARTS, bouc_wen_model, run_bouc_wen, score
    from duffsym.data.loaders import load_bouc_wen

    folder = _data("bouc_wen_benchmark")
    if folder is None:
        return None, {}, []
    opts = BoucWenOptions(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.bouc_wen.items()})
    res = run_bouc_wen(folder, opts, progress=lambda m: print(f"  {m}", flush=True))
    test = load_bouc_wen(folder, part="multisine", unit="mm")
    _, y_hat = score(bouc_wen_model(opts), res.params, test, "multisine", opts.transient_periods)
    rows = [_row("structure + rate-independent Duffing-like element (path time) + directional damping"
                 if opts.direction else "structure + rate-independent Duffing-like element (path time)", res)]
    if cfg.compare:
        from dataclasses import replace

        if opts.direction:
            print("  the path element without the directional damping", flush=True)
            plain = run_bouc_wen(folder, replace(opts, direction=""))
            rows.append(_row("structure + rate-independent Duffing-like element (path time)", plain))
        print("  the rate-dependent element (Eq. 12 as published, cubic spring)", flush=True)
        rate = run_bouc_wen(folder, replace(opts, element="rate", powers=(3,), direction="",
                                           ee_random_starts=RATE_RANDOM_STARTS if opts.ee_random_starts else 0))
        rows.append(_row("structure + Eq. 12 element (rate-dependent)", rate))
        print("  reference: the benchmark's own Bouc-Wen law as the element", flush=True)
        rows.append(_reference(cfg, folder, opts))
    return res, {"bw_t": np.asarray(test.t), "bw_y": np.asarray(test.y) * 1e-3, "bw_yhat": y_hat}, rows


def _row(label, res) -> dict:
    d = res.to_dict()
    return {"label": label, "scores": d["scores"], "n_params": d["n_params"], "n_free": d["details"].get("n_free"),
            "seconds": d["seconds"], "equation_error_nrmse": d["details"].get("equation_error_nrmse"),
            "oe_nrmse": d["details"].get("oe_nrmse"), "params": d["params"], "reference": False}


def bouc_wen_reference_element():
    """REFERENCE ONLY, not a duffsym model: the benchmark's generator law (nu = 1) as a two-state element,
    z' = alpha d' - beta (gamma |d'| z + delta d' |z|) in the state x2 = z (x1 is an unused constant), so the
    same composition, equation-error start and scorer can run it."""
    import sympy as sp

    from duffsym.model.core import SymbolicModel
    from duffsym.model.library import D, D_DOT, X1, X2
    from duffsym.model.symbols import ParamSpec

    spec = lambda n, v, lo, hi: ParamSpec(name=n, latex=n, default=v, lower=lo, upper=hi, unit="1",  # noqa: E731
                                          description="Bouc-Wen reference")
    params = (spec("bw_alpha", 30.0, 0.0, 1e4), spec("bw_beta", 1.0, 0.0, 1e3), spec("bw_gamma", 0.5, -1e2, 1e2),
              spec("bw_delta", -0.5, -1e2, 1e2))
    a, b, g, dl = (p.symbol for p in params)
    dd = D_DOT.symbol
    return SymbolicModel(name="bouc-wen-reference", states=(X1, X2), inputs=(D, D_DOT), params=params,
                         rhs=(sp.Integer(0), a * dd - b * (g * sp.Abs(dd) * X2 + dl * dd * sp.Abs(X2))), output=X2,
                         position=X1, velocity=X2, description="REFERENCE: the benchmark's Bouc-Wen law")


def _reference(cfg, folder, opts) -> dict:
    from duffsym.benchmark.bouc_wen import score
    from duffsym.data.loaders import load_bouc_wen
    from duffsym.identify.structure import equation_error_start
    from duffsym.model.structure import mass_spring_damper, structure

    t0 = time.perf_counter()
    eq, params = mass_spring_damper(())
    model = structure(bouc_wen_reference_element(), equation=eq, params=params, name="structure-bouc-wen-reference")
    train = load_bouc_wen(folder, part="train", unit="mm")
    a = opts.estimation_start
    start = equation_error_start(train.slice(a, a + cfg.reference_samples), model,
                                 n_random=cfg.reference_random_starts, spread=10.0)
    ee = start.pop("_equation_nrmse")
    scores = {kind: score(model, start, load_bouc_wen(folder, part=kind, unit="mm"), kind, opts.transient_periods)[0]
              for kind in ("multisine", "sinesweep")}
    return {"label": "REFERENCE: the benchmark's own Bouc-Wen law as the element (not a duffsym model)",
            "scores": scores, "n_params": model.n_params, "n_free": model.n_params,
            "seconds": time.perf_counter() - t0, "equation_error_nrmse": ee, "oe_nrmse": None,
            "params": {k: float(v) for k, v in start.items()}, "reference": True}


def loops(freqs=(1.0, 30.0), per_cycle: int = 400) -> dict:
    """The path element (eps 1e-4 of the slow drive's velocity amplitude) and Eq. 12, both with the O(1)
    coefficients below, driven alone by d = sin(2 pi f t): their force over the third cycle at each f."""
    from duffsym.model.library import mr_damper, path_time
    from duffsym.simulate import simulate

    p = dict(c1=1.5, c2=0.5, c3=0.4, k1=2.0, k2=1.0, k3=0.0, A_f=1.0)
    els = {"path": path_time(mr_damper(3), 1e-4 * 2 * np.pi * freqs[0]), "rate": mr_damper(3)}
    out = {}
    for key, el in els.items():
        for f in freqs:
            t = np.arange(3 * per_cycle + 1) / (per_cycle * f)
            w = 2 * np.pi * f
            d = np.sin(w * t)
            tr = simulate(el, p, t, {"d": d, "d_dot": w * np.cos(w * t)})
            out[f"loop_{key}_{f:g}"] = np.c_[d, tr.y][-per_cycle - 1:]
    return out


def _silverbox(cfg):
    from duffsym.benchmark import SilverboxOptions
    from duffsym.benchmark.silverbox import PUBLISHED, build, run_silverbox, score_silverbox

    folder = _data("silverbox")
    if folder is None:
        return None
    s10 = paths.derived_dir() / "s10_silverbox.json"
    if cfg.silverbox_from_s10 and s10.is_file():
        meta = json.loads(s10.read_text())
        step = [s for s in meta["steps"] if not s.get("beyond_rule")][-1]
        model = build(step["effects"])
        t0 = time.perf_counter()
        scores = score_silverbox(folder / "SNLS80mV.csv", model, step["params"])
        return {"benchmark": "silverbox", "unit": "mV", "scores": scores, "model": "duffing-gain",
                "effects": step["effects"], "n_params": model.n_params, "seconds": time.perf_counter() - t0,
                "source": "s10's ladder and refit (data/derived/s10_silverbox.json)",
                "published": [{"name": p.name, "scores": p.scores, "source": p.source} for p in PUBLISHED]}
    opts = SilverboxOptions(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.silverbox.items()})
    res = run_silverbox(folder, opts, progress=lambda m: print(f"  {m}", flush=True)).to_dict()
    res["source"] = "duffsym benchmark silverbox" + (" (smoke settings)" if cfg.silverbox else "")
    return res


def compute(cfg: Config) -> dict:
    t0 = time.perf_counter()
    bw, arrays, rows = _bouc_wen(cfg)
    if bw is not None:
        arrays.update(loops())
    sb = _silverbox(cfg)
    meta = dict(study=STUDY, **C.provenance(cfg), bouc_wen=None if bw is None else bw.to_dict(), bouc_wen_rows=rows,
                silverbox=sb, seconds=time.perf_counter() - t0)
    files = C.write_derived(STUDY, arrays or {"empty": np.zeros(1)}, meta)
    return dict(meta=meta, files=files)


def read() -> tuple[dict, dict]:
    return C.read_derived(STUDY)


def plot() -> list:
    arrays, meta = read()
    out = []
    with C.style() as plt:
        if "bw_y" in arrays:
            bw = meta["bouc_wen"]
            t, y, yh = arrays["bw_t"], 1e3 * arrays["bw_y"], 1e3 * arrays["bw_yhat"]
            fig, axes = plt.subplots(2, 1, figsize=(6.4, 4.2), sharex=True)
            sl = slice(0, 1500)
            axes[0].plot(t[sl], y[sl], color="0.4", lw=1.2, label="benchmark (validation multisine)")
            axes[0].plot(t[sl], yh[sl], color="C0", lw=0.7, label="duffsym structure model (CLI defaults)")
            axes[0].set_ylabel("displacement [mm]")
            axes[0].legend(fontsize=7, loc="upper right")
            axes[1].plot(t[sl], y[sl] - yh[sl], color="C3", lw=0.6)
            axes[1].set_ylabel("error [mm]")
            axes[1].set_xlabel("time [s] (first 1500 of 8192 samples)")
            axes[0].set_title(f"Bouc-Wen multisine test: RMSE {bw['scores']['multisine']:.3g} m "
                              f"(dynoNet 4.52e-05 m), {bw['n_params']} parameters", fontsize=8)
            out.append(C.save(fig, STUDY, "bouc_wen"))
        fig, axes = plt.subplots(1, 2, figsize=(6.4, 3.8))
        for ax, key, unit in ((axes[0], "bouc_wen", "m"), (axes[1], "silverbox", "mV")):
            res = meta.get(key)
            if not res:
                ax.set_axis_off()
                continue
            names = list(res["scores"])
            x = np.arange(len(names))
            rows = meta.get("bouc_wen_rows") if key == "bouc_wen" and meta.get("bouc_wen_rows") else [
                {"label": "duffsym", "scores": res["scores"]}]
            width = 0.6 / len(rows)
            for i, row in enumerate(rows):
                ax.bar(x - 0.3 + width * (i + 0.5), [row["scores"][n] for n in names], width,
                       color=("C0", "0.35", "0.8")[i % 3], hatch="//" if row.get("reference") else None,
                       label=_short(row["label"]))
            for j, p in enumerate(res["published"][:2]):
                vals = [p["scores"].get(n, np.nan) for n in names]
                ax.plot(x + 0.38, vals, "_", ms=14, mew=2, color=f"C{j + 1}", label=p["name"][:40])
            ax.set_yscale("log")
            ax.set_xticks(x)
            ax.set_xticklabels([n.replace("_", "\n") for n in names], fontsize=6)
            ax.set_ylabel(f"test RMSE [{unit}]")
            ax.set_title(key.replace("_", "-") + " (bars: duffsym; dashes: published)", fontsize=7)
            allv = [v for r in rows for v in r["scores"].values()] + [
                v for p in res["published"][:2] for v in p["scores"].values()]
            ax.set_ylim(0.5 * min(allv), 1.6 * max(allv))
            ax.legend(fontsize=5, loc="upper center", bbox_to_anchor=(0.5, -0.28))
        out.append(C.save(fig, STUDY, "scores"))
        keys = sorted(k for k in arrays if k.startswith("loop_"))
        if keys:
            fig, axes = plt.subplots(1, 2, figsize=(6.4, 2.8), sharey=True)
            for ax, kind, title in ((axes[0], "path", "path-time element (rate-independent)"),
                                    (axes[1], "rate", "Eq. 12 element (rate-dependent)")):
                for j, k in enumerate(kk for kk in keys if kk.startswith(f"loop_{kind}_")):
                    f = k.rsplit("_", 1)[1]
                    ax.plot(arrays[k][:, 0], arrays[k][:, 1], lw=(2.0, 0.8)[j % 2], color=("0.6", "C3")[j % 2],
                            ls=("-", "--")[j % 2], label=f"d = sin(2 pi {f} Hz t)")
                ax.set_title(title, fontsize=8)
                ax.set_xlabel("drive d")
                ax.legend(fontsize=6)
            axes[0].set_ylabel("element force y = A_f x2")
            out.append(C.save(fig, STUDY, "loops"))
    return out


def _short(label: str) -> str:
    if label.startswith("REFERENCE"):
        return "reference: Bouc-Wen law as element"
    if "directional" in label:
        return "path-time element + directional damping"
    return "path-time element" if "path" in label else ("Eq. 12 element" if "Eq. 12" in label else label[:30])


def write_numbers(meta: dict) -> list:
    files = []
    bw, sb = meta.get("bouc_wen"), meta.get("silverbox")
    if bw:
        files += [C.write_number(STUDY, "bw_multisine", f"{bw['scores']['multisine']:.3g}"),
                  C.write_number(STUDY, "bw_sinesweep", f"{bw['scores']['sinesweep']:.3g}"),
                  C.write_number(STUDY, "bw_nparams", str(bw["n_params"])),
                  C.write_number(STUDY, "bw_seconds", f"{bw['seconds']:.0f}")]
    if sb:
        for k, v in sb["scores"].items():
            files.append(C.write_number(STUDY, f"sb_{k}", f"{v:.3f}"))
    rows = []
    for r in meta.get("bouc_wen_rows") or ([] if not bw else [{"label": "structure + Duffing-like element",
                                                               "scores": bw["scores"], "n_params": bw["n_params"]}]):
        rows.append(f"{'Bouc--Wen' if not rows else ''} & {_short(r['label'])} ({r['n_params']} par.) & "
                    f"{r['scores']['multisine']:.3g} & {r['scores']['sinesweep']:.3g} & m \\\\")
    if bw:
        for p in bw["published"]:
            name = p["name"].replace("&", r"\&")
            rows.append(f" & {name} & {p['scores'].get('multisine', float('nan')):.3g} & -- & m \\\\")
    rr = {("rate" if "Eq. 12" in r["label"] else "ref" if r.get("reference") else "dir" if "directional" in r["label"]
           else "path"): r
          for r in meta.get("bouc_wen_rows") or []}
    for key, r in rr.items():
        files += [C.write_number(STUDY, f"bw_{key}_multisine", f"{r['scores']['multisine']:.3g}"),
                  C.write_number(STUDY, f"bw_{key}_sinesweep", f"{r['scores']['sinesweep']:.3g}"),
                  C.write_number(STUDY, f"bw_{key}_seconds", f"{r['seconds']:.0f}")]
    files.append(C.write_number(STUDY, "table_bw", "\n".join(rows)))
    return files


def summarize(meta: dict) -> str:
    lines = ["s13 structure + element on the public benchmarks"]
    bw, sb = meta.get("bouc_wen"), meta.get("silverbox")
    if bw:
        lines.append(f"  Bouc-Wen ({bw['n_params']} parameters, {bw['seconds']:.0f} s): multisine "
                     f"{bw['scores']['multisine']:.3g} m, sine sweep {bw['scores']['sinesweep']:.3g} m "
                     f"(dynoNet 4.52e-5, PNLSS 1.87e-5); target <= 4.5e-5: "
                     f"{'met' if bw['scores']['multisine'] <= 4.5e-5 else 'NOT met'}")
        for r in meta.get("bouc_wen_rows") or []:
            lines.append(f"    {r['label']}: {r['n_params']} parameters, multisine {r['scores']['multisine']:.3g} m, "
                         f"sine sweep {r['scores']['sinesweep']:.3g} m, equation error {r['equation_error_nrmse']:.3f}, "
                         f"{r['seconds']:.0f} s")
    else:
        lines.append("  Bouc-Wen: data absent, skipped")
    if sb:
        lines.append("  Silverbox (" + sb.get("source", "") + "): " + ", ".join(
            f"{k} {v:.3f} mV" for k, v in sb["scores"].items()) + " (SUBNET arrow 1.406 / 0.316 mV)")
    else:
        lines.append("  Silverbox: data absent, skipped")
    return "\n".join(lines)


def main(argv=None, *, smoke: bool = False) -> int:
    if argv is None and smoke:
        argv = ["--smoke"]
    args = C.parse_args(argv, __doc__.splitlines()[0])
    if not args.plot_only and _data("bouc_wen_benchmark") is None and _data("silverbox") is None:
        print("s13: skipped: neither ../shared/data/external/bouc_wen_benchmark/ (train.h5, test.h5 from "
              "https://github.com/forgi86/dynonet examples/BW or the 4TU record doi:10.4121/12967592) nor "
              "silverbox/ (https://www.nonlinearbenchmark.org/benchmarks/silverbox) is there; point "
              "DUFFSYM_EXTERNAL_DATA at the folder holding them. No outputs written.")
        return 0
    return C.run_study(argv, doc=__doc__, label="s13", config=Config, compute=compute, plot=plot,
                       write_numbers=write_numbers, summarize=summarize, read=read, announce=True, args=args)


if __name__ == "__main__":
    sys.exit(main())
