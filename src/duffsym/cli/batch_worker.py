"""The work of one record of ``duffsym batch``: a :class:`~duffsym.engine.Task` that runs the command's
own function (``run_fit``, ``run_validate``, ``run_diagnose``, ``run_ladder``, ``run_sample``) on the
parsed options and returns its result object.

:func:`record_task` (in the submitting process) parses the record's options with the command's own
parser, exactly as ``duffsym COMMAND ... --json --quiet`` would, and packs the bytes of the input files,
so a worker needs no shared file system. :func:`run_record` (in the worker) writes the files to a private
temporary folder (keeping their names), points the parsed options at them and calls the command's
function through :func:`duffsym.cli.guarded` (the same checks and one-line errors as the command line).
It returns a :class:`~duffsym.campaign.RecordRun` holding the command's :class:`~duffsym.cli.common.CommandResult`
(its ``to_dict()`` is the JSON the command prints), the exit code and the record's stderr, with the
temporary paths replaced by the original ones in the messages and the result.
"""

from __future__ import annotations

import argparse
import io
import os
import socket
import sys
import tempfile
import threading
import time
from contextlib import contextmanager, redirect_stderr
from dataclasses import dataclass
from pathlib import Path

_local = threading.local()
_lock = threading.Lock()
_installed = {"count": 0, "saved": None}


class _ThreadStream:
    """``sys.stdout``/``sys.stderr`` stand-in that writes to this thread's capture buffer, if it has one.

    ``contextlib.redirect_stdout`` swaps the stream for the whole process; two tasks in threads of one
    worker would then mix their output. This keeps each task's output its own.
    """

    def __init__(self, name: str, real):
        self._name, self._real = name, real

    def _target(self):
        return getattr(_local, self._name, None) or self._real

    def write(self, text):
        return self._target().write(text)

    def flush(self):
        return self._target().flush()

    def __getattr__(self, attr):
        return getattr(self._target(), attr)


@contextmanager
def _captured():
    """Capture this thread's stdout and stderr (as text) while the block runs."""
    out, err = io.StringIO(), io.StringIO()
    with _lock:
        if _installed["count"] == 0:
            _installed["saved"] = (sys.stdout, sys.stderr)
            sys.stdout = _ThreadStream("out", sys.stdout)
            sys.stderr = _ThreadStream("err", sys.stderr)
        _installed["count"] += 1
    _local.out, _local.err = out, err
    try:
        yield out, err
    finally:
        _local.out = _local.err = None
        with _lock:
            _installed["count"] -= 1
            if _installed["count"] == 0:
                sys.stdout, sys.stderr = _installed["saved"]


@dataclass(frozen=True)
class InputFile:
    """An input file of a record as it travels to a worker: its path (as the user gave it) and its bytes."""

    path: str
    data: bytes

    @classmethod
    def read(cls, path) -> InputFile:
        return cls(str(path), Path(path).read_bytes())


def command_line(command: str, data: str, fit: str | None, argv, quiet: bool = True) -> list[str]:
    """The ``duffsym`` arguments of one record (without the program name), as the batch runs it."""
    if command == "validate":
        head = [command, fit, data]
    elif fit is not None:
        head = [command, data, "--fit", fit]
    else:
        head = [command, data]
    return head + list(argv) + ["--json"] + (["--quiet"] if quiet else [])


def parse_record(command: str, argv: list[str]):
    """The options of one record parsed by the command's own parser: ``(args, None)``, or ``(None, (exit code,
    argparse's message))`` when they are not valid (e.g. a misspelt option in a manifest)."""
    from duffsym.cli import build_parser

    parser = build_parser(argv)
    text = io.StringIO()
    try:
        with redirect_stderr(text):
            return parser.parse_args(argv), None
    except SystemExit as exc:
        return None, (exc.code if isinstance(exc.code, int) else 2, text.getvalue())


def _has_quiet(command: str) -> bool:
    from duffsym.cli import build_parser

    parser = build_parser([command])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return "--quiet" in sub.choices[command]._option_string_actions


def record_task(command: str, job):
    """The :class:`~duffsym.engine.Task` of one batch job (a :class:`~duffsym.campaign.manifest.Job`)."""
    from duffsym.engine import Task

    files = [InputFile.read(job.data)] + ([InputFile.read(job.fit)] if job.fit is not None else [])
    argv = command_line(
        command, str(job.data), None if job.fit is None else str(job.fit), job.argv, quiet=_has_quiet(command)
    )
    args, usage = parse_record(command, argv)
    if usage is not None:
        return Task(usage_error, usage)
    return Task(run_record, (args, tuple(files)))


def usage_error(code: int, text: str):
    """The outcome of a record whose options the command's parser refused (no work done)."""
    from duffsym.campaign import RecordRun

    return RecordRun(
        exit_code=code, result=None, message=_last_line(text), stderr=text[-4000:], seconds=0.0, worker=_worker()
    )


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return lines[-1] if lines else ""


def _worker() -> str:
    return f"{socket.gethostname()}:{os.getpid()}"


def _swapped(value, swaps):
    """``value`` (strings, lists and dicts of them) with each path ``a`` replaced by ``b``."""
    if isinstance(value, str):
        for a, b in swaps:
            value = value.replace(a, b)
        return value
    if isinstance(value, list):
        return [_swapped(v, swaps) for v in value]
    if isinstance(value, tuple):
        return tuple(_swapped(v, swaps) for v in value)
    if isinstance(value, dict):
        return {k: _swapped(v, swaps) for k, v in value.items()}
    return value


def _point_at(args, swaps):
    """A copy of the parsed options with every input path (an option equal to it, or an item of a list option)
    replaced by its temporary copy."""
    import argparse

    new = dict(swaps)

    def one(v):
        if isinstance(v, list):
            return [one(x) for x in v]
        return new.get(v, v) if isinstance(v, str) else v

    return argparse.Namespace(**{k: one(v) for k, v in vars(args).items()})


def run_record(args, files: tuple[InputFile, ...]):
    """Run one record's command in this process; never raises for the record's own errors (they are its
    exit code and message). Ctrl-C in a serial batch stops the batch, not one record."""
    from dataclasses import replace

    from duffsym.campaign import RecordRun
    from duffsym.cli import guarded
    from duffsym.cli.common import err
    from duffsym.errors import show_notes

    show_notes()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="duffsym-batch-") as tmp:
        swaps = []
        for folder, f in zip(("data", "fit"), files):
            copy = Path(tmp) / folder / Path(f.path).name
            copy.parent.mkdir()
            copy.write_bytes(f.data)
            swaps.append((f.path, str(copy)))
        local = _point_at(args, swaps)
        with _captured() as (_, stderr):
            result, code = guarded(local, lambda: local.run(local))
            for line in () if result is None else result.notes:
                err(line)
        text = stderr.getvalue()
    if code == 130:  # the command caught an interrupt (Ctrl-C in a serial batch): stop the batch, not one record
        raise KeyboardInterrupt
    back = [(b, a) for a, b in swaps]
    if result is not None:
        code = result.exit_code
        result = replace(result, data=_swapped(result.portable().data, back), value=None, text="")
    text = _swapped(text, back)
    return RecordRun(
        exit_code=code,
        result=result,
        message=_last_line(text) if code else "",
        stderr=text[-4000:],
        seconds=time.perf_counter() - t0,
        worker=_worker(),
    )
