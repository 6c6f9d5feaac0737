"""The diagnosis in words: the verdict on the ranked candidates, and the sentences beside it (the proposal to look
outside the catalogue, the smoothing, the SINDy cross-check, the base fit's check, the inactive effects)."""

from __future__ import annotations

from collections.abc import Sequence

from duffsym.diagnose.noisefloor import BAND_SHARE
from duffsym.diagnose.options import EXACT_FIT, GROWTH, STABILITY_CHECKED, TIE
from duffsym.diagnose.parts import BaseCheck, Candidate, SindyCheck
from duffsym.diagnose.residuals import ResidualAnalysis

#: the play candidates: the play on the element's input (``backlash``), the gap in series with it (``contact-gap``)
PLAY_EFFECTS = ("backlash", "contact-gap")


def play_half_width(c: Candidate, record, y_fit) -> tuple[float | None, float]:
    """The fitted play's half-width and standard error of candidate ``c``: ``bl_h`` of the backlash, the zero-force
    stretch of the contact gap's free run ``y_fit`` (:func:`duffsym.effects.gap.gap_half_width`); (None, nan) for
    other candidates."""
    if "bl_h" in c.params:
        return float(c.params["bl_h"]), float(c.stderr.get("bl_h", float("nan")))
    if "gap_w" in c.params and y_fit is not None:
        from duffsym.effects.gap import gap_half_width

        return gap_half_width(record, y_fit, float(c.params["gap_w"]), float(c.stderr.get("gap_w", float("nan"))))
    return None, float("nan")


def play_sentence(cands: Sequence[Candidate], record, y_candidates, rate_independent: bool) -> str:
    """When the needed effect is a play: its half-width with its standard error, in input units, and for a contact
    gap on a rate-dependent element the advice to try the rate-independent one ('' otherwise)."""
    c = next((c for c in cands if c.needed), None)
    if c is None or c.effect not in PLAY_EFFECTS:
        return ""
    h, se = play_half_width(c, record, y_candidates.get(c.effect))
    if h is None:
        return ""
    unit = (record.units or {}).get("d", "")
    s = f" The fitted play's half-width: h = {h:.3g} ± {se:.2g}{' ' + unit if unit else ''}."
    if c.effect == "contact-gap" and not rate_independent:
        s += (
            " A force held on both sides of the gap is a friction element's: its loop does not depend on the speed, "
            "so try the rate-independent element too (`--model mr-damper-path`)."
        )
    return s


def why_not(message: str) -> str:
    """Why a candidate has no result: screened out, its free run diverged, or its fit failed."""
    if "WallTime_Exceeded" in message:
        return f"not converged: its share of the time budget ran out ({message})"
    return message if message.startswith(("screened out", "free run", "not tried")) else f"fit failed: {message}"


def full_verdict(res, out, base_held, noise_method, shifted, w, evidence, base_check, inactive) -> str:
    """The diagnosis's sentences: the verdict, the proposal to look outside the catalogue, smoothing, SINDy,
    the base fit's check and the inactive effects."""
    return (
        _verdict(res, out, base_held, noise_method, shifted)
        + proposal(res, out)
        + _smoothing_sentence(w)
        + _sindy_sentence(evidence, out)
        + _base_sentence(base_check)
        + "".join(f" Inactive in the fitted model: {e}: {why}." for e, why in inactive.items())
    )


def proposal(residuals, candidates) -> str:
    """The diagnosis's sentence proposing discovery, when no catalogued effect is needed and the model is
    not at the noise: what ``duffsym ladder`` (discovery on by default) will look for ('' otherwise)."""
    if any(c.needed for c in candidates) or residuals.at_noise_level or residuals.excess < 1.5:
        return ""
    tr = residuals.trend
    g, rho = float(tr.get("growth", 1.0)), float(tr.get("spearman", 0.0))
    if (g > GROWTH and rho > 0.5) or (g < 1 / GROWTH and rho < -0.5):
        return (
            f" The error {'grows' if g > 1 else 'shrinks'} over the record ({g:.1f}x from the first to the last "
            "quarter): `duffsym ladder` (discovery on by default) refits windows to find the parameter that "
            "drifts and tries it following time or the dissipated energy."
        )
    return (
        " Outside the catalogue: `duffsym ladder` (discovery on by default) looks for a term by sparse "
        "regression of the residual on polynomials and switching functions of d, d', x, x'."
    )


def _sindy_sentence(evidence: SindyCheck | None, cands: Sequence[Candidate]) -> str:
    if evidence is None or not evidence.conclusive:
        return ""
    found = evidence.supported_terms
    if not found:
        return ""
    terms = ", ".join(f"{m['term']}" + (f" ({m['effect']})" if m.get("effect") else "") for m in found)
    best = next((c for c in cands if c.success), None)
    effects = {m.get("effect") for m in found}
    if best is not None and best.needed and best.effect in effects:
        return f" The SINDy cross-check independently selects {terms}, the term of {best.effect}."
    return f" The SINDy cross-check selects term(s) the model lacks: {terms}."


def _share(c: Candidate, floor: bool) -> str:
    """The share of the excess error a candidate removes, in words; with the held-out floor as the noise
    reference the best candidate removes all of it by construction, so no share is quoted."""
    if floor:
        return "how much error is left above the noise cannot be said: the noise is not measurable"
    return f"{100 * c.explained:.0f} % of the excess error"


def _not_needed_why(c: Candidate) -> str:
    if c.stable is False:
        return "its fitted set is outside the derived stability certificate (energy-producing)"
    return f"removes only {100 * c.explained:.0f} % of the excess error"


def band_sentence(band: float | None, dt: float) -> str:
    """The sentence saying that a low-pass filtered force was judged in a band ('' without one)."""
    if band is None:
        return ""
    return (
        f" The force is low-pass filtered (cutoff about {band / BAND_SHARE / dt:.3g} Hz, found from the fitted "
        f"model's spectrum): every fit was refined, and every free run judged against the measured force, below "
        f"{band / dt:.3g} Hz, where the filter left the force intact."
    )


def _smoothing_sentence(w: int) -> str:
    if w <= 1:
        return ""
    return (
        f" The force is smoothed by a {w}-sample moving average (detected in its spectrum): the models were "
        "fitted to the force restored by its regularised inverse and judged through the same average against "
        "the measured force."
    )


def _base_sentence(check: BaseCheck | None) -> str:
    if check is None:
        return ""
    s = ""
    if check.budget:
        s += (
            f" Time budget: the {' and the '.join(check.budget)} stopped on "
            f"{'its' if len(check.budget) == 1 else 'their'}"
            " share of the budget before converging (give more with --budget)."
        )
    if not check.as_good:
        s += (
            f" Caution: the diagnosis's base fit (free-run NRMSE {check.nrmse_fit_part:.3g} on the fitting part) "
            f"is worse than {check.reference} ({check.reference_nrmse_fit_part:.3g}): every candidate is "
            "judged against a weaker base."
        )
    if check.stable is False:
        s += (
            f" The base fit is outside the derived stability certificate ({check.stability}): "
            "an energy-producing parameter set; treat its numbers with care."
        )
    return s


def _fits_verdict(
    res: ResidualAnalysis, base_held: float, noise_method: str, floor: bool, noise_said: str
) -> str | None:
    """The verdict when no candidate is needed and the model fits (exactly, to the noise, or to the noise
    level with a small structured misfit); None when it does not."""
    if base_held < EXACT_FIT:
        return (
            f"The model fits the record exactly: held-out NRMSE {base_held:.2g}, below {EXACT_FIT:g} (noise-free "
            "data?); nothing is left to explain and no effect is needed."
        )
    if res.at_noise_level:
        if floor:
            return (
                "The model fits as well as any candidate: no catalogued effect lowers the held-out error "
                f"convincingly (held-out NRMSE {base_held:.3g}){noise_said}."
            )
        return (
            f"The model fits to the noise: the residual is white and at the noise level "
            f"(RMS {res.rmse:.3g} vs noise {res.noise:.3g}, from {noise_method}); no effect is needed, and no "
            f"catalogued effect improves the held-out error convincingly."
        )
    if res.excess < 1.5 and not floor:
        return (
            f"The model fits to the noise level but not to white noise: the residual RMS is {res.rmse:.3g}, "
            f"{res.excess:.2g}x the noise (from {noise_method}), yet {100 * res.acf_outside:.0f} % of its "
            "autocorrelation lags are outside the 95 % bound: a small structured misfit remains that no catalogued "
            "effect lowers convincingly; no effect is needed."
        )
    return None


def _unstable_tail(ok: Sequence[Candidate]) -> str:
    """The sentence on supported candidates not taken because their fitted set is energy-producing."""
    unstable = [c for c in ok[:STABILITY_CHECKED] if c.stable is False and c.supported and c.explained >= 0.5]
    if not unstable:
        return ""
    return (
        " Not taken although supported, because the fitted set is outside the derived stability certificate "
        "(energy-producing): " + "; ".join(f"{c.effect} ({c.stability})" for c in unstable) + "."
    )


def _verdict(
    res: ResidualAnalysis,
    cands: Sequence[Candidate],
    base_held: float,
    noise_method: str = "given",
    shifted: bool = False,
) -> str:
    ok = [c for c in cands if c.success and not c.diverged]
    best = ok[0] if ok else None
    where = res.findings()
    floor = noise_method.startswith("held-out residual floor")
    noise_said = (
        f" (noise level {res.noise:.3g}, from {noise_method.split(':')[0]})"
        if not floor
        else f" (the noise is not measurable on this record; the reference {res.noise:.3g} is the lowest held-out "
        "RMS of any fitted model, an upper bound of the noise)"
    )
    if not any(c.needed for c in ok):
        fits = _fits_verdict(res, base_held, noise_method, floor, noise_said)
        if fits is not None:
            return fits
    tail = _unstable_tail(ok)
    if best is not None and best.needed:
        s = (
            f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
            f"Adding {best.effect} ({best.physics}) explains it: the held-out NRMSE falls from {base_held:.3g} to "
            f"{best.nrmse_after:.3g} (dBIC {best.delta_bic:.0f}, {_share(best, floor)})."
        )
        if best.effect == "force-offset" and shifted and best.explained < 0.5:
            s += " It is taken because the loop is shifted (residual mean a large share of its RMS)."
        ties = [c for c in ok[1:] if c.needed and c.nrmse_after <= best.nrmse_after * (1 + TIE)]
        if ties:
            s += (
                f" {', '.join(c.effect for c in ties)} explain{'s' if len(ties) == 1 else ''} it almost as well "
                "here: this record cannot tell them apart."
            )
        return s + tail
    needed = next((c for c in ok if c.needed), None)
    if needed is not None:
        return (
            f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
            f"Adding {needed.effect} ({needed.physics}) explains it: the held-out NRMSE falls from {base_held:.3g} "
            f"to {needed.nrmse_after:.3g} (dBIC {needed.delta_bic:.0f}, {_share(needed, floor)})."
        ) + tail
    if best is not None and best.supported:
        return (
            f"The model fails: {where[0] if where else 'the residual is structured'}{noise_said}. "
            f"{best.effect} helps (held-out NRMSE {base_held:.3g} -> {best.nrmse_after:.3g}, dBIC "
            f"{best.delta_bic:.0f}) but {_not_needed_why(best)}, so it is not the missing effect with confidence. "
            f"What remains: {'; '.join(where[:2]) if where else 'unclear'}."
        ) + tail
    return (
        "No catalogued effect explains what the model misses: "
        + ("; ".join(where[:3]) if where else "the residual is structured")
        + noise_said
        + (
            f". The best candidate, {best.effect}, changes the held-out NRMSE only from {base_held:.3g} to "
            f"{best.nrmse_after:.3g}."
            if best is not None
            else "."
        )
        + tail
    )
