"""Many records at once: :func:`run_batch` (behind ``duffsym batch`` and :func:`duffsym.batch`), on an
:class:`~duffsym.engine.Engine`.

Each record is one :class:`~duffsym.engine.Task` made by the caller's ``make_task`` (for
:func:`duffsym.batch` and ``duffsym batch``, :mod:`duffsym.cli.batch`: the command ``fit``,
``validate``, ``diagnose``, ``ladder`` or ``sample`` run by its own function), executed by the engine
in a worker process that has paid the start-up once; it returns a :class:`RecordRun` whose
``result.to_dict()`` is the command's JSON. One result file per record is written atomically to the
results folder as each record finishes; it holds the command's JSON and a ``"batch"`` block (status,
message, the hash of the inputs and options). A rerun skips the records whose result is complete and whose
hash is unchanged, so an interrupted batch resumes where it stopped. ``summary.json``, ``summary.csv`` and
``summary.png`` describe every record, failures included: one record's error never stops the others.
"""

from __future__ import annotations

import json
import sys
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from duffsym._io import check_output_dir, write_json_atomic
from duffsym._json import jsonable
from duffsym.campaign.manifest import COMMANDS, Job, collect_jobs
from duffsym.campaign.summary import plot_summary, row, write_csv
from duffsym.errors import DataError
from duffsym.options import resolve

STATUSES = ("ok", "failed", "error")
__all__ = ["run_batch", "RunOptions", "CampaignResult", "BatchResult", "RecordRun", "COMMANDS", "collect_jobs", "Job"]


@dataclass(frozen=True)
class RecordRun:
    """What the task of one record returns: the command's result (``result.to_dict()`` is its JSON; None when
    the command failed before it had one), the exit code (0: a usable result; 1: the command ran but its result
    is not usable, or it crashed; 2: bad input), the last stderr line when the exit code is not 0, the record's
    stderr (the end of it), the seconds it took and the worker (``host:pid``)."""

    exit_code: int
    result: Any
    message: str
    stderr: str
    seconds: float
    worker: str


@dataclass(frozen=True)
class CampaignResult:
    """The outcome of a batch: one row per record, in input order.

    Each row has the contract's ``record``, ``status`` (``ok``: a usable result; ``failed``: the
    command ran but its result is not usable, e.g. a fit that did not converge; ``error``: bad
    input or a crash; ``interrupted``: not run), ``success``, ``nrmse``, ``result`` (the result
    file), ``message``, and ``seconds``, ``reused`` (skipped: complete from an earlier run),
    ``labels`` (the manifest's extra fields), ``params`` (identified parameters).
    """

    command: str
    out: Path
    rows: tuple[dict, ...]
    seconds: float
    engine: str
    n_ran: int
    figure: Path | None = None
    interrupted: bool = False
    extra: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, name: str) -> dict:
        for r in self.rows:
            if r["record"] == name:
                return r
        raise KeyError(name)

    @property
    def counts(self) -> dict:
        return {s: sum(r["status"] == s for r in self.rows) for s in (*STATUSES, "interrupted")}

    @property
    def all_ok(self) -> bool:
        return all(r["status"] == "ok" for r in self.rows)

    def result(self, name: str) -> dict:
        """The stored result file of a record (the command's JSON with its ``"batch"`` block)."""
        return json.loads(Path(self[name]["result"]).read_text())

    def to_dict(self) -> dict:
        return {
            "command": self.command,
            "out": str(self.out),
            "records": [dict(r) for r in self.rows],
            "counts": self.counts,
            "n_records": len(self.rows),
            "n_ran": self.n_ran,
            "n_reused": sum(bool(r["reused"]) for r in self.rows),
            "seconds": self.seconds,
            "engine": self.engine,
            "figure": None if self.figure is None else str(self.figure),
            "interrupted": self.interrupted,
            **self.extra,
        }

    def summary(self) -> str:
        c = self.counts
        lines = [
            f"batch {self.command}: {len(self.rows)} records, {c['ok']} ok, {c['failed']} not usable, "
            f"{c['error']} errors"
            + (f", {c['interrupted']} not run (interrupted)" if c["interrupted"] else "")
            + f"; ran {self.n_ran}, reused {len(self.rows) - self.n_ran - c['interrupted']}; "
            f"{self.seconds:.1f} s on {self.engine}"
        ]
        width = max([len(r["record"]) for r in self.rows] + [6])
        for r in self.rows:
            nr = "" if r["nrmse"] is None else f"{r['nrmse']:.4g}"
            lines.append(f"  {r['record']:<{width}} {r['status']:<11} {nr:>8}  {r['message'][:100]}")
        lines.append(f"results in {self.out} (summary.json, summary.csv" + (", summary.png)" if self.figure else ")"))
        return "\n".join(lines)


#: The former name of :class:`CampaignResult` (``duffsym.simulate.BatchResult`` is another thing: many
#: simulations at once).
BatchResult = CampaignResult


# ---------------------------------------------------------------------------------------------- stored results
def _load_complete(path: Path, digest: str) -> dict | None:
    """The stored result if it is complete and made from the same inputs and options, else None."""
    try:
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    b = doc.get("batch") if isinstance(doc, dict) else None
    if not isinstance(b, dict) or not b.get("complete") or b.get("hash") != digest:
        return None
    return doc


def _document(command: str, job: Job, digest: str, outcome) -> dict:
    """The result file of a record: the command's JSON and the ``"batch"`` block."""
    if outcome.ok:
        v: RecordRun = outcome.value
        status = {0: "ok", 1: "failed"}.get(v.exit_code, "error")
        if status == "failed" and ": internal error:" in v.message:  # the CLI's exit 1 for a crash
            status = "error"
        meta = dict(
            message=v.message, seconds=v.seconds, worker=v.worker, exit_code=v.exit_code, stderr=v.stderr, complete=True
        )
        body = {} if v.result is None else v.result.to_dict()
    else:
        # the engine lost the task (a worker died): not complete, so a rerun tries again
        status, body = "error", {}
        meta = dict(
            message=f"{type(outcome.error).__name__}: {outcome.error}",
            seconds=None,
            worker=None,
            exit_code=None,
            stderr="",
            complete=False,
        )
    if not meta["message"] and status != "ok":
        meta["message"] = f"exit code {meta['exit_code']}"
    batch = dict(
        status=status,
        command=command,
        record=job.name,
        data=str(job.data),
        fit=None if job.fit is None else str(job.fit),
        argv=list(job.argv),
        labels=job.labels,
        hash=digest,
        **meta,
    )
    return {**{k: v for k, v in body.items() if k != "batch"}, "batch": batch}


# ---------------------------------------------------------------------------------------------- main
@dataclass(frozen=True)
class RunOptions:
    """How :func:`run_batch` runs the records (every field has the default ``run_batch`` uses; pass the object
    as ``run_batch(..., run=RunOptions(workers=0))`` or any field as a keyword, ``run_batch(..., workers=0)``).

    Fields
    ------
    workers : local worker processes (default: the cores available); 0 runs in this process.
    scheduler : address of a Dask scheduler: the records run on its workers (overrides ``workers``).
    engine : an open :class:`~duffsym.engine.Engine` to use instead (``workers``/``scheduler`` ignored).
    retry_failed : rerun records whose stored result is ``failed`` or ``error`` (default: keep them).
    progress : a progress bar on stderr (tqdm): records done, failures, estimated time left.
    figure : write ``summary.png``.
    """

    workers: int | None = None
    scheduler: str | None = None
    engine: Any = None
    retry_failed: bool = False
    progress: bool = True
    figure: bool = True


def run_batch(
    inputs: Iterable = (),
    *,
    make_task,
    command: str = "fit",
    out,
    manifest=None,
    fit=None,
    options: Any = None,
    run: RunOptions | None = None,
    **settings,
) -> CampaignResult:
    """Run the task of every record of a folder, a glob or a manifest, on an engine.

    Parameters
    ----------
    inputs : CSV files, folders (their ``*.csv``) and glob patterns.
    make_task : ``make_task(command, job) -> Task`` for a :class:`Job`, the task returning a :class:`RecordRun`
        (:func:`duffsym.cli.batch_worker.record_task` for :func:`duffsym.batch`).
    command : ``"fit"``, ``"validate"``, ``"diagnose"``, ``"ladder"`` or ``"sample"``.
    out : the results folder: ``<record>.json`` per record, ``summary.json``, ``summary.csv``, ``summary.png``.
    manifest : CSV or JSON manifest (see :mod:`duffsym.campaign.manifest`): file, columns, model,
        effects, fit, options per record; other fields are labels (current, amplitude, frequency, ...).
    fit : a FIT.json for every record, or a folder of ``<record>.json`` (e.g. the ``out`` of a batch fit).
    options : options of the command for every record, as on its command line (``"--starts 3"``) or
        a mapping (``{"starts": 3}``).
    run : how the records run, a :class:`RunOptions` (default: its defaults).
    **settings : any :class:`RunOptions` field by name (``workers``, ``scheduler``, ``engine``,
        ``retry_failed``, ``progress``, ``figure``), replacing that field of ``run``; an unknown name raises
        :class:`TypeError`.

    Returns
    -------
    CampaignResult
    """
    from duffsym.engine import Engine, default_workers

    how = resolve(RunOptions, run, settings, "run_batch")
    engine, progress, figure = how.engine, how.progress, how.figure
    t0 = time.perf_counter()
    jobs = collect_jobs(inputs, command=command, manifest=manifest, fit=fit, options=options)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} is a file; give a folder for the results")
    check_output_dir(out, option="--out")  # up front, as fit checks its --out: created, and writable
    lock = _remove_stale_temporaries(out)
    digests = {j.name: j.input_hash(command) for j in jobs}
    done: dict[str, dict] = {}
    for j in jobs:
        doc = _load_complete(out / f"{j.name}.json", digests[j.name])
        if doc is not None and (not how.retry_failed or doc["batch"].get("status") == "ok"):
            done[j.name] = doc
    todo = [j for j in jobs if j.name not in done]
    own = engine is None
    if own:
        engine = Engine(default_workers() if how.workers is None else how.workers, scheduler=how.scheduler)
    bar = _progress_bar(len(todo), command, progress)
    say = bar.write if progress else (lambda *a, **k: None)
    if progress:
        say(
            f"batch {command}: {len(jobs)} records, {len(done)} complete from an earlier run, {len(todo)} to "
            f"run on {engine!r}",
            file=sys.stderr,
        )
    fresh: dict[str, dict] = {}
    interrupted = False
    try:
        if todo:
            if own:
                engine.start()
            n_bad = 0
            for outcome in engine.run([make_task(command, j) for j in todo]):
                job = todo[outcome.index]
                doc = _document(command, job, digests[job.name], outcome)
                write_json_atomic(out / f"{job.name}.json", jsonable(doc), default=str)
                fresh[job.name] = doc
                if doc["batch"]["status"] != "ok":
                    n_bad += 1
                    say(f"  {job.name}: {doc['batch']['status']}: {doc['batch']['message']}", file=sys.stderr)
                bar.set_postfix_str(f"not ok {n_bad}", refresh=False)
                bar.update(1)
    except KeyboardInterrupt:
        interrupted = True
        raise
    finally:
        bar.close()
        # a local cluster takes a few seconds to stop: it does so while the summary is written
        closing = threading.Thread(target=engine.close, name="duffsym-engine-close") if own else None
        if closing is not None:
            closing.start()
        try:
            rows = _rows(command, jobs, fresh, done, out)
            res = CampaignResult(
                command=command,
                out=out,
                rows=tuple(rows),
                seconds=time.perf_counter() - t0,
                engine=repr(engine),
                n_ran=len(fresh),
                interrupted=interrupted,
            )
            _write_summary(res, figure and not interrupted)
        finally:
            if closing is not None:
                closing.join()
            if lock is not None:
                lock.close()
    return _with_figure(res, out / "summary.png" if figure and not interrupted else None)


def _rows(command: str, jobs: list[Job], fresh: dict, done: dict, out: Path) -> list[dict]:
    """The summary rows in input order: this run's results, the reused ones, and those not run."""
    rows = []
    for j in jobs:
        doc = fresh.get(j.name) or done.get(j.name)
        if doc is None:
            rows.append(
                {
                    "record": j.name,
                    "status": "interrupted",
                    "success": False,
                    "nrmse": None,
                    "result": None,
                    "message": "not run: the batch was interrupted; rerun to complete it",
                    "seconds": None,
                    "reused": False,
                    "data": str(j.data),
                    "worker": None,
                    "labels": dict(j.labels),
                    "params": {},
                }
            )
        else:
            rows.append(row(command, j.name, out / f"{j.name}.json", doc, reused=j.name in done))
    return rows


def _with_figure(res: CampaignResult, fig: Path | None) -> CampaignResult:
    from dataclasses import replace

    return replace(res, figure=fig if fig is not None and fig.is_file() else None)


#: Lock file of the batches writing into one results folder (each holds a shared lock while it runs).
LOCK_NAME = ".duffsym-batch.lock"


def _remove_stale_temporaries(out: Path):
    """Remove the temporary files a killed run left in ``out`` (a killed run's lock is released with it),
    unless another batch is writing there right now: its temporary files are not stale. Returns the open
    lock file, held (shared) until the batch ends."""
    try:
        import fcntl
    except ImportError:  # no advisory locks (Windows): leave the temporary files (they never match *.json)
        return None
    lock = open(out / LOCK_NAME, "a")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:  # another batch runs in this folder
        fcntl.flock(lock, fcntl.LOCK_SH)
        return lock
    for stale in out.glob(".*.tmp*"):
        stale.unlink(missing_ok=True)
    fcntl.flock(lock, fcntl.LOCK_SH)
    return lock


def _write_summary(res: CampaignResult, figure: bool) -> None:
    out = res.out
    if figure:
        plot_summary(list(res.rows), res.command, out / "summary.png")
        res = _with_figure(res, out / "summary.png")
    write_csv(list(res.rows), out / "summary.csv")
    write_json_atomic(out / "summary.json", jsonable(res.to_dict()), default=str)


def _progress_bar(total: int, command: str, enabled: bool):
    from tqdm import tqdm

    return tqdm(
        total=total, desc=f"batch {command}", unit="record", file=sys.stderr, disable=not enabled, dynamic_ncols=True
    )
