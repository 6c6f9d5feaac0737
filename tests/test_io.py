"""The atomic-write and bounded-read helpers of duffsym._io."""

import os

import pytest

from duffsym._io import atomic_path, atomic_write, check_input_file, check_output_path, write_json_atomic
from duffsym.errors import DataError


def test_atomic_write_keeps_old_content_when_the_writer_fails(tmp_path):
    p = tmp_path / "fit.json"
    p.write_text("good")
    with pytest.raises(RuntimeError):
        with atomic_write(p) as fh:
            fh.write("half")
            raise RuntimeError("boom")
    assert p.read_text() == "good"
    assert sorted(os.listdir(tmp_path)) == ["fit.json"]  # no temporary file left behind


def test_atomic_write_survives_keyboard_interrupt(tmp_path):
    p = tmp_path / "data.csv"
    p.write_text("old")
    with pytest.raises(KeyboardInterrupt):
        with atomic_write(p) as fh:
            fh.write("x" * 1000)
            raise KeyboardInterrupt
    assert p.read_text() == "old" and len(os.listdir(tmp_path)) == 1


def test_json_that_cannot_be_serialised_leaves_the_file(tmp_path):
    p = tmp_path / "fit.json"
    p.write_text('{"ok": 1}')
    with pytest.raises(ValueError):
        write_json_atomic(p, {"x": float("nan")})
    assert p.read_text() == '{"ok": 1}'


def test_a_file_being_written_never_looks_finished(tmp_path):
    """While ``atomic_write`` writes ``r.json`` its temporary file ends in ``.tmp``, so a reader that
    lists finished results (``*.json``, as a resumed batch does) never counts it; ``atomic_path`` keeps
    the suffix for writers that take the format from it (``savefig``)."""
    with atomic_write(tmp_path / "r.json") as fh:
        fh.write("{}")
        assert list(tmp_path.glob("*.json")) == [] and len(list(tmp_path.glob(".r.json.*.tmp"))) == 1
    assert [p.name for p in tmp_path.glob("*.json")] == ["r.json"]
    with atomic_path(tmp_path / "f.png") as tmp:
        assert tmp.suffix == ".png"


def test_atomic_path_renames_on_success(tmp_path):
    p = tmp_path / "sub" / "fig.png"
    with atomic_path(p) as tmp:
        assert tmp.suffix == ".png" and tmp.parent == p.parent
        tmp.write_bytes(b"png")
    assert p.read_bytes() == b"png" and len(os.listdir(p.parent)) == 1


def test_new_file_gets_umask_permissions(tmp_path):
    p = write_json_atomic(tmp_path / "a.json", {})
    umask = os.umask(0)
    os.umask(umask)
    assert (os.stat(p).st_mode & 0o777) == (0o666 & ~umask)


@pytest.mark.parametrize("dev", ["/dev/zero", "/dev/urandom"])
def test_devices_are_refused(dev):
    with pytest.raises(DataError, match="device"):
        check_input_file(dev)


def test_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(DataError, match="FIFO"):
        check_input_file(fifo)


def test_size_limit(tmp_path):
    p = tmp_path / "big.csv"
    p.write_bytes(b"x" * 2000)
    with pytest.raises(DataError, match="limit"):
        check_input_file(p, limit=1000)
    assert check_input_file(p, limit=5000) == 2000


def test_output_equal_to_input_is_refused(tmp_path):
    data = tmp_path / "data.csv"
    data.write_text("time\n")
    with pytest.raises(DataError, match="also an input"):
        check_output_path(tmp_path / "." / "data.csv", inputs=[data])
    with pytest.raises(DataError, match="is a folder"):
        check_output_path(tmp_path, inputs=[data])
