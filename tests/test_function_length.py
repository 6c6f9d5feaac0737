"""Functions in ``src/duffsym`` stay short enough to read: at most ``MAX_LINES`` lines of code (the
docstring not counted), unless their docstring gives the reason in one line starting with ``Long:``."""
from __future__ import annotations

import ast
from pathlib import Path

import duffsym

SRC = Path(duffsym.__file__).parent
MAX_LINES = 120


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
    assert not too_long, (f"functions over {MAX_LINES} lines of code; split them into named pieces or give the "
                          "reason in a docstring line starting with 'Long:':\n" + "\n".join(too_long))


def test_the_check_counts_code_and_honours_a_reason(tmp_path):
    body = "\n".join(f"    x{i} = {i}" for i in range(5))
    (tmp_path / "m.py").write_text(f'def f():\n    """Doc.\n\n    More.\n    """\n{body}\n\n\n'
                                   f'def g():\n    """Doc.\n\n    Long: a reason.\n    """\n{body}\n')
    assert long_functions(tmp_path, limit=4) == [f"{tmp_path.name}/m.py:1 f: 5 lines"]
    assert long_functions(tmp_path, limit=5) == []
