"""Every input or output path problem is one line naming the path and the command, exit 2 (issue 24):
symbolic link loops, a batch's error under its own name (not its --command's), write errors that name
the file they could not write."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from duffsym.cli import main


@pytest.fixture()
def record(tmp_path):
    t = np.arange(400) * 0.005
    d = np.sin(2 * np.pi * 2 * t)
    path = tmp_path / "rec.csv"
    np.savetxt(path, np.column_stack([t, d, 0.5 * d]), delimiter=",", header="time,displacement,force", comments="")
    return path


@pytest.fixture()
def loop(tmp_path):
    a, b = tmp_path / "loopA", tmp_path / "loopB"
    os.symlink(b, a)
    os.symlink(a, b)
    return a


def _one_line_exit_2(capsys, argv, *words):
    code = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, (code, err)
    assert all(w in err[0] for w in words), err[0]
    assert "internal error" not in err[0] and "Traceback" not in err[0]
    return err[0]


@pytest.mark.parametrize(
    "argv",
    [
        ["fit", "{rec}", "--out", "{loop}"],
        ["fit", "{rec}", "--plot", "{loop}"],
        ["fit", "{loop}"],
        ["batch", "{rec}", "--command", "fit", "--out", "{loop}", "--workers", "0"],
        ["convert", "{rec}", "--columns", "time=1,displacement=2,force=3", "--out", "{loop}"],
    ],
)
def test_a_symlink_loop_is_one_line_and_exit_2(capsys, record, loop, argv):
    argv = [a.format(rec=record, loop=loop) for a in argv]
    _one_line_exit_2(capsys, argv, f"duffsym {argv[0]}:", "loop")


def test_a_batch_error_carries_the_batch_command_name(capsys, record, tmp_path):
    (tmp_path / "afile").write_text("x")
    line = _one_line_exit_2(
        capsys, ["batch", str(record), "--command", "fit", "--out", str(tmp_path / "afile"), "--workers", "0"], "afile"
    )
    assert line.startswith("duffsym batch:")


def test_a_write_that_fails_names_the_file(capsys, record, tmp_path, monkeypatch):
    """Disk full: write() raises ENOSPC with no file name; the message names the output and the command."""
    import duffsym._io as io

    real = io.os.replace

    def full(src, dst):
        if str(dst).endswith("fit.json"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(src, dst)

    monkeypatch.setattr(io.os, "replace", full)
    out = tmp_path / "fit.json"
    code = main(["fit", str(record), "--out", str(out), "--quiet"])
    line = capsys.readouterr().err.strip().splitlines()[-1]  # (after the fit's own notes)
    assert code == 2 and line.startswith("duffsym fit: error:") and "No space left on device" in line
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())
    assert line.count(str(out)) == 1


@pytest.mark.parametrize("victim", ["rec.json", "summary.json"])
def test_a_batch_write_that_fails_names_the_file_and_the_batch(capsys, record, tmp_path, monkeypatch, victim):
    """Disk full under ``batch``: the one line names the file it could not write and the batch command (it read
    ``duffsym fit: error: [Errno 28] No space left on device`` before), exit 2, no temporary file left."""
    import duffsym._io as io

    real = io.os.replace

    def full(src, dst):
        if str(dst).endswith(victim):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return real(src, dst)

    monkeypatch.setattr(io.os, "replace", full)
    out = tmp_path / "out"
    line = _one_line_exit_2(
        capsys,
        ["batch", str(record), "--command", "fit", "--out", str(out), "--workers", "0", "--quiet"],
        "No space left on device",
    )
    assert line.startswith("duffsym batch: error:") and line.count(str(out / victim)) == 1
    assert not any(".tmp" in p.name for p in out.iterdir())


def test_a_batch_into_a_folder_it_cannot_write_stops_before_any_fit(capsys, record, tmp_path, monkeypatch):
    """A read-only results folder is refused up front, as ``fit --out`` is (simulated through ``os.access``: the
    tests may run as root, for whom a folder's mode does not stop a write)."""
    import duffsym._io as io

    out = tmp_path / "ro"
    out.mkdir()
    real = io.os.access
    monkeypatch.setattr(io.os, "access", lambda p, m, *a, **k: False if os.fspath(p) == str(out) else real(p, m))
    fitted = []
    import duffsym.identify as identify

    monkeypatch.setattr(identify, "fit", lambda *a, **k: fitted.append(1))
    line = _one_line_exit_2(
        capsys, ["batch", str(record), "--command", "fit", "--out", str(out), "--workers", "0"], "not writable"
    )
    assert line.startswith("duffsym batch: error: --out") and str(out) in line and not fitted
    assert list(out.iterdir()) == []
