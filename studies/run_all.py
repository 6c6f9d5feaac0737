"""Run every study: ``python studies/run_all.py [--smoke] [--workers N] [--force]`` (what ``duffsym reproduce`` calls).

The studies are the files ``studies/sNN_<name>.py``. Each study's outputs are cached under a hash of
what it depends on (:func:`study_key`: the duffsym version and the bytes of its source, the study's
own scripts, the stored benchmark results it reads (:data:`READS`), the shipped records in ``data/``,
the names, sizes and times of the external data files, the mode and the Python version); a study whose key is unchanged and whose recorded files are all
there is skipped with a line saying so (``--force`` reruns it). The key and the file list are in
``<derived>/.reproduce/<study>.json``.

With ``--workers 1`` (the default of this script) the studies run one after another in this process,
in order of NN. With ``--workers N`` they run in parallel on :class:`duffsym.engine.Engine` (N local
worker processes), each study in its own Python process (its output goes to
``<derived>/.reproduce/<study>.log``), the longest first; a study that reads another's results runs
after it in the same task (:data:`AFTER`). One line per study gives its status, wall time and the
files it wrote; a failing study never stops the others; the exit status is 1 if any failed.
"""
from __future__ import annotations

import hashlib
import importlib
import json
import os
import platform
import subprocess
import sys
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import paths  # noqa: E402

HERE = Path(__file__).resolve().parent
#: every ``studies/sNN_<name>.py`` in order of NN (each has ``main(argv)`` taking ``--smoke``)
STUDIES = tuple(sorted(p.stem for p in HERE.glob("s[0-9][0-9]_*.py")))
#: typical full-run seconds per study: the order of a parallel run (longest first) and the weights of the estimate
#: of the time left; 60 s if not listed. Measured 2026-11-27: fresh virtualenv and empty code cache,
#: ``--workers 2`` on 2 cores with another job on one of them (load 3-4); s11 and s14 in their short versions
TYPICAL_SECONDS = {"s01": 8, "s02": 11, "s03": 3, "s04": 2, "s05": 18, "s06": 464, "s07": 1216, "s08": 126,
                   "s09": 78, "s10": 376, "s11": 468, "s12": 19, "s13": 233, "s14": 60}
#: study prefix -> the studies whose results it reads (it runs after them) or whose code it imports
AFTER = {"s11": ("s06",)}
IMPORTS = {"s07": ("s06",), "s11": ("s06",)}
#: study prefix -> the stored benchmark results it reads in its default (reproduce) mode: part of its key
READS = {"s11": ("benchmarks/results/s11_current_driven.json",),
         "s14": ("benchmarks/results/s14_model_comparison.json",)}
USAGE = "usage: run_all.py [--smoke] [--workers N] [--force]"


def _estimate(done: list[str], left: list[str], elapsed: float, smoke: bool) -> str:
    """``about m:ss left`` from the typical times of the studies done and left (equal weights for smoke)."""
    def weight(name):
        return 1.0 if smoke else float(TYPICAL_SECONDS.get(name[:3], 60))

    if not done or elapsed <= 0:
        return ""
    seconds = int(elapsed / sum(map(weight, done)) * sum(map(weight, left)))
    return f", about {seconds // 60}:{seconds % 60:02d} left"


def _outputs_since(start: float, prefixes: tuple[str, ...]) -> list[str]:
    """Files named ``<prefix>...`` under the output folders modified since ``start`` (epoch seconds)."""
    found = []
    for folder in (paths.derived_dir(), paths.figures_dir(), paths.output_dir()):
        if folder.is_dir():
            for f in sorted(folder.iterdir()):
                if f.is_file() and f.name.startswith(prefixes) and f.stat().st_mtime >= start - 1e-3:
                    found.append(str(f.relative_to(paths.output_root())))
    return found


# ------------------------------------------------------------------------------------------ the cache
def _hash_files(h, files) -> None:
    for f in sorted(files):
        h.update(b"\0" + str(f).encode() + b"\0")
        h.update(Path(f).read_bytes())


def _external_listing(h) -> None:
    """Names, sizes and modification times of the external data (hashing their bytes would take minutes)."""
    try:
        from duffsym.data import external_data_dir

        root = external_data_dir()
    except Exception:  # noqa: BLE001 - absent external data is part of the key too
        h.update(b"no external data")
        return
    for f in sorted(p for p in root.rglob("*") if p.is_file()):
        st = f.stat()
        h.update(f"{f.relative_to(root)}|{st.st_size}|{int(st.st_mtime)}\n".encode())


def package_hash() -> str:
    """SHA-256 of duffsym's version and the bytes of its source files."""
    import duffsym

    h = hashlib.sha256(duffsym.__version__.encode())
    _hash_files(h, Path(duffsym.__file__).parent.rglob("*.py"))
    return h.hexdigest()


def study_key(name: str, smoke: bool, *, package: str | None = None, external: str | None = None) -> str:
    """The hash of everything study ``name`` depends on (see the module docstring)."""
    h = hashlib.sha256(f"{name}|{'smoke' if smoke else 'full'}|{platform.python_version()}".encode())
    h.update((package or package_hash()).encode())
    own = [HERE / f"{name}.py", HERE / "_common.py", HERE / "paths.py", HERE / "duffsym.mplstyle"]
    own += [p for dep in IMPORTS.get(name[:3], ()) for p in HERE.glob(f"{dep}_*.py")]
    own += [paths.repo_root() / f for f in READS.get(name[:3], ())]
    _hash_files(h, [p for p in own if p.is_file()])
    _hash_files(h, [p for p in (paths.repo_root() / "data").glob("*") if p.is_file()])
    if external is None:
        e = hashlib.sha256()
        _external_listing(e)
        external = e.hexdigest()
    h.update(external.encode())
    return h.hexdigest()


def _cache_file(name: str) -> Path:
    return paths.derived_dir() / ".reproduce" / f"{name}.json"


def cached(name: str, key: str) -> dict | None:
    """The cache entry of ``name`` if its key is ``key`` and every file it recorded is still there."""
    try:
        entry = json.loads(_cache_file(name).read_text())
    except (OSError, ValueError):
        return None
    root = paths.output_root()
    if entry.get("key") != key or not entry.get("files") or not all((root / f).is_file() for f in entry["files"]):
        return None
    return entry


def remember(name: str, key: str, seconds: float, files: list[str]) -> None:
    path = _cache_file(name)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps({"key": key, "seconds": round(seconds, 1), "files": files}, indent=1))
    os.replace(tmp, path)


# ------------------------------------------------------------------------------------------ running
def _run_here(name: str, argv: list[str]) -> bool:
    """Run one study in this process (its ``main``); a raised error is printed and counts as a failure."""
    try:
        rc = importlib.import_module(name).main(argv)
        return rc in (0, None)
    except Exception:  # report and go on with the other studies
        traceback.print_exc()
        return False


def run_group(task: tuple) -> list[tuple[str, bool, float, float]]:
    """Run studies one after another, each in its own Python process: ``[(name, ok, start, seconds)]``.

    ``task`` is ``(names, argv, output_root)``; each study's stdout and stderr go to
    ``<derived>/.reproduce/<name>.log``. Runs on an engine worker.
    """
    names, argv, root = task
    env = {**os.environ, "MPLBACKEND": "Agg", paths.ENV_VAR: root}
    out = []
    for name in names:
        log = Path(root) / "data" / "derived" / ("smoke" if "--smoke" in argv else "") / ".reproduce" / f"{name}.log"
        log.parent.mkdir(parents=True, exist_ok=True)
        start, t0 = time.time(), time.perf_counter()
        script = HERE / f"{name}.py"
        with open(log, "w") as fh:
            rc = subprocess.run([sys.executable, str(script), *argv], cwd=str(paths.repo_root()), env=env,
                                stdout=fh, stderr=subprocess.STDOUT).returncode if script.is_file() else 2
            if not script.is_file():
                fh.write(f"no study {script}\n")
        out.append((name, rc == 0, start, time.perf_counter() - t0))
        done = log.with_suffix(".done")  # the parent reports the study from this as soon as it is there
        done.write_text(json.dumps(out[-1]))
    return out


def _groups(todo: list[str]) -> list[tuple[str, ...]]:
    """The studies to run as tasks: a study of :data:`AFTER` joins the task of what it reads; longest first."""
    groups: dict[str, list[str]] = {n: [n] for n in todo}
    for name in list(todo):
        for dep in AFTER.get(name[:3], ()):
            head = next((g for g in groups if g[:3] == dep), None)
            if head is not None and name in groups and name != head:
                groups[head] += groups.pop(name)
    weight = lambda g: sum(TYPICAL_SECONDS.get(n[:3], 60) for n in g)  # noqa: E731
    return sorted((tuple(g) for g in groups.values()), key=weight, reverse=True)


class Report:
    """One line per study as it finishes, and the summary."""

    def __init__(self, total: int, smoke: bool):
        self.total, self.smoke, self.t0 = total, smoke, time.perf_counter()
        self.lines: list[str] = []
        self.failed: list[str] = []
        self.done: list[str] = []

    def line(self, name: str, text: str, ok: bool = True) -> None:
        self.done.append(name)
        elapsed = time.perf_counter() - self.t0
        self.lines.append(f"{name}: {text}")
        if not ok:
            self.failed.append(name)
        print(f"[{int(elapsed) // 60}:{int(elapsed) % 60:02d}] {name}: {text} ({len(self.done)} of {self.total})",
              flush=True)

    def finish(self) -> int:
        print("\n".join(["", "summary:"] + self.lines))
        print(f"run_all.py: {len(self.done)} studies in {time.perf_counter() - self.t0:.1f} s", flush=True)
        if self.failed:
            print(f"run_all.py: {len(self.failed)} of {self.total} studies failed: {', '.join(self.failed)}",
                  file=sys.stderr)
            return 1
        return 0


def _finished(report: Report, name: str, ok: bool, start: float, seconds: float, key: str) -> None:
    files = _outputs_since(start, (name, name[:3] + "_"))
    if ok:
        remember(name, key, seconds, files)
    else:
        log = paths.derived_dir() / ".reproduce" / f"{name}.log"
        if log.is_file():  # a parallel run's study wrote here: show where it stopped
            tail = log.read_text(errors="replace").splitlines()[-12:]
            print("\n".join([f"--- end of {log}:"] + tail), file=sys.stderr, flush=True)
    report.line(name, f"{'ok' if ok else 'FAILED'} in {seconds:.1f} s; {len(files)} files: {', '.join(files)}", ok)


def _parse(argv: list[str]) -> dict | None:
    opts = {"smoke": False, "force": False, "workers": 1}
    it = iter(argv)
    for a in it:
        if a in ("--smoke", "--force"):
            opts[a[2:]] = True
        elif a == "--workers" or a.startswith("--workers="):
            value = a.split("=", 1)[1] if "=" in a else next(it, "")
            if not value.isdigit() or int(value) < 1:
                print(f"run_all.py: --workers takes a positive whole number; got {value!r}", file=sys.stderr)
                return None
            opts["workers"] = int(value)
        else:
            print(f"run_all.py: unknown argument {a!r}; {USAGE}", file=sys.stderr)
            return None
    return opts


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    opts = _parse(argv)
    if opts is None:
        return 2
    smoke = opts["smoke"]
    paths.set_mode("smoke" if smoke else "full")  # each study sets it again from its own argv
    study_argv = ["--smoke"] if smoke else []
    pkg, ext = package_hash(), hashlib.sha256()
    _external_listing(ext)
    keys = {n: study_key(n, smoke, package=pkg, external=ext.hexdigest()) for n in STUDIES}
    report = Report(len(STUDIES), smoke)
    todo = []
    for name in STUDIES:
        entry = None if opts["force"] else cached(name, keys[name])
        if entry:
            report.line(name, f"unchanged, skipped (cached: {entry['seconds']} s, {len(entry['files'])} files; "
                        "--force reruns it)")
        else:
            todo.append(name)
    if opts["workers"] <= 1 or len(todo) <= 1:
        _run_serial(todo, study_argv, report, keys)
    else:
        _run_parallel(todo, study_argv, report, keys, opts["workers"])
    return report.finish()


def _run_serial(todo, study_argv, report, keys) -> None:
    for k, name in enumerate(todo):
        elapsed = time.perf_counter() - report.t0
        print(f"[{int(elapsed) // 60}:{int(elapsed) % 60:02d}] {name} ({k + 1} of {len(todo)} to run"
              f"{_estimate(todo[:k], todo[k:], elapsed, report.smoke)})", file=sys.stderr, flush=True)
        start, t0 = time.time(), time.perf_counter()
        ok = _run_here(name, study_argv)
        _finished(report, name, ok, start, time.perf_counter() - t0, keys[name])


def _run_parallel(todo, study_argv, report, keys, workers: int) -> None:
    from duffsym.engine import Engine

    groups = _groups(todo)
    print(f"running {len(todo)} studies on {workers} worker processes, longest first: "
          + "; ".join(" then ".join(g) for g in groups), file=sys.stderr, flush=True)
    root = str(paths.output_root())
    folder = paths.derived_dir() / ".reproduce"
    for name in todo:
        (folder / f"{name}.done").unlink(missing_ok=True)
    watcher = _Watcher(folder, todo, lambda *r: _finished(report, *r, keys[r[0]]))
    with Engine(workers=workers) as engine:
        watcher.start()
        try:
            for outcome in engine.as_completed(run_group, [(g, study_argv, root) for g in groups]):
                watcher.poll()
                if not outcome.ok:
                    for name in groups[outcome.index]:
                        watcher.reported.add(name)
                        report.line(name, f"FAILED: the worker raised {type(outcome.error).__name__}: "
                                    f"{outcome.error}", ok=False)
                    continue
                for name, ok, start, seconds in outcome.value:
                    watcher.report(name, ok, start, seconds)
        finally:
            watcher.stop()


class _Watcher:
    """Reports each study of a parallel run as soon as its worker writes ``<name>.done`` (every 2 s)."""

    def __init__(self, folder: Path, names: list[str], on_done):
        import threading

        self.folder, self.names, self.on_done = folder, names, on_done
        self.reported: set[str] = set()
        self.lock = threading.Lock()
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self._loop, daemon=True)

    def start(self) -> None:
        self.thread.start()

    def stop(self) -> None:
        self.stopped.set()
        self.thread.join(timeout=5)

    def _loop(self) -> None:
        while not self.stopped.wait(2.0):
            self.poll()

    def poll(self) -> None:
        for name in self.names:
            done = self.folder / f"{name}.done"
            if name not in self.reported and done.is_file():
                try:
                    _, ok, start, seconds = json.loads(done.read_text())
                except (OSError, ValueError):
                    continue  # being written: next time
                self.report(name, ok, start, seconds)

    def report(self, name: str, ok: bool, start: float, seconds: float) -> None:
        with self.lock:
            if name in self.reported:
                return
            self.reported.add(name)
            self.on_done(name, ok, start, seconds)


if __name__ == "__main__":
    sys.exit(main())
