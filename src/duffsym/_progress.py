"""Progress of long work on stderr: elapsed time, a count, an estimate of the time left.

Long commands (``diagnose``, ``ladder``, ``sample``, ``reproduce``) take minutes on records of
thousands of samples. :class:`Progress` prints one line per step on stderr (never stdout, so
``--json`` output stays one JSON object), prefixed with the elapsed time; a step that is item
``done + 1`` of ``total`` gets the count and an estimate of the time left from the mean time of the
items done so far. ``--quiet`` passes None instead, and nothing is printed.

Library functions take ``progress`` as any callable of one message string (``print`` works);
:func:`reporter` adapts it, so they can pass counts without knowing what they were given.
"""

from __future__ import annotations

import sys
import time


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return (
        f"{seconds // 60}:{seconds % 60:02d}"
        if seconds < 3600
        else f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"
    )


class Progress:
    """One line per step on ``stream`` (stderr): ``[m:ss] message (k of n, about m:ss left)``."""

    def __init__(self, stream=None, prefix: str = ""):
        self.stream = stream
        self.prefix = prefix
        self.t0 = time.perf_counter()
        self._group: tuple[int, float] | None = None  # (total, start time) of the counted items

    def __call__(self, msg: str, done: int | None = None, total: int | None = None) -> None:
        now = time.perf_counter()
        text = msg
        if total is not None and done is not None:
            if done == 0 or self._group is None or self._group[0] != total:
                self._group = (total, now)
            count = f"{done + 1} of {total}"
            if done > 0:
                left = (now - self._group[1]) / done * (total - done)
                count += f", about {_clock(left)} left"
            text = f"{msg} ({count})"
        out = self.stream or sys.stderr
        print(f"{self.prefix}[{_clock(now - self.t0)}] {text}", file=out, flush=True)


def _silent(msg: str, done: int | None = None, total: int | None = None) -> None:
    return None


def reporter(progress):
    """A ``say(msg, done=None, total=None)`` from ``progress``: a :class:`Progress`, any one-argument
    callable (the count is appended to its message), or None (silent)."""
    if progress is None:
        return _silent
    if isinstance(progress, Progress):
        return progress

    def say(msg: str, done: int | None = None, total: int | None = None) -> None:
        progress(msg if total is None or done is None else f"{msg} ({done + 1} of {total})")

    return say
