"""The derived stability conditions of a model, stored in the code cache so that a new process need not
derive them again (SymPy's Lyapunov derivation costs ~0.3 s per model, a sixth of a small cached fit).

A stored file is ``<cache>/conditions_<model key>_<derivation hash>.json``: the model's equations are in its
key and the derivation's source files in the hash, so a changed model or derivation is derived afresh. Each
condition is a Python expression over the parameter names; it is read back only through
:func:`safe_test`, which accepts arithmetic, comparisons, ``and``/``or``/``not`` and ``math`` functions on
those names and nothing else, so a planted file cannot run code (and a file that is not this user's, or
that others can write to, is not read at all).
"""

from __future__ import annotations

import ast
import functools
import hashlib
import json
import keyword
import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path

#: The derivation's sources whose text keys the stored conditions.
DERIVATION_FILES = ("stability.py", "lyapunov.py", "_mechanics.py", "energy.py", "coupled.py")
#: The stored form's version.
FORMAT = 1

_NODES = (
    ast.Expression, ast.BoolOp, ast.And, ast.Or, ast.UnaryOp, ast.Not, ast.USub, ast.UAdd, ast.BinOp, ast.Add,
    ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.Mod, ast.Compare, ast.Eq, ast.NotEq, ast.Lt, ast.LtE, ast.Gt,
    ast.GtE, ast.IfExp, ast.Name, ast.Attribute, ast.Call, ast.Constant, ast.Load,
)  # fmt: skip
_BUILTINS = {"abs": abs, "min": min, "max": max}


@functools.lru_cache(maxsize=1)
def derivation_hash() -> str:
    """A hash of the derivation's source files and the stored form's version."""
    import duffsym.derive as derive

    h = hashlib.sha256(f"format {FORMAT}".encode())
    folder = Path(derive.__file__).parent
    for name in DERIVATION_FILES:
        path = folder / name
        h.update(name.encode() + (path.read_bytes() if path.is_file() else b"-"))
    return h.hexdigest()[:16]


def _path(model) -> Path | None:
    from duffsym.codegen.compiled import cache_dir

    try:
        return cache_dir() / f"conditions_{model.key}_{derivation_hash()}.json"
    except OSError:
        return None


def _trusted(path: Path) -> bool:
    """A regular file of this user that no one else can write to (:func:`duffsym.codegen.compiled.trusted_file`)."""
    from duffsym.codegen.compiled import trusted_file

    try:
        return trusted_file(os.lstat(path))
    except OSError:
        return False


def load_conditions(model) -> list[tuple[str, list[str], str]] | None:
    """The stored conditions of ``model`` (None when there are none, the file is not trusted, or any row is not a
    condition :func:`safe_test` accepts)."""
    path = _path(model)
    if path is None or not _trusted(path):
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        rows = [(str(n), [str(a) for a in args], str(src)) for n, args, src in data["conditions"]]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if data.get("model") != model.key or any(safe_test(args, src) is None for _, args, src in rows):
        return None  # another model's, or a row that is not a condition: derived again and rewritten
    return rows


def save_conditions(model, rows: Sequence[tuple[str, list[str], str]]) -> None:
    """Store the conditions of ``model`` (silently skipped when the cache cannot be written)."""
    from duffsym._io import atomic_write

    path = _path(model)
    if path is None:
        return
    try:
        with atomic_write(path) as fh:
            json.dump({"model": model.key, "conditions": [list(r) for r in rows]}, fh)
    except OSError:
        return


def safe_test(args: Sequence[str], source: str) -> Callable[..., bool] | None:
    """``lambda *args: source`` when ``source`` is an expression of the allowed kinds (module docstring) over
    ``args``, else None."""
    if not all(a.isidentifier() and not keyword.iskeyword(a) and a not in ("math", *_BUILTINS) for a in args):
        return None
    try:
        tree = ast.parse(source, mode="eval")
    except SyntaxError:
        return None
    allowed = set(args) | {"math"} | set(_BUILTINS)
    for node in ast.walk(tree):
        if not isinstance(node, _NODES):
            return None
        if isinstance(node, ast.Name) and node.id not in allowed:
            return None
        if isinstance(node, ast.Attribute) and not (
            isinstance(node.value, ast.Name) and node.value.id == "math" and not node.attr.startswith("_")
        ):
            return None
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float, bool)):
            return None
        if isinstance(node, ast.Call) and (node.keywords or not _callable(node.func)):
            return None
    code = compile(f"lambda {', '.join(args)}: ({source})", "<stored stability condition>", "eval")
    return eval(code, {"__builtins__": {}, "math": math, **_BUILTINS})  # the expression was checked above


def _callable(func: ast.expr) -> bool:
    """A ``math`` function or one of the allowed builtins."""
    if isinstance(func, ast.Name):
        return func.id in _BUILTINS
    return isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == "math"


def tests_from(rows: Sequence[tuple[str, list[str], str]]) -> tuple:
    """``((name, test), ...)`` of the rows whose expression :func:`safe_test` accepts."""
    out = []
    for name, args, src in rows:
        test = safe_test(args, src)
        if test is not None:
            out.append((name, test))
    return tuple(out)
