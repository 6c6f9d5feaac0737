"""``duffsym fit A.csv B.csv ...`` / ``duffsym fit --manifest M``: one parameter set fitted to several records.

A campaign fit is one :class:`~duffsym.identify.Problem` over all the records: the parameters are
shared, each record keeps its own initial state. Each record brings its labels: a constant
``current``/``voltage`` column of the file, or the manifest's ``current``/``voltage`` column (which
must agree with the file's when both are given); a command model (``mr-damper-current``) reads the
level as the record's command. Other manifest columns (``amplitude``, ``frequency``, ...) are kept as
labels in the record's metadata; ``name`` and ``columns`` are the record's name and column mapping.
A manifest here is the one of ``duffsym batch`` (:func:`duffsym.campaign.manifest.read_manifest`);
the per-record ``model``, ``effects``, ``fit`` and ``options`` of a batch have no meaning in one
fit and are refused with a one-line error.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from duffsym.cli.common import CLIError, err, parse_mapping

if TYPE_CHECKING:
    from duffsym.data.record import Record

#: manifest fields that belong to per-record commands (``duffsym batch``), not to one shared fit
PER_RECORD_ONLY = ("model", "effects", "fit", "options")


def _manifest_entries(path: str) -> list[tuple[str, dict]]:
    from duffsym.campaign.manifest import read_manifest

    base = Path(path).parent
    out = []
    for i, entry in enumerate(read_manifest(path)):
        bad = [k for k in PER_RECORD_ONLY if entry.get(k) not in (None, "", [], {})]
        if bad:
            raise CLIError(
                f"--manifest {path} record {i + 1}: {', '.join(bad)} is per record (duffsym batch); a "
                "campaign fit uses one model: give --model/--add/options on the command line"
            )
        file = Path(str(entry["file"]))
        out.append((str(file if file.is_absolute() else base / file), entry))
    return out


def _label(record, entry: dict, path: str):
    """The record with the manifest's name, current/voltage and other labels applied."""
    changes: dict = {}
    for key in ("current", "voltage"):
        if entry.get(key) in (None, ""):
            continue
        try:
            value = float(entry[key])
        except (TypeError, ValueError):
            raise CLIError(f"{path}: manifest {key} {entry[key]!r} is not a number") from None
        have = getattr(record, key)
        if have is not None and not math.isclose(have, value, rel_tol=1e-6, abs_tol=1e-9):
            raise CLIError(f"{path}: the file's {key} is {have:g} but the manifest says {value:g}; make them agree")
        changes[key] = value
    if entry.get("name"):
        changes["name"] = str(entry["name"])
    labels = {k: v for k, v in entry.items() if k not in ("file", "name", "columns", "current", "voltage")}
    if labels:
        changes["metadata"] = {**dict(record.metadata), "labels": labels}
    return record.replace(**changes) if changes else record


def campaign_records(args, read_record) -> list[tuple[str, Record]]:
    """``(path, record)`` of every record of ``args.data`` and ``--manifest``, labels applied, names unique.

    ``read_record(args, path)`` reads one file with the command's ``--columns``/``--units`` options; a
    manifest's ``columns`` replaces ``--columns`` for its record.
    """
    entries: list[tuple[str, dict]] = [(p, {}) for p in args.data or []]
    if getattr(args, "manifest", None):
        entries += _manifest_entries(args.manifest)
    if not entries:
        raise CLIError("give the record(s) to fit: one or more CSV files, or --manifest FILE")
    out = []
    for path, entry in entries:
        if entry.get("columns"):
            cols = entry["columns"]
            args_one = type(args)(
                **{
                    **vars(args),
                    "columns": cols
                    if isinstance(cols, str)
                    else ",".join(f"{k}={v}" for k, v in parse_mapping(cols, "columns").items()),
                }
            )
        else:
            args_one = args
        record = _label(read_record(args_one, path), entry, path)
        out.append((path, record if record.name else record.replace(name=Path(path).stem)))
    names = [r.name for _, r in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise CLIError(f"two records are named {dup[0]!r}; give each a distinct file name or a manifest 'name'")
    return out


def hold_unseen_rates(model, records, fixed: dict, quiet: bool) -> tuple[dict, str]:
    """Hold the field rate ``eta`` of a command model when no record's command varies (its lag is unseen).

    Returns the fixed values and the reason ("" when nothing was held), for the fit's ``defaults_applied``.
    """
    if "eta" not in model.param_names or "eta" in fixed:
        return fixed, ""
    import numpy as np

    if any(r.command is not None and np.ptp(np.asarray(r.command)) > 0 for r in records):
        return fixed, ""
    eta = float(model.defaults()["eta"])
    reason = (
        f"held at {eta:g} 1/s: the commands are constant in every record, so the field's lag does not show "
        "(--fix eta=VALUE to choose it)"
    )
    if not quiet:
        err(f"duffsym fit: note: eta {reason}")
    return {**fixed, "eta": eta}, reason


def plot_campaign(result, records, path: str) -> None:
    """Measured and fitted force against displacement, one small panel per record (at most 12 shown)."""
    import matplotlib.pyplot as plt
    import numpy as np

    from duffsym.plot import save_figure

    shown = records[:12]
    ncol = min(4, len(shown))
    nrow = math.ceil(len(shown) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.6 * nrow + 0.6), squeeze=False)
    for k, (ax, rec) in enumerate(zip(axes.flat, shown)):
        y_sim = np.asarray(result.y_sim[k], dtype=float)
        ax.plot(rec.d, rec.y, ".", color="0.6", ms=1.5)
        ax.plot(rec.d, y_sim, color="k", lw=0.7)
        err = np.sqrt(np.mean((rec.y - y_sim) ** 2)) / max(np.std(rec.y), 1e-300)
        level = (
            f", {rec.current:g} A"
            if rec.current is not None
            else (f", {rec.voltage:g} V" if rec.voltage is not None else "")
        )
        ax.set_title(f"{rec.name}{level}: NRMSE {err:.3f}", fontsize=8)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(shown) :]:
        ax.set_visible(False)
    more = f" (first 12 of {len(records)})" if len(records) > 12 else ""
    fig.suptitle(
        f"one {result.model} parameter set for {len(records)} records{more}: measured (grey), "
        "fitted free run (black), force vs displacement, whole records",
        fontsize=9,
    )
    fig.tight_layout()
    save_figure(fig, path)
