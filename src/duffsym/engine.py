"""Where independent pieces of work run: in this process, on local worker processes, or on a cluster.

One small interface over `Dask distributed <https://distributed.dask.org>`_ (an existing, well-kept
engine; duffsym adds no scheduler of its own)::

    with Engine(workers=2) as engine:            # a LocalCluster of 2 worker processes
        results = engine.map(func, items)        # ordered, like the built-in map
    with Engine(scheduler="tcp://host:8786"):    # the same code on a running Dask cluster
        ...
    Engine()                                     # serial, in this process (the default of the library)
    for outcome in engine.run(tasks): ...        # Task(func, args, kwargs) objects, as each finishes

A worker process imports duffsym and compiles its generated code once, then serves every task it
is given: the start-up (the imports and compilation every ``duffsym`` command pays) is paid once per
worker instead of once per piece of work. ``func`` and the items must be picklable (module-level
functions; cloudpickle also takes lambdas and closures). ``map`` has the signature emcee expects of
a pool, so an engine can be passed as ``pool=`` to :func:`duffsym.uncertainty.sample`.

Tasks run one at a time per worker (one thread each): IPOPT and the compiled simulators are
single-threaded, and two fits in threads of one process would only contend for the GIL.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from duffsym.errors import DuffsymError

KINDS = ("serial", "local", "cluster")


class EngineError(DuffsymError, RuntimeError):
    """The engine could not start or reach its workers."""


@dataclass(frozen=True)
class Outcome:
    """The outcome of one item of :meth:`Engine.as_completed`: its index, and its value or the error it raised."""

    index: int
    value: Any = None
    error: BaseException | None = None

    @property
    def ok(self) -> bool:
        return self.error is None


@dataclass(frozen=True)
class Task:
    """One piece of library work: a function and its arguments, run by :meth:`Engine.run` where the engine
    runs (pyPESTO's Engine/Task idea). ``func`` is a module-level function (it travels by name to worker
    processes), and the arguments and what it returns must be picklable: a typed result object, not text."""

    func: Callable
    args: tuple = ()
    kwargs: Mapping[str, Any] = field(default_factory=dict)

    def execute(self) -> Any:
        """Run the task here and return what its function returns."""
        return self.func(*self.args, **dict(self.kwargs))


def execute(task: Task) -> Any:
    """``task.execute()``: the function an engine maps over tasks."""
    return task.execute()


@dataclass
class Pending:
    """A call given to :meth:`Engine.submit`: its Dask future, or (serial) the call to make when asked."""

    future: Any = None
    task: Task | None = None

    def result(self) -> Any:
        """The call's value (its error raised here); waits for a worker's call to finish."""
        if self.future is None:
            assert self.task is not None
            return self.task.execute()
        try:
            return self.future.result()
        finally:
            self.future.release()


def default_workers() -> int:
    """The number of local worker processes used when none is given: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _call(func, item):
    return func(item)


class Engine:
    """Maps a function over items serially, on local processes (Dask ``LocalCluster``) or on a Dask cluster.

    Parameters
    ----------
    workers : None or 0 (default): serial, in this process. N >= 1: a ``LocalCluster`` of N worker
        processes with one thread each, started on entry and closed on exit.
    scheduler : address of a running Dask scheduler (``tcp://host:8786``, or a scheduler file path
        ending in ``.json``); overrides ``workers``. The workers must have duffsym installed (see the README).
    silence_logs : logging level below which Dask's own messages are hidden (default: ``logging.CRITICAL``,
        errors hidden too: a worker whose heartbeat met a scheduler closed by Ctrl-C logged a 30-line
        traceback under the batch's one-line "interrupted"; an error of the work itself reaches the caller as
        an exception, not as a log line).

    Use it as a context manager (or call :meth:`start` and :meth:`close`).
    """

    def __init__(self, workers: int | None = None, *, scheduler: str | None = None, silence_logs: int | None = None):
        if workers is not None and (isinstance(workers, bool) or int(workers) != workers or workers < 0):
            raise EngineError(f"workers must be a non-negative integer (0: serial in this process); got {workers!r}")
        self.workers = int(workers or 0)
        self.scheduler = scheduler
        self.silence_logs = silence_logs
        self.kind = "cluster" if scheduler else ("local" if self.workers >= 1 else "serial")
        self._client: Any = None  # a dask.distributed Client once started (dask is imported on start)
        self._cluster: Any = None  # its LocalCluster when local
        self._scattered: dict[int, tuple[Any, Any]] = {}

    # ------------------------------------------------------------------ life cycle
    def start(self) -> Engine:
        """Start the local cluster or connect to the scheduler (nothing to do when serial)."""
        if self.kind == "serial" or self._client is not None:
            return self
        import logging

        try:
            from dask.distributed import Client, LocalCluster
        except ImportError as exc:  # pragma: no cover - a dependency of duffsym
            raise EngineError(f"dask.distributed is not installed ({exc}); pip install 'distributed'") from None
        level = logging.CRITICAL if self.silence_logs is None else self.silence_logs
        try:
            if self.kind == "cluster":
                spec = str(self.scheduler)
                self._client = (
                    Client(scheduler_file=spec, timeout="30s")
                    if spec.endswith(".json")
                    else Client(spec, timeout="30s")
                )
            else:
                # the worker processes read Dask's logging settings when they import it, before LocalCluster's
                # silence_logs reaches them: a worker still starting when the batch is interrupted logged its
                # INFO lines ("Received 'close-stream' ...") under the CLI's one-line "interrupted"
                name = logging.getLevelName(level)
                if isinstance(name, str) and not name.startswith("Level"):
                    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", name.lower())
                # processes, one thread each; the scheduler and its status page on loopback, any free port
                self._cluster = LocalCluster(
                    n_workers=self.workers,
                    threads_per_worker=1,
                    processes=True,
                    host="127.0.0.1",
                    dashboard_address="127.0.0.1:0",
                    silence_logs=level,
                )
                self._client = Client(self._cluster)
        except OSError as exc:
            self.close()
            where = f"the scheduler at {self.scheduler}" if self.kind == "cluster" else "a local cluster"
            raise EngineError(
                f"cannot start or reach {where} ({exc}); check the address and that the scheduler "
                "runs (dask scheduler), or run without --scheduler"
            ) from None
        return self

    def close(self) -> None:
        """Disconnect, and stop the local cluster if this engine started it."""
        self._scattered.clear()
        for obj in (self._client, self._cluster):
            if obj is not None:
                try:
                    obj.close()
                except Exception:  # noqa: BLE001 - closing a half-dead cluster must not mask the real error
                    pass
        self._client = self._cluster = None

    def __enter__(self) -> Engine:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def n_workers(self) -> int:
        """Workers currently serving this engine (1 when serial)."""
        if self._client is None:
            return 1
        return len(self._client.scheduler_info().get("workers", {})) or self.workers

    def __repr__(self) -> str:
        where = self.scheduler if self.kind == "cluster" else f"{self.workers} local process(es)"
        return f"Engine({self.kind}: {where if self.kind != 'serial' else 'in this process'})"

    def __getstate__(self):  # an engine travels by name only (e.g. inside a pickled pool argument)
        raise TypeError("an Engine cannot be pickled; create it where the work is submitted")

    # ------------------------------------------------------------------ work
    def _func_ref(self, func):
        """A callable object (e.g. a log-posterior holding compiled simulators) is sent to the workers once,
        not with every task: emcee calls ``map`` with the same function at every step."""
        import types

        if isinstance(func, (types.FunctionType, types.BuiltinFunctionType)):
            return func, False
        key = id(func)
        if key not in self._scattered:
            future = self._client.scatter(func, broadcast=True, hash=False)
            self._scattered[key] = (func, future)  # holding func keeps its id unique
        return self._scattered[key][1], True

    def _submit(self, func, items: list):
        self.start()
        ref, scattered = self._func_ref(func)
        if scattered:
            return self._client.map(_call, [ref] * len(items), items, pure=False)
        return self._client.map(func, items, pure=False)

    def map(self, func: Callable, items: Iterable) -> list:
        """``[func(item) for item in items]``, run by the engine; the first error raised by a task is raised here."""
        items = list(items)
        if self.kind == "serial" or not items:
            return [func(item) for item in items]
        futures = self._submit(func, items)
        try:
            return self._client.gather(futures)
        finally:
            for f in futures:
                f.release()

    def submit(self, func: Callable, *args, **kwargs) -> Pending:
        """Start ``func(*args, **kwargs)`` on a worker and return at once (serial: it runs when its result is asked
        for), so that this process can do other work meanwhile; :meth:`Pending.result` waits for its value or raises
        its error. ``func`` is a module-level function (it travels by name)."""
        task = Task(func, args, kwargs)
        if self.kind == "serial":
            return Pending(task=task)
        self.start()
        return Pending(future=self._client.submit(execute, task, pure=False))

    def run(self, tasks: Iterable[Task]) -> Iterator[Outcome]:
        """Execute every :class:`Task`; yield an :class:`Outcome` per task (its index, and the task's return
        value or its error) as each finishes, as :meth:`as_completed` does."""
        return self.as_completed(execute, tasks)

    def as_completed(self, func: Callable, items: Iterable) -> Iterator[Outcome]:
        """Run ``func`` on every item; yield an :class:`Outcome` per item as each finishes (any order).

        An error raised by one item is yielded as that item's outcome and never stops the others.
        A worker that dies (killed, out of memory) is replaced by Dask and its task retried; a task
        that kills several workers is reported with Dask's ``KilledWorker`` error.
        """
        items = list(items)
        if self.kind == "serial":
            for i, item in enumerate(items):
                try:
                    yield Outcome(i, value=func(item))
                except Exception as exc:  # noqa: BLE001 - reported per item, the others go on
                    yield Outcome(i, error=exc)
            return
        if not items:
            return
        from dask.distributed import as_completed

        futures = self._submit(func, items)
        index = {f.key: i for i, f in enumerate(futures)}
        try:
            for future in as_completed(futures):
                i = index[future.key]
                try:
                    value = future.result()
                except Exception as exc:  # noqa: BLE001 - reported per item
                    yield Outcome(i, error=exc)
                else:
                    yield Outcome(i, value=value)
                future.release()
        finally:
            for f in futures:
                if not f.done():
                    f.cancel()
