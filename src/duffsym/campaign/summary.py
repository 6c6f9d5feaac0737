"""The summary of a batch: one row per record (``summary.json``, ``summary.csv``) and a figure."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from duffsym._io import atomic_path, write_text_atomic

#: Labels the figure plots the parameters against, in order of preference.
AXES = ("current", "voltage", "amplitude", "frequency")
HEAD = ("record", "status", "success", "nrmse", "result", "message")


def _finite(v):
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def nrmse_of(command: str, result: dict | None) -> float | None:
    """The record's free-run NRMSE from its command's JSON (ladder: the final fit; sample: the sampled fit)."""
    if not result:
        return None
    if command == "ladder":
        return _finite((result.get("final") or {}).get("nrmse"))
    if command == "sample":
        return _finite((result.get("fit") or {}).get("nrmse"))
    return _finite(result.get("nrmse"))


def params_of(command: str, result: dict | None) -> dict:
    """The identified parameters in the command's JSON (sample: the posterior medians), free ones only when known."""
    if not result:
        return {}
    if command == "fit":
        free = result.get("free") or list(result.get("stderr", {}))
        return {k: result["params"][k] for k in free if k in result.get("params", {})}
    if command == "ladder":
        final = result.get("final") or {}
        return {k: final.get("params", {}).get(k) for k in final.get("stderr", {})}
    if command == "sample":
        return dict(result.get("median") or {})
    if command == "diagnose":
        return dict(result.get("base_params") or {})
    return {}


def row(command: str, name: str, path: Path, doc: dict, *, reused: bool) -> dict:
    """The summary row of one record from its stored result (``{...command JSON, "batch": {...}}``)."""
    b = doc.get("batch", {})
    result = {k: v for k, v in doc.items() if k != "batch"} or None
    return {
        "record": name,
        "status": b.get("status", "error"),
        "success": b.get("status") == "ok",
        "nrmse": nrmse_of(command, result),
        "result": str(path),
        "message": b.get("message", ""),
        "seconds": b.get("seconds"),
        "reused": reused,
        "data": b.get("data"),
        "worker": b.get("worker"),
        "labels": dict(b.get("labels", {})),
        "params": params_of(command, result),
    }


def to_csv(rows: list[dict]) -> str:
    """The rows as CSV: the contract's columns, then seconds, reused, data, the labels and ``param:<name>``."""
    labels = list(dict.fromkeys(k for r in rows for k in r["labels"]))
    params = list(dict.fromkeys(k for r in rows for k in r["params"]))
    cols = [*HEAD, "seconds", "reused", "data", *labels, *(f"param:{p}" for p in params)]
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        flat = {**{k: r.get(k) for k in cols[:9]}, **r["labels"], **{f"param:{k}": v for k, v in r["params"].items()}}
        w.writerow(["" if flat.get(c) is None else flat.get(c) for c in cols])
    return buf.getvalue()


def write_csv(rows: list[dict], path) -> Path:
    return write_text_atomic(path, to_csv(rows))


def _axis_label(rows: list[dict]) -> tuple[str | None, list[str]]:
    """The label to plot parameters against (the first of ``AXES`` that varies) and the others that vary."""
    varying = []
    for k in dict.fromkeys(k for r in rows for k in r["labels"]):
        vals = {r["labels"].get(k) for r in rows}
        if len(vals) > 1 and all(isinstance(v, (int, float)) for v in vals):
            varying.append(k)
    x = next((k for k in AXES if k in varying), None)
    return x, [k for k in varying if k != x]


def plot_summary(rows: list[dict], command: str, path) -> Path:
    """NRMSE per record; with numeric labels such as ``current`` in the manifest, each parameter against it
    (one line per value of the other labels, e.g. per amplitude and frequency)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    import numpy as np

    done = [r for r in rows if r["status"] in ("ok", "failed", "error")]
    x_label, others = _axis_label([r for r in done if r["params"]])
    params = list(dict.fromkeys(k for r in done for k in r["params"])) if x_label else []
    params = params[:6]
    n_rows = max(1, math.ceil(len(params) / 2))
    fig = plt.figure(figsize=(11 if params else 6, max(3.0, 0.22 * len(rows) + 1.2, 2.4 * n_rows)))
    grid = fig.add_gridspec(n_rows, 3 if params else 1)
    ax = fig.add_subplot(grid[:, 0])
    names = [r["record"] for r in rows]
    vals = np.array([r["nrmse"] if r["nrmse"] is not None else np.nan for r in rows], dtype=float)
    colors = ["tab:blue" if r["status"] == "ok" else "tab:red" for r in rows]
    y = np.arange(len(rows))
    ax.barh(y, np.nan_to_num(vals), color=colors)
    top = np.nanmax(vals) if np.any(np.isfinite(vals)) else 1.0
    for i, r in enumerate(rows):
        if r["status"] != "ok":
            ax.text(
                0.02 * top,
                i,
                r["status"] if r["status"] != "failed" else "not usable",
                va="center",
                fontsize=7,
                color="tab:red",
            )
    ax.set_yticks(y, names, fontsize=7 if len(rows) > 12 else 9)
    ax.invert_yaxis()
    ax.set_xlabel("free-run NRMSE")
    n_ok = sum(r["status"] == "ok" for r in rows)
    ax.set_title(f"batch {command}: NRMSE per record\n{n_ok}/{len(rows)} usable (red: not)", fontsize=10)
    for j, p in enumerate(params):
        pa = fig.add_subplot(grid[j // 2, 1 + j % 2])
        groups: dict[tuple, list] = {}
        for r in done:
            v = r["params"].get(p)
            if v is None or r["status"] != "ok":
                continue
            key = tuple(r["labels"].get(o) for o in others)
            groups.setdefault(key, []).append((r["labels"][x_label], float(v)))
        for key, pts in sorted(groups.items(), key=lambda kv: tuple(-np.inf if v is None else v for v in kv[0])):
            pts.sort()
            lab = ", ".join(f"{o} {k:g}" for o, k in zip(others, key)) if others else None
            pa.plot([a for a, _ in pts], [b for _, b in pts], "o-", ms=3, lw=0.8, label=lab)
        mags = np.abs([b for pts in groups.values() for _, b in pts])
        if mags.size and np.median(mags) > 0 and mags.max() > 30 * np.median(mags):
            # a few fits far off the others (e.g. a parameter running to large values) would flatten the rest
            pa.set_yscale("symlog", linthresh=float(np.median(mags)))
            p += " (symlog)"
        pa.set_title(p, fontsize=9)
        assert x_label is not None  # without a label column there are no parameter panels
        pa.set_xlabel(x_label, fontsize=8)
        pa.tick_params(labelsize=7)
        if j == 0 and others and len(groups) > 1:
            pa.legend(fontsize=6, ncol=1)
    if params:
        fig.suptitle(f"parameters (usable fits) against {x_label}", x=0.67, fontsize=10)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120)
    plt.close(fig)
    return path
