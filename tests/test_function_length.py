"""Functions in ``src/duffsym`` stay short enough to read: at most ``MAX_LINES`` lines of code (the
docstring not counted), unless their docstring gives the reason in one line starting with ``Long:``."""

from __future__ import annotations

import ast
from pathlib import Path

import duffsym

SRC = Path(duffsym.__file__).parent
MAX_LINES = 80


def code_lines(node: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines from the first statement after the docstring to the function's end."""
    body = node.body
    if ast.get_docstring(node) is not None and len(body) > 1:
        body = body[1:]
    return node.end_lineno - body[0].lineno + 1


def long_functions(root: Path = SRC, limit: int = MAX_LINES) -> list[str]:
    out = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            n = code_lines(node)
            doc = ast.get_docstring(node) or ""
            if n > limit and not any(line.strip().startswith("Long:") for line in doc.splitlines()):
                out.append(f"{path.relative_to(root.parent)}:{node.lineno} {node.name}: {n} lines")
    return out


def test_no_function_is_longer_than_the_limit_without_a_reason():
    too_long = long_functions()
    assert not too_long, (
        f"functions over {MAX_LINES} lines of code; split them into named pieces or give the "
        "reason in a docstring line starting with 'Long:':\n" + "\n".join(too_long)
    )


def test_the_check_counts_code_and_honours_a_reason(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(5))
    (tmp_path / "m.py").write_text(
        f'def f():\n    """Doc.\n\n    More.\n    """\n{body}\n\n\n'
        f'def g():\n    """Doc.\n\n    Long: a reason.\n    """\n{body}\n'
    )
    assert long_functions(tmp_path, limit=4) == [f"{tmp_path.name}/m.py:1 f: 5 lines"]
    assert long_functions(tmp_path, limit=5) == []


#: packages already held to the house target (issue 27): at most this many lines of code per function, with no
#: exemption; their command modules (the command layer's) and the modules of other owners are not in it yet
STRICT_PACKAGES = ("diagnose", "uncertainty", "derive", "data", "control", "plot")
STRICT_LINES = 80
NOT_YET = ("command.py", "discover.py", "drift.py", "_mechanics.py")
#: the most parameters a public function of the strict packages takes (more: an options object, see duffsym.options)
MAX_PARAMETERS = 12


def _strict_functions():
    for package in STRICT_PACKAGES:
        for path in sorted((SRC / package).rglob("*.py")):
            if path.name in NOT_YET or path.name.endswith("_command.py"):
                continue
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                    yield path, node


def _n_parameters(node) -> int:
    a = node.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs] + [x.arg for x in (a.vararg, a.kwarg) if x]
    return len([n for n in names if n not in ("self", "cls")])


def test_the_strict_packages_keep_functions_within_80_lines():
    too_long = [
        f"{path.relative_to(SRC.parent)}:{node.lineno} {node.name}: {code_lines(node)} lines"
        for path, node in _strict_functions()
        if code_lines(node) > STRICT_LINES
    ]
    assert not too_long, f"functions over {STRICT_LINES} lines of code:\n" + "\n".join(too_long)


def test_public_functions_of_the_strict_packages_take_at_most_12_parameters():
    many = [
        f"{path.relative_to(SRC.parent)}:{node.lineno} {node.name}: {_n_parameters(node)} parameters"
        for path, node in _strict_functions()
        if not node.name.startswith("_") and _n_parameters(node) > MAX_PARAMETERS
    ]
    assert not many, "public functions with more than 12 parameters (use an options object):\n" + "\n".join(many)


def _public_functions():
    """Functions a user may call: no underscore in their name or their module's path (a private module such
    as a numba kernel template is not API)."""
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC)
        if any(part.startswith("_") and part != "__init__.py" for part in rel.parts):
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not node.name.startswith("_"):
                yield path, node


def test_no_public_function_takes_more_than_12_parameters():
    many = [
        f"{path.relative_to(SRC.parent)}:{node.lineno} {node.name}: {_n_parameters(node)} parameters"
        for path, node in _public_functions()
        if _n_parameters(node) > MAX_PARAMETERS
    ]
    assert not many, "public functions with more than 12 parameters (use an options object):\n" + "\n".join(many)
