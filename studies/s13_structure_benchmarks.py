"""Study s13 — hysteresis as a component: the Duffing-like element inside a structure, on the public benchmarks.

Bouc–Wen hysteretic benchmark (``duffsym benchmark bouc-wen`` with its defaults,
:mod:`duffsym.benchmark.bouc_wen`): a mass with a cubic spring whose restoring force includes the
paper's MR-damper element (Eq. 12, n = 3) driven by the mass's own motion (the ``structure`` model,
:mod:`duffsym.model.structure`), estimated on the training multisine only (equation-error start by
variable projection, then the output-error collocation fit), scored by RMSE in metres on the
validation multisine (periodic steady state: two periods of the same input are run before the scored
one) and the sine sweep (from rest).

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

    @classmethod
    def smoke(cls) -> "Config":
        from duffsym.benchmark import BoucWenOptions, SilverboxOptions

        return cls(bouc_wen=asdict(BoucWenOptions.smoke()), silverbox=asdict(SilverboxOptions.smoke()),
                   silverbox_from_s10=False)

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
    from duffsym.benchmark.bouc_wen import run_bouc_wen, score
    from duffsym.data.loaders import load_bouc_wen
    from duffsym.model.core import SymbolicModel  # noqa: F401

    folder = _data("bouc_wen_benchmark")
    if folder is None:
        return None, {}
    opts = BoucWenOptions(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg.bouc_wen.items()})
    res = run_bouc_wen(folder, opts, progress=lambda m: print(f"  {m}", flush=True))
    from duffsym.benchmark.bouc_wen import bouc_wen_model

    test = load_bouc_wen(folder, part="multisine", unit="mm")
    _, y_hat = score(bouc_wen_model(opts), res.params, test, "multisine", opts.transient_periods)
    return res, {"bw_t": np.asarray(test.t), "bw_y": np.asarray(test.y) * 1e-3, "bw_yhat": y_hat}


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
    bw, arrays = _bouc_wen(cfg)
    sb = _silverbox(cfg)
    meta = dict(study=STUDY, **C.provenance(cfg), bouc_wen=None if bw is None else bw.to_dict(), silverbox=sb,
                seconds=time.perf_counter() - t0)
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
            axes[0].plot(t[sl], yh[sl], color="C0", lw=0.7, label="structure + Duffing-like element")
            axes[0].set_ylabel("displacement [mm]")
            axes[0].legend(fontsize=7, loc="upper right")
            axes[1].plot(t[sl], y[sl] - yh[sl], color="C3", lw=0.6)
            axes[1].set_ylabel("error [mm]")
            axes[1].set_xlabel("time [s] (first 1500 of 8192 samples)")
            axes[0].set_title(f"Bouc-Wen multisine test: RMSE {bw['scores']['multisine']:.3g} m "
                              f"(dynoNet 4.52e-05 m), {bw['n_params']} parameters", fontsize=8)
            out.append(C.save(fig, STUDY, "bouc_wen"))
        fig, axes = plt.subplots(1, 2, figsize=(6.4, 3.6))
        for ax, key, unit in ((axes[0], "bouc_wen", "m"), (axes[1], "silverbox", "mV")):
            res = meta.get(key)
            if not res:
                ax.set_axis_off()
                continue
            names = list(res["scores"])
            x = np.arange(len(names))
            ax.bar(x - 0.2, [res["scores"][n] for n in names], 0.4, color="C0", label="duffsym")
            for j, p in enumerate(res["published"][:2]):
                vals = [p["scores"].get(n, np.nan) for n in names]
                ax.plot(x + 0.2 * (j + 1) - 0.1, vals, "_", ms=14, mew=2, color=f"C{j + 1}", label=p["name"][:40])
            ax.set_yscale("log")
            ax.set_xticks(x)
            ax.set_xticklabels([n.replace("_", "\n") for n in names], fontsize=6)
            ax.set_ylabel(f"test RMSE [{unit}]")
            ax.set_title(key.replace("_", "-") + " (bars: duffsym; dashes: published)", fontsize=7)
            allv = [v for v in res["scores"].values()] + [v for p in res["published"][:2] for v in p["scores"].values()]
            ax.set_ylim(0.5 * min(allv), 1.6 * max(allv))
            ax.legend(fontsize=5, loc="upper center", bbox_to_anchor=(0.5, -0.32))
        out.append(C.save(fig, STUDY, "scores"))
    return out


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
    if bw:
        rows.append(f"Bouc--Wen & structure + Duffing-like element ({bw['n_params']} par.) & "
                    f"{bw['scores']['multisine']:.3g} & {bw['scores']['sinesweep']:.3g} & m \\\\")
        for p in bw["published"]:
            rows.append(f" & {p['name']} & {p['scores'].get('multisine', float('nan')):.3g} & -- & m \\\\")
    files.append(C.write_number(STUDY, "table_bw", "\n".join(rows)))
    return files


def summarize(meta: dict) -> str:
    lines = ["s13 structure + element on the public benchmarks"]
    bw, sb = meta.get("bouc_wen"), meta.get("silverbox")
    if bw:
        lines.append(f"  Bouc-Wen ({bw['n_params']} parameters, {bw['seconds']:.0f} s): multisine "
                     f"{bw['scores']['multisine']:.3g} m, sine sweep {bw['scores']['sinesweep']:.3g} m "
                     f"(dynoNet 4.52e-5, PNLSS 1.87e-5); target <= 4.5e-5: "
                     f"{'met' if bw['scores']['multisine'] <= 4.52e-5 else 'NOT met'}")
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
