"""Markdown reports (with PNG figures) of a diagnosis and of a ladder: ``--report DIR``."""

from __future__ import annotations

from pathlib import Path

from duffsym._io import write_json_atomic, write_text_atomic
from duffsym.data.record import Record
from duffsym.diagnose.search import why_not


def _save(fig, path: Path) -> str:
    from duffsym.plot.loops import save_figure

    save_figure(fig, path)
    return path.name


def _candidates_table(diag) -> list[str]:
    lines = [
        "| effect | held-out NRMSE | ΔBIC | excess error explained | verdict | parameters |",
        "|---|---|---|---|---|---|",
    ]
    for c in diag.candidates:
        if not c.success:
            lines.append(f"| {c.effect} | – | – | – | {why_not(c.message)} | |")
            continue
        pv = ", ".join(f"{k} = {v:.4g} ± {c.stderr.get(k, float('nan')):.2g}" for k, v in c.params.items())
        flag = "needed" if c.needed else ("helps partly" if c.supported else "not supported")
        lines.append(
            f"| {c.effect} | {c.nrmse_after:.4g} | {c.delta_bic:.1f} | {100 * c.explained:.0f} % | {flag} | {pv} |"
        )
    return lines


def write_diagnosis_report(diag, record: Record, folder) -> Path:
    """``folder/diagnosis.md`` with the figures of where the model fails and of the candidates."""
    from duffsym._json import jsonable
    from duffsym.diagnose.figures import plot_candidates, plot_play, plot_where

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    f1 = _save(plot_where(diag, record), folder / "where_it_fails.png")
    f2 = _save(plot_candidates(diag, record), folder / "candidates.png")
    lines = [
        f"# Diagnosis of {diag.model}{' + ' + ' + '.join(diag.effects) if diag.effects else ''} on "
        f"{record.name or record.source}",
        "",
        f"**Verdict.** {diag.verdict}",
        "",
        f"Free-run NRMSE {diag.nrmse:.4g} over the whole record, {diag.nrmse_heldout:.4g} on the held-out tail "
        f"(from t = {diag.split['t_split']:.4g} s, {diag.split['n_heldout']} samples); noise level "
        f"{diag.noise:.3g} (estimated from the measurement alone).",
        "",
        "## Where the model fails",
        "",
    ]
    lines += [f"- {s}" for s in diag.residuals.findings()]
    lines += [
        "",
        f"![where the model fails]({f1})",
        "",
        "## Which effect is missing",
        "",
        "Each catalogued effect was added and the model refitted on the fitting part; the held-out NRMSE "
        "is the free-run error on data the fit never saw.",
        "",
    ]
    lines += _candidates_table(diag)
    lines += ["", f"![candidates]({f2})", ""]
    fig = plot_play(diag, record)
    if fig is not None:  # the play candidate against the plateaus after the reversals
        lines += ["## The play candidate", "", f"![the play and the plateaus]({_save(fig, folder / 'play.png')})", ""]
    if diag.sindy is not None:
        lines += ["## SINDy cross-check", "", f"{diag.sindy.get('verdict')}: {diag.sindy.get('message', '')}", ""]
    write_json_atomic(folder / "diagnosis.json", jsonable(diag.to_dict()), default=str)
    path = write_text_atomic(folder / "diagnosis.md", "\n".join(lines) + "\n")
    return path


def write_ladder_report(lad, record: Record, folder, written: set | None = None) -> Path:
    """``folder/ladder.md``: the steps, the error falling, and a diagnosis section per step. ``written``: the
    steps whose sections are already in ``folder`` from this run (not rewritten; updated here), so that a
    ladder can write its report after every step (``duffsym ladder --report``)."""
    from duffsym._json import jsonable
    from duffsym.diagnose.figures import plot_ladder

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    f1 = _save(plot_ladder(lad, record), folder / "ladder.png")
    lines = [
        f"# Ladder on {record.name or record.source}",
        "",
        "| step | model | NRMSE (whole) | NRMSE (held out) | BIC |",
        "|---|---|---|---|---|",
    ]
    for i, s in enumerate(lad.steps):
        lines.append(
            f"| {i} | {' + '.join(('base',) + s.effects)} | {s.nrmse:.4g} | {s.nrmse_heldout:.4g} | {s.bic:.1f} |"
        )
    lines += ["", f"Stopped: {lad.stopped}", "", f"![the error falls]({f1})", ""]
    written = set() if written is None else written
    for i, s in enumerate(lad.steps):
        sub = folder / f"step{i}"
        if i not in written:
            write_diagnosis_report(s.diagnosis, record, sub)
            written.add(i)
        lines.append(
            f"- step {i} ({' + '.join(('base',) + s.effects)}): [diagnosis](step{i}/diagnosis.md) — "
            f"{s.diagnosis.verdict}"
        )
        lines += [f"  - **{e} is inactive**: {why}" for e, why in s.inactive.items()]
    final = lad.final_fit
    if final is None:  # a ladder still running (written after each step)
        lines += ["", f"**Not finished.** {lad.final_note}"]
        write_json_atomic(folder / "ladder.json", jsonable(lad.to_dict()), default=str)
        return write_text_atomic(folder / "ladder.md", "\n".join(lines) + "\n")
    title = "refitted on the whole record" if not lad.final_note else "(" + lad.final_note + ")"
    lines += [
        "",
        f"## Final model, {title}",
        "",
        f"NRMSE {final.nrmse:.4g}, status {final.status}.",
        "",
        "| parameter | value | standard error |",
        "|---|---|---|",
    ]
    for k in final.free:
        lines.append(f"| {k} | {final.params[k]:.6g} | {final.stderr.get(k, float('nan')):.3g} |")
    write_json_atomic(folder / "ladder.json", jsonable(lad.to_dict()), default=str)
    path = write_text_atomic(folder / "ladder.md", "\n".join(lines) + "\n")
    return path
