"""Ctrl-C of ``duffsym batch --workers 2`` at any moment (imports, the local cluster starting, fits
running) prints one line and exits 130 (issue 24: 4 of 6 tries printed a 20-line traceback from the
cluster's shutdown, or from the interrupted imports)."""

from __future__ import annotations

import math
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parents[1] / "data"


#: at 0.8 s a worker process may still be starting its own interpreter; 1 run in 6 it then prints its own
#: KeyboardInterrupt traceback from multiprocessing's spawn_main (seen after the merge of issue 24's fix;
#: the parent's atexit shutdown is quiet since). A known, open defect, not a passing claim.
SPAWNING = pytest.mark.xfail(
    reason="a worker interrupted inside multiprocessing's spawn_main prints its own traceback (about 1 run in 6)",
    strict=False,
)


@pytest.mark.parametrize("delay", [pytest.param(0.8, marks=SPAWNING), 1.5, 2.5, 3.5])  # after the interpreter started
def test_ctrl_c_of_a_batch_is_one_line(tmp_path, delay):
    recs = tmp_path / "recs"
    recs.mkdir()
    # six fits: the batch runs about 8 s, well past the last interrupt (two records ended near 3.5 s, and an
    # interrupt landing as the interpreter shut down killed it with SIGINT: exit -2, not a defect of the batch)
    for k in range(3):
        for name in ("synthetic_sine", "synthetic_random"):
            shutil.copy(DATA / f"{name}.csv", recs / f"{name}_{k}.csv")
    cmd = [
        sys.executable,
        "-m",
        "duffsym.cli",
        "batch",
        str(recs),
        "--command",
        "fit",
        "--out",
        str(tmp_path / "out"),
        "--workers",
        "2",
        "--quiet",
    ]
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(delay)
    # the batch must still be running, or the test interrupts nothing (a skip here would leave Ctrl-C untested)
    assert proc.poll() is None, "the batch finished before the interrupt: give it longer records"
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert proc.returncode == 130 and lines == ["interrupted"], (proc.returncode, lines[:5])


def test_an_interrupt_swallowed_by_a_gc_callback_still_stops_the_command():
    """CI saw it (the 3.5 s case above): Ctrl-C landed inside Dask's garbage-collector callback, Python printed
    "Exception ignored in ... GCDiagnosis._gc_callback ... KeyboardInterrupt", and the batch ran on and exited 0.
    Here a collector callback raises the interrupt: the command's work must stop, and nothing is printed."""
    import gc

    fired, slept = _interrupt_swallowed_by_gc(30.0)  # the redelivered interrupt (after 50 ms) cuts the sleep short
    state = (signal.getsignal(signal.SIGINT), signal.pthread_sigmask(signal.SIG_BLOCK, []), gc.callbacks)
    assert fired == [1] and slept < 10.0, state  # the handler, blocked signals, callbacks


def _interrupt_swallowed_by_gc(sleep: float) -> tuple[list[int], float]:
    """A collector callback raises KeyboardInterrupt once (Python swallows it) inside ``interrupts_reach_main``,
    then the block sleeps ``sleep`` s: (whether it fired, the seconds the sleep lasted). The block must raise."""
    import gc

    from duffsym.cli import interrupts_reach_main

    fired: list[int] = []

    def callback(phase, info):
        if not fired:
            fired.append(1)
            raise KeyboardInterrupt

    t0 = [math.inf]
    try:
        with pytest.raises(KeyboardInterrupt), interrupts_reach_main():
            # registered inside the guard: a collection in another thread (one an earlier test in this worker left
            # running) would otherwise fire it before the guard's hook is in place, and Python would swallow it
            gc.callbacks.append(callback)
            gc.collect()
            t0[0] = time.perf_counter()
            time.sleep(sleep)
    finally:
        gc.callbacks.remove(callback)
    return fired, time.perf_counter() - t0[0]


def test_an_interrupt_swallowed_just_before_the_work_ends_is_not_lost():
    """The race CI's rehearsal found: the work ended within the 50 ms before the redelivery; the block's end
    raises it then (exit 130), and no SIGINT is sent afterwards to a process already shutting down."""
    import gc

    from duffsym.cli import interrupts_reach_main

    def callback(phase, info):
        gc.callbacks.remove(callback)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt), interrupts_reach_main():
        gc.callbacks.append(callback)  # inside the guard, as above
        gc.collect()
    time.sleep(0.2)  # a stray SIGINT from a timer would raise here


def test_outside_the_guard_python_swallows_that_interrupt():
    """The trap above is real: without :func:`interrupts_reach_main` the same callback's interrupt is lost."""
    import gc

    fired: list[int] = []
    seen: list[type] = []

    def callback(phase, info):
        if not fired:
            fired.append(1)
            raise KeyboardInterrupt

    previous, sys.unraisablehook = sys.unraisablehook, lambda u: seen.append(type(u.exc_value))
    gc.callbacks.append(callback)
    try:
        gc.collect()
        finished = True
    finally:
        gc.callbacks.remove(callback)
        sys.unraisablehook = previous
    assert finished and fired == [1] and seen == [KeyboardInterrupt]


def test_an_interrupt_is_redelivered_even_when_a_flag_only_handler_was_left_installed():
    """A handler left behind by other code that only sets a flag (or ignores SIGINT) would swallow the redelivered
    interrupt, and the work would run to its end. One candidate cause of the full-suite failure of the test above,
    which this test reproduces on purpose. Within the block, Python's default handler is put in place, and the
    other handler is put back afterwards."""

    def flag_only(signum, frame):
        pass

    old = signal.signal(signal.SIGINT, flag_only)
    try:
        fired, slept = _interrupt_swallowed_by_gc(5.0)
        assert signal.getsignal(signal.SIGINT) is flag_only
    finally:
        signal.signal(signal.SIGINT, old)
    assert fired == [1] and slept < 3.0


def _distributed_log_level(_):
    import logging

    return logging.getLogger("distributed.core").getEffectiveLevel()


def test_the_local_cluster_workers_start_with_dask_logging_silenced():
    """CI saw "interrupted" followed by a worker's "distributed.core - INFO - Received 'close-stream' ...": the
    worker processes read Dask's logging settings when they import it (INFO), before LocalCluster's silence_logs
    reaches them. They now start at the engine's level; before: 20 (INFO). The level is CRITICAL: at ERROR, a CI run
    of bb62381 showed a worker's "distributed.worker - ERROR - Failed to communicate with scheduler during
    heartbeat" and its traceback (30 lines) after Ctrl-C of a batch, the scheduler closed before the worker."""
    import logging

    from duffsym.engine import Engine

    with Engine(workers=2) as engine:
        levels = engine.map(_distributed_log_level, [0, 1])
    assert levels == [logging.CRITICAL, logging.CRITICAL]
