"""The generated-code cache runs only code duffsym generated, from folders only this user controls."""

import os
import py_compile
import subprocess
import sys
import textwrap
import warnings

import pytest

from duffsym.codegen import compiled


def _run(code: str, cache, tmp_path) -> subprocess.CompletedProcess:
    env = {**os.environ, "DUFFSYM_CACHE": str(cache), "TMPDIR": str(tmp_path)}
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True, timeout=300
    )


def test_planted_bytecode_is_never_executed(tmp_path):
    """A .pyc planted beside the generated source (hash-based, unchecked: Python's importer trusts it
    without looking at the source) must not run; the module comes from the verified source."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    key = "duffsym_gen_planted_test"
    source = "VALUE = 1\n"
    (cache / f"{key}.py").write_text(source)
    marker = tmp_path / "pwned"
    evil = tmp_path / "evil.py"
    evil.write_text(f"open({str(marker)!r}, 'w').write('ran')\nVALUE = 666\n")
    pyc = cache / "__pycache__" / f"{key}.{sys.implementation.cache_tag}.pyc"
    pyc.parent.mkdir(mode=0o700)
    py_compile.compile(str(evil), cfile=str(pyc), invalidation_mode=py_compile.PycInvalidationMode.UNCHECKED_HASH)
    proc = _run(
        f"""
        from duffsym.codegen.compiled import load_generated
        m = load_generated({key!r}, {source!r})
        print(m.VALUE)
    """,
        cache,
        tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert not marker.exists(), "the planted bytecode ran"
    assert proc.stdout.strip() == "1"


def test_tampered_source_is_regenerated_not_run(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    key = "duffsym_gen_tampered_test"
    (cache / f"{key}.py").write_text("VALUE = 666\n")
    proc = _run(
        f"""
        from duffsym.codegen.compiled import load_generated
        print(load_generated({key!r}, "VALUE = 1\\n").VALUE)
    """,
        cache,
        tmp_path,
    )
    assert proc.stdout.strip() == "1", proc.stderr
    assert (cache / f"{key}.py").read_text() == "VALUE = 1\n"


@pytest.mark.parametrize("mode", [0o777, 0o775, 0o757])
def test_cache_writable_by_others_is_not_used(tmp_path, monkeypatch, mode):
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, mode)
    monkeypatch.setenv("DUFFSYM_CACHE", str(shared))
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        chosen = compiled.cache_dir()
    assert chosen != shared
    assert any("other users" in str(w.message) for w in caught)
    assert (os.stat(chosen).st_mode & 0o022) == 0 and os.stat(chosen).st_uid == os.getuid()


def test_pycache_writable_by_others_is_not_used(tmp_path, monkeypatch):
    c = tmp_path / "c"
    (c / "__pycache__").mkdir(parents=True)
    os.chmod(c, 0o700)
    os.chmod(c / "__pycache__", 0o777)
    assert "other users" in compiled._unsafe_reason(c)


def test_fallback_temp_cache_is_per_user_and_private(tmp_path, monkeypatch):
    monkeypatch.delenv("DUFFSYM_CACHE", raising=False)
    home = tmp_path / "home"
    home.mkdir()
    os.chmod(home, 0o500)  # ~/.cache cannot be created
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    try:
        chosen = compiled.cache_dir()
    finally:
        os.chmod(home, 0o700)
    if os.getuid() == 0:  # root ignores the 0500 mode: ~/.cache is created and private
        assert chosen == home / ".cache" / "duffsym"
    else:
        assert chosen == tmp_path / f"duffsym-cache-{os.getuid()}"
    assert (os.stat(chosen).st_mode & 0o077) == 0


def test_no_probe_file_is_written(tmp_path, monkeypatch):
    monkeypatch.setenv("DUFFSYM_CACHE", str(tmp_path / "c"))
    compiled.cache_dir()
    assert os.listdir(tmp_path / "c") == []


_NUMBA_SOURCE = "from numba import njit\n\n\n@njit(cache=True)\ndef f(x):\n    return x + 1\n\n\nVALUE = f(1)\n"


def _plant_pickle(index, marker) -> None:
    """Prepend to numba's index a pickle that creates ``marker`` when loaded (numba unpickles the index)."""
    import pickle

    class Evil:
        def __reduce__(self):
            return (exec, (f"open({str(marker)!r}, 'w').write('ran')",))

    index.write_bytes(pickle.dumps(Evil()) + index.read_bytes())


@pytest.mark.parametrize("how", ["writable-by-others", "another-user"])
def test_numba_index_files_not_safe_to_load_are_rebuilt_not_run(tmp_path, how):
    """Issue 24: a world-writable (or foreign) .nbi with a pickle prepended ran during a normal fit."""
    if how == "another-user" and os.getuid() != 0:
        pytest.skip("making a file another user's needs root")
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    key = "duffsym_gen_numba_index_test"
    code = f"""
        from duffsym.codegen.compiled import load_generated
        print(load_generated({key!r}, {_NUMBA_SOURCE!r}).VALUE)
    """
    first = _run(code, cache, tmp_path)
    assert first.stdout.strip() == "2", first.stderr
    indexes = sorted((cache / "__pycache__").glob(f"{key}.*.nbi"))
    assert indexes, "numba wrote no index"
    marker = tmp_path / "pwned"
    for idx in indexes:
        _plant_pickle(idx, marker)
        if how == "writable-by-others":
            os.chmod(idx, 0o666)
        else:
            os.chown(idx, 12345, 12345)
    second = _run(code, cache, tmp_path)
    assert second.stdout.strip() == "2", second.stderr
    assert not marker.exists(), "the planted index ran"
    for idx in sorted((cache / "__pycache__").glob(f"{key}.*.nbi")):  # rebuilt, this user's and private
        st = os.stat(idx)
        assert st.st_uid == os.getuid() and not st.st_mode & 0o022


def test_remove_untrusted_names_only_the_unsafe_files(tmp_path):
    pyc = tmp_path / "__pycache__"
    pyc.mkdir()
    ok, bad = pyc / "k.f-3.py311.nbi", pyc / "k.g-5.py311.nbc"
    other = pyc / "other.f-3.py311.nbi"
    for p in (ok, bad, other):
        p.write_bytes(b"x")
        os.chmod(p, 0o644)
    os.chmod(bad, 0o664)
    os.chmod(other, 0o666)  # another module's: left to its own load
    (tmp_path / "k.py").symlink_to(tmp_path / "elsewhere.py")
    removed = compiled.remove_untrusted(tmp_path, "k")
    assert sorted(p.name for p in removed) == ["k.g-5.py311.nbc", "k.py"]
    assert ok.exists() and other.exists() and not bad.exists()
