"""s04: the paper's statements about parameter influence, measured on simulated loops.

Sect. 2 describes how each parameter of the Duffing-like equation shapes the loops of Fig. 3, and
Sect. 3 how the MR damper parameters of Table 1 shape those of Fig. 6. Each statement is turned
into a number measured with :mod:`duffsym.plot.loops` on the last cycle of a simulation, and a
verdict. Where the simulation contradicts the paper the verdict says so, with the numbers.

Fig. 3's excitation is not stated in the paper; the statements are checked at 0.5, 1 and 2 Hz
(unit amplitude) and a statement holds only where it holds at each of them. Fig. 6 is at 0.25 Hz,
unit amplitude, as the paper states.

Outputs: ``data/derived/s04_paper_claims.json``, ``paper/output/s04_claims_table.tex`` (one row per
statement), ``s04_n_hold.tex``, ``s04_n_claims.tex`` and ``s04_claim_<name>.tex`` (the measured numbers).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path
from typing import Callable

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from duffsym import Sine, duffing_like, mr_damper, simulate  # noqa: E402
from duffsym.plot.loops import LoopMetrics, trajectory_loop_metrics  # noqa: E402
from duffsym.model.presets import (  # noqa: E402
    FIG3_BASE, FIG3_CHANGES, FIG3_N, TABLE1_BASE, TABLE1_FREQUENCY_HZ, TABLE1_N, TABLE1_SWEEPS,
)

FIG3_FREQUENCIES = (0.5, 1.0, 2.0)
SAMPLES_PER_PERIOD = 1000
PERIODS = 5  # from rest; the last one is measured (transients decay within 1-2 periods here)


@lru_cache(maxsize=None)
def fig3_metrics(frequency: float, change: str | None) -> LoopMetrics:
    """Loop metrics of the Fig. 3 benchmark (``change=None``) or of one of its one-at-a-time changes."""
    n, params = FIG3_N, dict(FIG3_BASE)
    if change == "n":
        n = int(FIG3_CHANGES["n"])
    elif change is not None:
        params[change] = FIG3_CHANGES[change]
    period = 1.0 / frequency
    t = np.arange(PERIODS * SAMPLES_PER_PERIOD + 1) * (period / SAMPLES_PER_PERIOD)
    traj = simulate(duffing_like(n), params, t, Sine(1.0, frequency))
    return trajectory_loop_metrics(traj, period)


@lru_cache(maxsize=None)
def fig6_metrics(name: str, value: float) -> LoopMetrics:
    """Loop metrics of a Table 1 set: the base values with ``name`` set to ``value`` (``n`` builds the model)."""
    n, params = TABLE1_N, dict(TABLE1_BASE)
    if name == "n":
        n = int(value)
    else:
        params[name] = value
    period = 1.0 / TABLE1_FREQUENCY_HZ
    t = np.arange(PERIODS * SAMPLES_PER_PERIOD + 1) * (period / SAMPLES_PER_PERIOD)
    traj = simulate(mr_damper(n), params, t, Sine(1.0, TABLE1_FREQUENCY_HZ))
    return trajectory_loop_metrics(traj, period)


def sweep(name: str) -> list[tuple[float, LoopMetrics]]:
    values = next(v for p, v in TABLE1_SWEEPS.values() if p == name) if name != "n" else TABLE1_SWEEPS["g"][1]
    return [(v, fig6_metrics(name, v)) for v in values]


@dataclass(frozen=True)
class Verdict:
    claim: str
    source: str
    holds: bool
    measured: str


def _rel(a: float, b: float) -> float:
    return (a - b) / abs(b)


def _fig3_each(test: Callable[[float], tuple[bool, str]]) -> tuple[bool, str]:
    results = [test(f) for f in FIG3_FREQUENCIES]
    return all(ok for ok, _ in results), "; ".join(f"{f:g} Hz: {text}" for f, (_, text) in zip(FIG3_FREQUENCIES, results))


# ------------------------------------------------------------------------------------ Fig. 3 claims
def claim_k1_area_most() -> tuple[bool, str]:
    def one(f):
        base = fig3_metrics(f, None).area_v
        change = {k: _rel(fig3_metrics(f, k).area_v, base) for k in ("k1", "alpha", "beta")}
        ok = abs(change["k1"]) > max(abs(change["alpha"]), abs(change["beta"]))
        return ok, ", ".join(f"{k} {v:+.0%}" for k, v in change.items())
    return _fig3_each(one)


def claim_alpha_reduces_width() -> tuple[bool, str]:
    def one(f):
        r = _rel(fig3_metrics(f, "alpha").width_v, fig3_metrics(f, None).width_v)
        return r < 0, f"width {r:+.0%}"
    return _fig3_each(one)


def claim_stiffness_controls_width() -> tuple[bool, str]:
    """k1, alpha and beta each change the d'-y loop width by more than 5 %."""
    def one(f):
        base = fig3_metrics(f, None).width_v
        change = {k: _rel(fig3_metrics(f, k).width_v, base) for k in ("k1", "alpha", "beta")}
        return all(abs(v) > 0.05 for v in change.values()), ", ".join(f"{k} {v:+.1%}" for k, v in change.items())
    return _fig3_each(one)


def claim_c1_amplifies() -> tuple[bool, str]:
    def one(f):
        r = _rel(fig3_metrics(f, "c1").peak, fig3_metrics(f, None).peak)
        return r > 0.1, f"peak {r:+.0%}"
    return _fig3_each(one)


def claim_delta_reduces() -> tuple[bool, str]:
    def one(f):
        r = _rel(fig3_metrics(f, "delta").peak, fig3_metrics(f, None).peak)
        return r < -0.05, f"peak {r:+.0%}"
    return _fig3_each(one)


def claim_gamma_modulates() -> tuple[bool, str]:
    def one(f):
        r = _rel(fig3_metrics(f, "gamma").peak, fig3_metrics(f, None).peak)
        return abs(r) > 0.05, f"peak {r:+.0%}"
    return _fig3_each(one)


def claim_n_sharpens() -> tuple[bool, str]:
    def one(f):
        a, b = fig3_metrics(f, None).sharpness, fig3_metrics(f, "n").sharpness
        return b > a, f"sharpness {a:.2f} -> {b:.2f}"
    return _fig3_each(one)


def claim_af_scales() -> tuple[bool, str]:
    def one(f):
        ratio = fig3_metrics(f, "A_f").peak / fig3_metrics(f, None).peak
        return abs(ratio - FIG3_CHANGES["A_f"] / FIG3_BASE["A_f"]) < 1e-9, f"peak ratio {ratio:.12g}"
    return _fig3_each(one)


# ------------------------------------------------------------------------------------ Fig. 6 claims
def _monotone(values, increasing=True) -> bool:
    d = np.diff(values)
    return bool(np.all(d > 0) if increasing else np.all(d < 0))


def claim_c2_linearizes() -> tuple[bool, str]:
    s = sweep("c2")
    lin = [m.linearity for _, m in s]
    sharp = [m.sharpness for _, m in s]
    return _monotone(lin) and _monotone(sharp, False), (
        "c2 " + ", ".join(f"{v:g}: R^2 {m.linearity:.3f}, sharpness {m.sharpness:.2f}" for v, m in s))


def claim_c1_steepens_pre_yield() -> tuple[bool, str]:
    s = sweep("c1")
    slopes = [m.pre_yield_slope for _, m in s]
    text = "c1 " + ", ".join(f"{v:g}: {m.pre_yield_slope:+.2f}" for v, m in s)
    neg = [v for v, m in s if m.area_d < 0]
    if neg:
        text += (f"; for c1 = {', '.join(f'{v:g}' for v in neg)} the loop is inverted: the input damper c1 < 0 "
                 "drives the force against the piston velocity, so the d-y area (energy per cycle) is negative: "
                 "the model gives energy back, which no passive damper does")
    return _monotone(slopes), text


def claim_n_steepens_pre_yield() -> tuple[bool, str]:
    s = sweep("n")
    return _monotone([m.pre_yield_slope for _, m in s]), "n " + ", ".join(f"{v:g}: {m.pre_yield_slope:.3f}" for v, m in s)


def claim_c3_lowers_post_yield() -> tuple[bool, str]:
    s = sweep("c3")
    return _monotone([m.post_yield_slope for _, m in s], False), "c3 " + ", ".join(
        f"{v:g}: {m.post_yield_slope:.3f}" for v, m in s)


def claim_k_orientation() -> tuple[bool, str]:
    parts, ok = [], True
    for name in ("k1", "k2", "k3"):
        s = sweep(name)
        orient = {m.orientation for _, m in s}
        ok &= len(orient) == 2
        parts.append(f"{name} " + ", ".join(f"{v:g}: {'ccw' if m.area_v > 0 else 'cw'}" for v, m in s))
    return ok, "; ".join(parts)


def claim_k_area_between_paths() -> tuple[bool, str]:
    """k1, k2, k3 each change the area between the back-and-forth paths of the d'-y loop by more than 50 %."""
    parts, ok = [], True
    energy = []
    for name in ("k1", "k2", "k3"):
        s = sweep(name)
        areas = [abs(m.area_v) for _, m in s]
        spread = (max(areas) - min(areas)) / min(areas)
        ok &= spread > 0.5
        ad = [m.area_d for _, m in s]
        energy.append((max(ad) - min(ad)) / min(ad))
        parts.append(f"{name}: |d'-y area| " + ", ".join(f"{v:g}: {a:.3f}" for (v, _), a in zip(s, areas)))
    text = "; ".join(parts) + (f"; the d-y area (energy per cycle) changes by at most {max(energy):.1%} over "
                               "these sweeps: the k's reshape the velocity-force loop, not the dissipation")
    return ok, text


def claim_amplitude_from_damping_not_stiffness() -> tuple[bool, str]:
    spread = {}
    for name in ("c1", "c2", "c3", "n", "k1", "k2", "k3"):
        peaks = [m.peak for _, m in sweep(name)]
        spread[name] = (max(peaks) - min(peaks)) / min(peaks)
    ok = all(spread[k] > 0.10 for k in ("c1", "c2", "c3", "n")) and all(spread[k] < 0.02 for k in ("k1", "k2", "k3"))
    return ok, "peak spread over each sweep: " + ", ".join(f"{k} {v:.1%}" for k, v in spread.items())


CLAIMS: tuple[tuple[str, str, Callable[[], tuple[bool, str]]], ...] = (
    ("k1 has the major influence on the loop area among the stiffness parameters", "Sect. 2, Fig. 3",
     claim_k1_area_most),
    ("a greater alpha reduces the pre-yield width", "Sect. 2, Fig. 3", claim_alpha_reduces_width),
    ("the stiffness parameters k1, alpha, beta control the loop width (each by > 5 %)", "Sect. 2, Fig. 3",
     claim_stiffness_controls_width),
    ("an increase in c1 amplifies y (> 10 %)", "Sect. 2, Fig. 3", claim_c1_amplifies),
    ("doubling delta reduces y (> 5 %)", "Sect. 2, Fig. 3", claim_delta_reduces),
    ("gamma modulates the y magnitude (> 5 %)", "Sect. 2, Fig. 3", claim_gamma_modulates),
    ("n sharpens the turn between pre- and post-yield", "Sect. 2, Fig. 3", claim_n_sharpens),
    ("A_f expands y (exactly in proportion)", "Sect. 2, Fig. 3", claim_af_scales),
    ("as c2 increases, F_mr behaves more linearly", "Sect. 3, Fig. 6b", claim_c2_linearizes),
    ("as c1 increases the pre-yield slope becomes steeper", "Sect. 3, Fig. 6a", claim_c1_steepens_pre_yield),
    ("as n increases the pre-yield slope becomes steeper", "Sect. 3, Fig. 6g", claim_n_steepens_pre_yield),
    ("an increase in c3 reduces the post-yield slope", "Sect. 3, Fig. 6c", claim_c3_lowers_post_yield),
    ("k1, k2, k3 turn the loops clockwise or counter-clockwise", "Sect. 3, Fig. 6d-f", claim_k_orientation),
    ("k1, k2, k3 change the area between the back-and-forth paths (d'-y, > 50 %)", "Sect. 3, Fig. 6d-f",
     claim_k_area_between_paths),
    ("c1, c2, c3, n change the F_mr amplitude (> 10 %), k1, k2, k3 do not notably (< 2 %)", "Sect. 3, Fig. 6",
     claim_amplitude_from_damping_not_stiffness),
)


def evaluate() -> list[Verdict]:
    out = []
    for text, source, fn in CLAIMS:
        holds, measured = fn()
        out.append(Verdict(text, source, bool(holds), measured))
    return out


_TEX = {"\\": r"\textbackslash{}", "_": r"\_", "%": r"\%", "^": r"\^{}", "&": r"\&", "#": r"\#", ">": r"$>$",
        "<": r"$<$", "|": r"\textbar{}", "{": r"\{", "}": r"\}", "$": r"\$", "~": r"\textasciitilde{}"}


def _tex_escape(s: str) -> str:
    """Plain text as LaTeX text, each special character replaced once (``|d'-y area|`` keeps its bars)."""
    return "".join(_TEX.get(ch, ch) for ch in s)


def main(argv=None) -> int:
    import paths

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--smoke", action="store_true", help="same settings as the full run (it takes seconds), "
                        "written apart from it (paper/smoke/)")
    paths.set_mode("smoke" if parser.parse_args(argv).smoke else "full")
    DERIVED, OUTPUT = paths.derived_dir(), paths.output_dir()
    made_by = f"% made by s04_paper_claims, {paths.mode()} run\n"
    verdicts = evaluate()
    DERIVED.mkdir(parents=True, exist_ok=True)
    OUTPUT.mkdir(parents=True, exist_ok=True)
    (DERIVED / "s04_paper_claims.json").write_text(json.dumps(
        {"fig3_frequencies_hz": FIG3_FREQUENCIES, "fig6_frequency_hz": TABLE1_FREQUENCY_HZ,
         "verdicts": [asdict(v) for v in verdicts], "run_mode": paths.mode()}, indent=2))
    bold_no = r"\textbf{does not hold}"
    rows = [rf"{_tex_escape(v.claim)} & {v.source} & {'holds' if v.holds else bold_no} \\" for v in verdicts]
    (OUTPUT / "s04_claims_table.tex").write_text("\n".join(rows) + "\n" + made_by)
    n_hold = sum(v.holds for v in verdicts)
    (OUTPUT / "s04_n_hold.tex").write_text(f"{n_hold}%\n" + made_by)
    (OUTPUT / "s04_n_claims.tex").write_text(f"{len(verdicts)}%\n" + made_by)
    for v, (_, _, fn) in zip(verdicts, CLAIMS):
        # the measured numbers of each statement, quotable in the text as \input{output/s04_<claim>}
        (OUTPUT / f"s04_{fn.__name__}.tex").write_text(_tex_escape(v.measured) + "%\n" + made_by)
    print(f"s04: {n_hold} of {len(verdicts)} statements of the paper hold in simulation")
    for v in verdicts:
        print(f"  [{'holds' if v.holds else 'DOES NOT HOLD'}] {v.claim} ({v.source}): {v.measured}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
