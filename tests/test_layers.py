"""The import direction of ``src/duffsym``: lower layers never import higher ones, and no package imports
another in a circle.

A small check over every ``import``/``from ... import`` in the source (function-level imports included,
found with :mod:`ast`), so a lazy import inside a function cannot hide a circle. Each module belongs to a
layer: its top-level package (``duffsym.identify.collocation`` -> ``identify``); the command line is the
package ``duffsym.cli`` (the top layer ``cli``), and only it: a module named ``command`` elsewhere belongs
to its own package's layer. ``duffsym/__init__.py`` is the public facade above everything (its lazy
``fit``/``read_csv`` re-exports) and ``from duffsym import __version__`` is not a dependency.
"""

from __future__ import annotations

import ast
from pathlib import Path

import duffsym

SRC = Path(duffsym.__file__).parent

#: Bottom to top. A module may import only from its own layer or the layers listed before it.
LAYERS = (
    "errors",
    "status",
    "options",
    "_typing",
    "_checks",
    "_json",
    "_io",
    "_progress",
    "model",
    "codegen",
    "excitation",
    "simulate",
    "plot",
    "data",
    "effects",
    "derive",
    "identify",
    "sindy",
    "uncertainty",
    "diagnose",
    "benchmark",  # public benchmarks scored by their own protocol (identify, diagnose below)
    "control",  # the inverse for control (a fitted model's command for a desired force)
    "engine",
    "campaign",  # run commands over many records (they drive everything below)
    "cli",
)
RANK = {name: i for i, name in enumerate(LAYERS)}


def _is_cli(module: str) -> bool:
    return module == "duffsym.cli" or module.startswith("duffsym.cli.")


def layer(module: str) -> str | None:
    """The layer of a ``duffsym`` module name; None for the package facade itself."""
    if _is_cli(module):
        return "cli"
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else None


def _module_name(path: Path, root: Path = SRC) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


def imports_of(path: Path) -> list[tuple[str, int]]:
    """Every ``duffsym`` module imported by the file, with the line."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if (
            isinstance(node, ast.ImportFrom)
            and node.level == 0
            and node.module
            and node.module.split(".")[0] == "duffsym"
        ):
            if node.module == "duffsym":  # from duffsym import X: X is a submodule or a facade name
                out += [
                    (f"duffsym.{a.name}", node.lineno)
                    for a in node.names
                    if (SRC / a.name).exists() or (SRC / f"{a.name}.py").exists()
                ]
            else:
                out.append((node.module, node.lineno))
        elif isinstance(node, ast.Import):
            out += [
                (a.name, node.lineno) for a in node.names if a.name.split(".")[0] == "duffsym" and a.name != "duffsym"
            ]
    return out


def edges() -> list[tuple[str, str, str, int]]:
    """(source layer, imported layer, source module, line) for every import between layers."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        module = _module_name(path)
        src = layer(module)
        if src is None:
            continue
        for target, line in imports_of(path):
            dst = layer(target)
            if dst is not None and dst != src:
                found.append((src, dst, module, line))
    return found


def test_every_module_has_a_layer():
    unknown = sorted({(s if s not in RANK else d) for s, d, _, _ in edges() if s not in RANK or d not in RANK})
    assert not unknown, f"layers not in LAYERS (add them where they belong): {unknown}"


def test_imports_point_down_the_layers():
    upward = [f"{m}:{line} ({s}) imports {d}" for s, d, m, line in edges() if RANK[d] > RANK[s]]
    assert not upward, "imports against the layer order:\n" + "\n".join(upward)


def test_no_package_imports_the_command_line():
    """``duffsym.cli`` is the top: parse, call the library, print. Nothing else imports it (the batch gets its
    per-record task from the command line as an argument, :func:`duffsym.campaign.run_batch`)."""
    bad = [f"{m}:{line} imports {d}" for s, d, m, line in edges() if d == "cli" and s != "cli"]
    assert not bad, bad


def private_names_imported(path: Path) -> list[tuple[str, str, int]]:
    """``(module, name, line)`` for every underscore name taken from a ``duffsym`` module by ``from ... import``."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "duffsym":
            out += [
                (node.module, a.name, node.lineno)
                for a in node.names
                if a.name.startswith("_") and not a.name.startswith("__")
            ]
    return out


def test_the_command_line_takes_no_private_name_from_another_package():
    """The command modules use the library's public names only (``cli.common`` is their own shared module)."""
    bad = []
    for path in sorted((SRC / "cli").rglob("*.py")):
        module = _module_name(path)
        bad += [
            f"{module}:{line} imports {name} from {src}"
            for src, name, line in private_names_imported(path)
            if layer(src) != "cli"
        ]
    assert not bad, bad


def test_effects_never_import_the_fitting_code():
    """An effect is a model extension with its guesses; fitting it lives in ``duffsym.identify.extended``."""
    bad = [
        f"{m}:{line} imports {d}"
        for s, d, m, line in edges()
        if s == "effects" and d in ("identify", "diagnose", "uncertainty", "sindy", "simulate", "codegen")
    ]
    assert not bad, bad


def find_circle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle of ``graph`` (node -> the nodes it imports) as a closed path, or None."""
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


def test_no_import_circle_between_packages():
    graph: dict[str, set[str]] = {}
    for s, d, _, _ in edges():
        graph.setdefault(s, set()).add(d)
    cycle = find_circle(graph)
    assert cycle is None, "import circle: " + " -> ".join(cycle)


def module_graph(root: Path = SRC) -> dict[str, set[str]]:
    """Module -> the ``duffsym`` modules it imports (function-level imports included). A package's
    ``__init__`` is its facade (it re-exports its modules), so imports *of* a package name are followed to
    the facade, but the facade's own imports are not: a module importing ``from duffsym.effects import X``
    depends on the facade, not on every module behind it."""
    modules, packages = {}, set()
    for path in sorted(root.rglob("*.py")):
        name = _module_name(path, root)
        modules[name] = path
        if path.name == "__init__.py":
            packages.add(name)

    def known(target: str) -> str:
        while target not in modules and "." in target:
            target = target.rsplit(".", 1)[0]
        return target

    graph = {}
    for name, path in modules.items():
        if name not in packages:
            graph[name] = {known(t) for t, _ in imports_of(path)} - {name} - packages
    return graph


def test_no_import_circle_between_modules():
    """Inside a package too: two modules that import each other (even in a function) are one module in two
    files, and the order they load in decides what works."""
    cycle = find_circle(module_graph())
    assert cycle is None, "import circle: " + " -> ".join(cycle)


#: duffsym's own private helper modules (``duffsym._io`` ...): private to the distribution, shared by its
#: packages by design (atomic writes, JSON, checks); an underscore *name* or a private module of another
#: package is still refused
SHARED_INTERNALS = ("duffsym._io", "duffsym._json", "duffsym._checks", "duffsym._typing", "duffsym._progress")


def private_imports_across_packages(root: Path = SRC) -> list[str]:
    """Every underscore name, or private module, that a module takes from another package."""
    bad = []
    for path in sorted(root.rglob("*.py")):
        module = _module_name(path, root)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.ImportFrom) and node.level == 0 and node.module):
                continue
            if node.module.split(".")[0] != "duffsym" or layer(node.module) == layer(module):
                continue
            names = [a.name for a in node.names if a.name.startswith("_") and not a.name.startswith("__")]
            private_module = any(p.startswith("_") for p in node.module.split(".")[1:])
            if names or (private_module and node.module not in SHARED_INTERNALS):
                bad.append(f"{module}:{node.lineno} imports {names or node.module} from {node.module}")
    return bad


def test_no_private_name_crosses_a_package():
    bad = private_imports_across_packages()
    assert not bad, "private names used across packages (make them public or move them):\n" + "\n".join(bad)


def test_the_checks_see_a_planted_circle_and_a_planted_private_import(tmp_path):
    pkg = tmp_path / "duffsym"
    (pkg / "diagnose").mkdir(parents=True)
    (pkg / "identify").mkdir()
    (pkg / "diagnose" / "a.py").write_text("from duffsym.diagnose.b import g\n")
    (pkg / "diagnose" / "b.py").write_text("def g():\n    from duffsym.diagnose.a import f\n")
    (pkg / "identify" / "c.py").write_text("from duffsym.diagnose.a import _hidden\n")
    assert find_circle(module_graph(pkg)) in (
        ["duffsym.diagnose.a", "duffsym.diagnose.b", "duffsym.diagnose.a"],
        ["duffsym.diagnose.b", "duffsym.diagnose.a", "duffsym.diagnose.b"],
    )
    assert private_imports_across_packages(pkg) == ["duffsym.identify.c:1 imports ['_hidden'] from duffsym.diagnose.a"]


def test_the_check_sees_a_planted_upward_import(tmp_path):
    """The checker itself: an effects module importing the fitting code is reported."""
    planted = tmp_path / "duffsym" / "effects"
    planted.mkdir(parents=True)
    (planted / "bad.py").write_text("def f():\n    from duffsym.identify import fit\n")
    found = imports_of(planted / "bad.py")
    assert found == [("duffsym.identify", 2)]
    assert RANK[layer(found[0][0])] > RANK[layer("duffsym.effects.bad")]
    assert layer("duffsym.cli.fit") == "cli" and layer("duffsym.cli") == "cli"
    assert layer("duffsym.identify.command") == "identify" and layer("duffsym.clinic") == "clinic"
