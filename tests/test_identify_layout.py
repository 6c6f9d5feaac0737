"""The layout of ``duffsym.identify``: no private name crosses a module boundary, and its modules import
each other without a circle (the fit pipeline ``collocation`` on top of ``nlp``, ``states`` and
``covariance``).

Checked over the source with :mod:`ast` (imports inside functions included, so a lazy import cannot hide a
circle or a private name). The command-line modules that still sit in the package (``command.py``,
``*_command.py``) belong to the ``cli`` layer (``tests/test_layers.py``) and are left to its checks.
"""

from __future__ import annotations

import ast
from pathlib import Path

import duffsym.identify

PACKAGE = Path(duffsym.identify.__file__).parent
PREFIX = "duffsym.identify"


def _is_cli(path: Path) -> bool:
    return path.stem == "command" or path.stem.endswith("_command")


def modules(root: Path = PACKAGE) -> dict[str, Path]:
    """``{module name: path}`` of the package's modules (the ``__init__`` facade and the CLI layer left out)."""
    return {p.stem: p for p in sorted(root.glob("*.py")) if p.stem != "__init__" and not _is_cli(p)}


def private_imports(path: Path) -> list[str]:
    """Every underscore name ``path`` takes from another ``duffsym`` module: ``from duffsym.x import _y`` and
    ``m._y`` on a module imported as ``import duffsym.x as m``; ``file:line name`` each."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    aliases, out = set(), []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "duffsym":
            out += [
                f"{path.name}:{node.lineno} {node.module}.{a.name}"
                for a in node.names
                if a.name.startswith("_") and not a.name.startswith("__")
            ]
        elif isinstance(node, ast.Import):
            aliases |= {a.asname for a in node.names if a.asname and a.name.startswith("duffsym.")}
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and node.attr.startswith("_")
            and not node.attr.startswith("__")
        ):
            out.append(f"{path.name}:{node.lineno} {node.value.id}.{node.attr}")
    return out


def package_imports(path: Path) -> set[str]:
    """The modules of ``duffsym.identify`` (short names) that ``path`` imports, anywhere in the file."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            if node.module == PREFIX:
                found |= {a.name for a in node.names if (path.parent / f"{a.name}.py").exists()}
            elif node.module.startswith(PREFIX + "."):
                found.add(node.module.split(".")[2])
        elif isinstance(node, ast.Import):
            found |= {a.name.split(".")[2] for a in node.names if a.name.startswith(PREFIX + ".")}
    return found - {path.stem}


def import_graph(root: Path = PACKAGE) -> dict[str, set[str]]:
    mods = modules(root)
    return {m: package_imports(p) & set(mods) for m, p in mods.items()}


def find_circle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph`` (``[a, b, ..., a]``), or None."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return path[path.index(nxt) :] + [nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        path.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (cycle := visit(start)):
            return cycle
    return None


def test_no_private_name_crosses_a_module_boundary_in_identify():
    found = [hit for p in modules().values() for hit in private_imports(p)]
    assert not found, (
        "private names imported from another module (make the name public and documented, or move "
        "it to where it is used):\n" + "\n".join(found)
    )


def test_identify_modules_import_each_other_without_a_circle():
    graph = import_graph()
    cycle = find_circle(graph)
    assert cycle is None, "import circle in duffsym.identify: " + " -> ".join(cycle)


def test_the_fit_pipeline_sits_on_top_of_its_pieces():
    """``collocation`` (the pipeline) uses ``nlp``, ``states`` and ``covariance``; none of them imports it, and
    the states' starts and the covariance need neither the NLP nor the pipeline."""
    graph = import_graph()
    assert {"nlp", "covariance"} <= graph["collocation"]
    assert "states" in graph["nlp"] and "states" in graph["initial"]
    for piece in ("nlp", "states", "covariance"):
        assert "collocation" not in graph[piece], f"{piece} imports the fit pipeline"
    assert not graph["states"] & {"nlp", "collocation", "covariance", "initial"}
    assert not graph["covariance"] & {"nlp", "collocation", "states"}


def test_the_checks_see_a_planted_private_import_and_circle(tmp_path):
    (tmp_path / "a.py").write_text("from duffsym.identify.b import _helper\n")
    (tmp_path / "b.py").write_text("import duffsym.identify.a as a\n\ndef f():\n    return a._thing\n")
    (tmp_path / "command.py").write_text("from duffsym._cli_common import _err\n")
    assert set(modules(tmp_path)) == {"a", "b"}
    assert private_imports(tmp_path / "a.py") == ["a.py:1 duffsym.identify.b._helper"]
    assert private_imports(tmp_path / "b.py") == ["b.py:4 a._thing"]
    assert import_graph(tmp_path) == {"a": {"b"}, "b": {"a"}}
    assert find_circle(import_graph(tmp_path)) == ["a", "b", "a"]
    assert find_circle({"a": {"b"}, "b": set()}) is None
