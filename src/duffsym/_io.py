"""Safe file output and bounded file input, shared by every writer and reader of duffsym.

Writers go through :func:`atomic_write` (or its helpers :func:`write_text_atomic`,
:func:`write_json_atomic`): the content is written to a temporary file in the destination's
folder, flushed to disk and renamed over the destination, so a reader (or an interrupt, or a
failed write) never sees a half-written file: the destination holds the old content or the new,
never a mix.

Readers that accept user paths check them first with :func:`check_input_file`: a FIFO, a
character device (``/dev/urandom``, ``/dev/zero``) or a file above the size limit is refused with
one line instead of hanging or exhausting the memory. (``duffsym batch`` and the campaign writers
use the same helpers.)
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

from duffsym.errors import DataError

#: Suffix of the temporary files (a crash by SIGKILL can leave one behind; they are never results).
TMP_SUFFIX = ".tmp"
#: Largest input file read by default (bytes); ``DUFFSYM_MAX_INPUT_BYTES`` overrides it.
MAX_INPUT_BYTES = 2 * 1024**3


def max_input_bytes() -> int:
    """The input size limit in bytes (``$DUFFSYM_MAX_INPUT_BYTES`` or :data:`MAX_INPUT_BYTES`)."""
    env = os.environ.get("DUFFSYM_MAX_INPUT_BYTES")
    try:
        return int(env) if env else MAX_INPUT_BYTES
    except ValueError:
        return MAX_INPUT_BYTES


@contextlib.contextmanager
def atomic_write(path, mode: str = "w", *, encoding: str | None = "utf-8", newline: str | None = None) -> Iterator[IO]:
    """Open a temporary file beside ``path`` for writing; on success rename it over ``path``.

    On any exception (including KeyboardInterrupt) the temporary file is removed and ``path`` is
    left as it was. The parent folder is created if missing.

    Parameters
    ----------
    path : the destination.
    mode : ``"w"`` (text) or ``"wb"`` (binary).
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_write: mode must be 'w' or 'wb'; got {mode!r}")
    kwargs: dict[str, Any] = {} if "b" in mode else {"encoding": encoding, "newline": newline}
    with atomic_path(path, keep_suffix=False) as tmp, open(tmp, mode, **kwargs) as fh:
        yield fh
        fh.flush()
        os.fsync(fh.fileno())


def _keep_mode(path: Path, tmp: str) -> None:
    """Give the temporary file the permissions a plain ``open(path, "w")`` would have given."""
    try:
        os.chmod(tmp, stat.S_IMODE(os.stat(path).st_mode))
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)


@contextlib.contextmanager
def atomic_path(path, *, keep_suffix: bool = True) -> Iterator[Path]:
    """A temporary path beside ``path`` for writers that want a file name (``savefig``, ``np.savez``:
    ``keep_suffix``, the default, keeps ``path``'s suffix, from which they take the format); renamed
    over ``path`` on success, removed on failure. Without ``keep_suffix`` the name ends in ``.tmp``,
    so that a temporary file never matches the pattern of finished ones (e.g. ``*.json``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    prefix, suffix = (f".{path.stem}.", f"{TMP_SUFFIX}{path.suffix}") if keep_suffix else (f".{path.name}.", TMP_SUFFIX)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=prefix, suffix=suffix)
    except OSError as exc:
        raise OSError(exc.errno, f"cannot write {path} ({exc.strerror or exc})") from None
    os.close(fd)
    try:
        yield Path(tmp)
        _keep_mode(path, tmp)
        os.replace(tmp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if exc.filename is None and str(path) not in str(exc):  # write() errors (disk full) name no file
            raise OSError(exc.errno, f"cannot write {path} ({exc.strerror or exc})") from None
        raise
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` to ``path`` atomically."""
    with atomic_write(path) as fh:
        fh.write(text)
    return Path(path)


def write_json_atomic(path, obj, **kwargs) -> Path:
    """Write ``obj`` as JSON (indent 2, no NaN) to ``path`` atomically; serialisation errors leave ``path``
    untouched."""
    text = json.dumps(obj, indent=kwargs.pop("indent", 2), allow_nan=kwargs.pop("allow_nan", False), **kwargs)
    return write_text_atomic(path, text)


def check_input_file(path, *, what: str = "data file", limit: int | None = None) -> int:
    """Raise a one-line :class:`DataError` unless ``path`` is a regular file of at most ``limit`` bytes.

    FIFOs, sockets and devices (``/dev/zero``, ``/dev/urandom``, ``<(cat file)``) cannot be sized
    and would hang or fill the memory; they are refused with a note to copy the data to a file.

    Returns
    -------
    int
        The file size in bytes.
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise DataError(f"{path}: no such file; check the path") from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read the {what} ({exc.strerror or exc}); check the path") from None
    if stat.S_ISDIR(st.st_mode):
        raise DataError(f"{path}: is a folder, not a {what}; give a file")
    if not stat.S_ISREG(st.st_mode):
        kind = (
            "a pipe (FIFO)"
            if stat.S_ISFIFO(st.st_mode)
            else ("a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else "not a regular file")
        )
        raise DataError(f"{path}: is {kind}, which cannot be sized; save the {what} to a regular file first")
    limit = max_input_bytes() if limit is None else limit
    if st.st_size > limit:
        raise DataError(
            f"{path}: {st.st_size / 1e6:.1f} MB is more than the {limit / 1e6:.0f} MB limit for a "
            f"{what}; split the record or raise DUFFSYM_MAX_INPUT_BYTES"
        )
    return int(st.st_size)


def same_file(a, b) -> bool:
    """Whether paths ``a`` and ``b`` name the same existing file (or the same path once resolved)."""
    a, b = Path(a), Path(b)
    try:
        return os.path.samefile(a, b)
    except OSError:
        try:
            return a.resolve() == b.resolve()
        except RuntimeError:  # a symbolic link loop (Python < 3.13 raises RuntimeError)
            bad = a if _link_loop(a) else b
            raise DataError(f"{bad}: a loop of symbolic links; give a real file path") from None


def _link_loop(path: Path) -> bool:
    try:
        path.resolve()
    except RuntimeError:
        return True
    return False


def check_output_path(path, *, inputs=(), option: str = "--out") -> Path:
    """Check before the work that ``path`` can be written and is none of ``inputs``.

    Raises a one-line :class:`DataError` if ``path`` is an input, an existing folder, or its folder
    cannot be created or written to. The folder is created if missing.
    """
    path = Path(path)
    if path.is_symlink() and _link_loop(path):
        raise DataError(f"{option} {path}: a loop of symbolic links; give a real file path")
    for src in inputs:
        if src is not None and same_file(path, src):
            raise DataError(
                f"{option} {path} is also an input ({src}); writing it would destroy the input: choose "
                "another output path"
            )
    if path.is_dir():
        raise DataError(f"{option} {path} is a folder; give a file name")
    _writable_folder(path.parent, f"{option} {path}", "another output path")
    if path.exists() and not os.access(path, os.W_OK):
        raise DataError(f"{option} {path}: the file exists and is not writable; choose another output path")
    return path


def check_output_dir(folder, *, option: str = "--report") -> Path:
    """Check before the work that ``folder`` is (or can be made) a writable folder."""
    folder = Path(folder)
    if folder.is_symlink() and _link_loop(folder):
        raise DataError(f"{option} {folder}: a loop of symbolic links; give a real folder")
    if folder.exists() and not folder.is_dir():
        raise DataError(f"{option} {folder} is a file, not a folder; give a folder")
    _writable_folder(folder, f"{option} {folder}", "another folder")
    return folder


def _writable_folder(folder: Path, what: str, instead: str) -> None:
    """Create ``folder`` if needed and check it is writable; ``what`` (option and path) starts the error."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DataError(
            f"{what}: cannot create the folder {folder} ({exc.strerror or exc}); choose {instead}"
        ) from None
    if not os.access(folder, os.W_OK | os.X_OK):
        raise DataError(f"{what}: the folder {folder} is not writable; choose {instead}")


def read_columns(path, roles: dict[str, tuple[str, ...]], optional=()) -> dict:
    """Named numeric columns of a small CSV with a header: ``roles`` maps a role to the accepted column
    names (matched case-insensitively, first hit wins); one-line errors name the file, row and column."""
    import numpy as np

    p = Path(path)
    check_input_file(p)
    with p.open("r", encoding="utf-8-sig", newline="") as fh:
        rows = list(csv.reader(fh))
    rows = [r for r in rows if any(f.strip() for f in r)]
    if len(rows) < 3:
        raise DataError(f"{path}: needs a header row and at least 2 data rows; got {max(len(rows) - 1, 0)} data row(s)")
    header = [h.strip().lower() for h in rows[0]]
    index = {}
    for role, names in roles.items():
        hit = next((header.index(n) for n in names if n in header), None)
        if hit is None and role not in optional:
            raise DataError(f"{path}: missing column {names[0]!r} (the {role}); the file has {rows[0]}; rename it")
        if hit is not None:
            index[role] = hit
    out = {r: np.empty(len(rows) - 1) for r in index}
    for k, row in enumerate(rows[1:], start=2):
        for role, i in index.items():
            try:
                v = float(row[i])
            except (IndexError, ValueError):
                raise DataError(
                    f"{path}: row {k}, column {rows[0][i]!r}: not a number "
                    f"({row[i] if i < len(row) else 'missing'!r}); fix the value"
                ) from None
            if not math.isfinite(v):
                raise DataError(f"{path}: row {k}, column {rows[0][i]!r}: not finite ({row[i]!r}); fill or remove it")
            out[role][k - 2] = v
    return out
