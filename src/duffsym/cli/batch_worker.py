"""The work of one record, as a worker does it: the ``duffsym`` command itself, run in-process
(a command-line module: it drives :func:`duffsym.cli.main`).

A task carries the bytes of its input files, so a worker needs no shared file system: it writes
them to a private temporary folder (keeping their names), runs ``duffsym COMMAND ... --json`` there
through :func:`duffsym.cli.main` (the same code, options and checks as the command line, so a batch
result is the result the command gives), and returns the JSON, the exit code and the last message.
The temporary paths are replaced by the original ones in what comes back.
"""
from __future__ import annotations

import io
import json
import os
import socket
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
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


def _has_option(command: str, option: str) -> bool:
    from duffsym.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    return option in sub.choices[command]._option_string_actions


def command_line(command: str, data: str, fit: str | None, argv) -> list[str]:
    """The ``duffsym`` arguments of one record (without the program name)."""
    if command == "validate":
        head = [command, fit, data]
    elif fit is not None:
        head = [command, data, "--fit", fit]
    else:
        head = [command, data]
    tail = ["--json"] + (["--quiet"] if _has_option(command, "--quiet") else [])
    return head + list(argv) + tail


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    return lines[-1] if lines else ""


def run_task(task: dict) -> dict:
    """Run one record (a task built by :func:`duffsym.campaign.run_batch`); never raises for the record's own errors.

    Returns ``{"exit_code": int, "result": dict|None, "message": str, "stderr": str, "seconds": float,
    "worker": str}``: exit code 0 (a usable result), 1 (the command ran; its result is not usable,
    e.g. a fit that did not converge) or 2 (bad input or an error; ``message`` says which).
    """
    from duffsym.cli import main

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="duffsym-batch-") as tmp:
        tmp_data = Path(tmp) / "data" / task["data_name"]
        tmp_data.parent.mkdir()
        tmp_data.write_bytes(task["data_bytes"])
        tmp_fit = None
        if task.get("fit_bytes") is not None:
            tmp_fit = Path(tmp) / "fit" / task["fit_name"]
            tmp_fit.parent.mkdir()
            tmp_fit.write_bytes(task["fit_bytes"])
        argv = command_line(task["command"], str(tmp_data), None if tmp_fit is None else str(tmp_fit), task["argv"])
        with _captured() as (out, err):
            try:
                code = int(main(argv) or 0)
            except SystemExit as exc:  # argparse: a bad option in the manifest
                code = exc.code if isinstance(exc.code, int) else 2
        stdout, stderr = out.getvalue(), err.getvalue()
    if code == 130:  # the command caught an interrupt (Ctrl-C in a serial batch): stop the batch, not one record
        raise KeyboardInterrupt
    swaps = [(str(tmp_data), task["data_path"])] + ([(str(tmp_fit), task["fit_path"])] if tmp_fit else [])
    for a, b in swaps:
        stdout, stderr = stdout.replace(a, b), stderr.replace(a, b)
        # a JSON string holds the path with JSON escapes
        stdout = stdout.replace(json.dumps(a)[1:-1], json.dumps(b)[1:-1])
    result = None
    if stdout.strip():
        try:
            result = json.loads(stdout)
        except json.JSONDecodeError:
            result = None
            code = code or 2
            stderr += "\nthe command printed something that is not JSON on stdout"
    message = _last_line(stderr) if code else ""
    return {"exit_code": code, "result": result, "message": message, "stderr": stderr[-4000:],
            "seconds": time.perf_counter() - t0, "worker": f"{socket.gethostname()}:{os.getpid()}"}
