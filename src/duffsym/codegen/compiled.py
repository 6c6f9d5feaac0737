"""Compiled (numba) right-hand side, Jacobian, output and integrator generated from a model.

The generated source is written once to a cache directory (``$DUFFSYM_CACHE`` or
``~/.cache/duffsym``) under the model's hash, and numba caches its machine code beside it, so a
second process pays neither code generation nor compilation.
"""

from __future__ import annotations

import os
import stat
import sys
import tempfile
import threading
import warnings
from functools import lru_cache
from pathlib import Path
from types import ModuleType

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from duffsym._io import atomic_write
from duffsym.codegen._printing import check_numeric_structure, state_jacobian
from duffsym.model.core import SymbolicModel

_TEMPLATE = Path(__file__).with_name("_integrator_template.py")
GENERATOR_VERSION = "14"
#: LLVM fast-math flags of the RK4 substep loop: reassociation and FMA contraction shorten the
#: dependency chain of each stage (the simulator's speed: benchmarks/bench_simulate.py); no "nnan"/"ninf",
#: so the blow-up test on non-finite states stays valid.
_FASTMATH = '{"reassoc", "contract", "nsz", "arcp"}'
_lock = threading.Lock()


class _Printer(PythonCodePrinter):
    """Python printer whose integer powers stay integer (numba turns them into multiplications)."""

    def _print_Pow(self, expr, rational=False):
        if expr.exp.is_Integer and 1 < int(expr.exp) <= 8:
            return _power_by_squaring(self.parenthesize(expr.base, 100), int(expr.exp))
        return super()._print_Pow(expr, rational=rational)


def _power_by_squaring(base: str, e: int) -> str:
    """``base**e`` as parenthesised products of depth log2(e) (x**5 -> ((x*x)*(x*x))*x): a shorter
    dependency chain than x*x*x*x*x, and the repeated square is one value to the compiler."""
    if e == 1:
        return base
    half = _power_by_squaring(base, e // 2)
    sq = f"({half}*{half})"
    return f"({sq}*{base})" if e % 2 else sq


def cache_dir() -> Path:
    """Directory of generated code: ``$DUFFSYM_CACHE``, else ``~/.cache/duffsym``, else a per-user
    ``$TMPDIR/duffsym-cache-<uid>``.

    A directory is used only if the current user owns it and no one else can write to it (nor to
    its ``__pycache__``, where numba keeps its pickled machine code): code loaded from a folder
    another user can write to is code that user chose. A candidate that fails is skipped with a
    warning saying why; no probe file is written (a fixed-name probe raced between processes).
    """
    base = os.environ.get("DUFFSYM_CACHE")
    candidates = [Path(base).expanduser()] if base else []
    uid = os.getuid() if hasattr(os, "getuid") else None
    candidates += [
        Path.home() / ".cache" / "duffsym",
        Path(tempfile.gettempdir()) / (f"duffsym-cache-{uid}" if uid is not None else "duffsym-cache"),
    ]
    problems = []
    for c in candidates:
        why = _unsafe_reason(c)
        if why is None:
            return c
        problems.append(f"{c}: {why}")
        if base and c == candidates[0]:
            warnings.warn(
                f"DUFFSYM_CACHE={base} is not used for generated code ({why}); using a private cache instead",
                UserWarning,
                stacklevel=2,
            )
    raise OSError(
        "no safe cache directory for generated code (" + "; ".join(problems) + "); set DUFFSYM_CACHE "
        "to a folder you own that no one else can write to"
    )


def _unsafe_reason(folder: Path) -> str | None:
    """Why ``folder`` cannot hold generated code (None if it can), creating it private (0700) if missing."""
    try:
        folder.mkdir(parents=True, exist_ok=True, mode=0o700)
    except OSError as exc:
        return f"cannot create it ({exc.strerror or exc})"
    for d in (folder, folder / "__pycache__"):
        try:
            st = os.stat(d)
        except FileNotFoundError:
            continue  # no __pycache__ yet: numba creates it inside the checked folder
        except OSError as exc:
            return f"cannot inspect {d} ({exc.strerror or exc})"
        if not stat.S_ISDIR(st.st_mode):
            return f"{d} is not a folder"
        if hasattr(os, "getuid") and st.st_uid != os.getuid():
            return f"{d} belongs to another user (uid {st.st_uid})"
        if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
            return f"{d} can be written by other users (mode {stat.S_IMODE(st.st_mode):o})"
    if not os.access(folder, os.W_OK | os.X_OK):
        return "not writable"
    return None


def _assign_block(lhs: list[str], exprs: list[sp.Expr], printer: _Printer, indent: str = "    ") -> list[str]:
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("_t"))
    lines = [f"{indent}{sym} = {printer.doprint(val)}" for sym, val in replacements]
    lines += [f"{indent}{target} = {printer.doprint(val)}" for target, val in zip(lhs, reduced)]
    return lines


def _scalar_rk4(model: SymbolicModel, printer: _Printer) -> list[str]:
    """A scalar RHS ``_f`` (one argument per state, input and parameter, returning a tuple) and the
    RK4 substep loop ``_advance`` written with scalar locals: no small temporary arrays."""
    n, ni = model.n_states, model.n_inputs
    xs = [f"x{i}_" for i in range(n)]
    us = [f"u{j}_" for j in range(ni)]
    ps = [f"p{j}_" for j in range(model.n_params)]
    subs = dict(zip(model.states, map(sp.Symbol, xs)))
    subs.update(zip(model.input_symbols, map(sp.Symbol, us)))
    subs.update(zip(model.param_symbols, map(sp.Symbol, ps)))
    exprs = [e.xreplace(subs) for e in model.rhs]
    outs = [f"_r{i}" for i in range(n)]
    lines = [
        '@njit(cache=True, inline="always")',
        f"def _f({', '.join(xs + us + ps)}):",
        *_assign_block(outs, exprs, printer),
        f"    return ({', '.join(outs)},)",
        "",
        "",
        '@njit(cache=True, inline="always", fastmath=FASTMATH)',
        "def _advance(x, U, k, p, dt, m, hold, xo):",
        "    h = dt / m",
        *[f"    {v} = p[{j}]" for j, v in enumerate(ps)],
        *[f"    s{i} = x[{i}]" for i in range(n)],
        *[f"    a{j} = U[k, {j}]" for j in range(ni)],
        *[f"    g{j} = 0.0 if hold else (U[k + 1, {j}] - U[k, {j}]) / m" for j in range(ni)],
        "    for s in range(m):",
        *[f"        ua{j} = a{j} + s * g{j}" for j in range(ni)],
        *[f"        ub{j} = ua{j} + 0.5 * g{j}" for j in range(ni)],
        *[f"        uc{j} = ua{j} + g{j}" for j in range(ni)],
    ]
    P = ", ".join(ps)

    def call(state, u):
        return f"_f({', '.join(state + [f'{u}{j}' for j in range(ni)])}, {P})"

    def tup(prefix):
        return ", ".join(f"{prefix}{i}" for i in range(n)) + ("," if n == 1 else "")

    S = [f"s{i}" for i in range(n)]
    lines.append(f"        {tup('q1_')} = {call(S, 'ua')}")
    lines.append(f"        {tup('q2_')} = {call([f's{i} + 0.5 * h * q1_{i}' for i in range(n)], 'ub')}")
    lines.append(f"        {tup('q3_')} = {call([f's{i} + 0.5 * h * q2_{i}' for i in range(n)], 'ub')}")
    lines.append(f"        {tup('q4_')} = {call([f's{i} + h * q3_{i}' for i in range(n)], 'uc')}")
    for i in range(n):
        lines.append(f"        s{i} = s{i} + h / 6.0 * (q1_{i} + 2.0 * q2_{i} + 2.0 * q3_{i} + q4_{i})")
    lines += [f"    xo[{i}] = s{i}" for i in range(n)]
    return lines


def generate_source(model: SymbolicModel) -> str:
    """The Python/numba source of the model's compiled functions (rhs, jac, output, integrator)."""
    check_numeric_structure(model)
    printer = _Printer({"fully_qualified_modules": True, "standard": "python3"})
    unpack = [f"    {s} = x[{i}]" for i, s in enumerate(model.states)]
    unpack += [f"    {c.symbol} = u[{i}]" for i, c in enumerate(model.inputs)]
    unpack += [f"    {p.symbol} = p[{i}]" for i, p in enumerate(model.params)]
    n = model.n_states
    jac = state_jacobian(model)
    lines = [
        f"# generated by duffsym.codegen.compiled (v{GENERATOR_VERSION}) for model {model.name!r}",
        f"# effects: {list(model.effects)}; key {model.key}. Do not edit: regenerated from the SymPy model.",
        "import math",
        "import numpy as np",
        "from numba import njit, prange",
        "",
        f"N_STATES = {n}",
        f"N_INPUTS = {model.n_inputs}",
        f"N_PARAMS = {model.n_params}",
        f"FASTMATH = {_FASTMATH}",
        "",
        "",
        '@njit(cache=True, inline="always")',
        "def rhs(x, u, p, out):",
        *unpack,
        *_assign_block([f"out[{i}]" for i in range(n)], list(model.rhs), printer),
        "",
        "",
        *_scalar_rk4(model, printer),
        "",
        "",
        '@njit(cache=True, inline="always")',
        "def jac(x, u, p, out):",
        *unpack,
        *_assign_block([f"out[{i}, {j}]" for i in range(n) for j in range(n)], list(jac), printer),
        "",
        "",
        '@njit(cache=True, inline="always")',
        "def output(x, u, p):",
        *unpack,
        *_assign_block(["_y"], [model.output], printer),
        "    return _y",
        "",
        "",
        *_pointer_functions(model, unpack, jac, printer),
    ]
    return "\n".join(lines) + _TEMPLATE.read_text()


def _pointer_functions(model: SymbolicModel, unpack: list[str], jac, printer: _Printer) -> list[str]:
    """``rhs_ptr``, ``jac_ptr`` and ``output_ptr``: the model's functions again, compiled on import with the
    explicit signatures of :mod:`duffsym.codegen.generic`, whose one integrator calls them through pointers."""
    n = model.n_states
    return [
        "from duffsym.codegen.generic import SIG_JAC, SIG_OUT, SIG_RHS  # noqa: E402",
        "",
        "",
        "@njit(SIG_RHS, cache=True)",
        "def rhs_ptr(x, u, p, out):",
        *unpack,
        *_assign_block([f"out[{i}]" for i in range(n)], list(model.rhs), printer),
        "",
        "",
        "@njit(SIG_JAC, cache=True)",
        "def jac_ptr(x, u, p, out):",
        *unpack,
        *_assign_block([f"out[{i}, {j}]" for i in range(n) for j in range(n)], list(jac), printer),
        "",
        "",
        "@njit(SIG_OUT, cache=True)",
        "def output_ptr(x, u, p):",
        *unpack,
        *_assign_block(["_y"], [model.output], printer),
        "    return _y",
        "",
        "",
    ]


@lru_cache(maxsize=64)
def compiled_module(model: SymbolicModel) -> ModuleType:
    """Import (generating on first use) the compiled module of ``model``."""
    return load_generated(f"duffsym_gen_{model.key}_v{GENERATOR_VERSION}", generate_source(model))


def load_generated(key: str, source: str) -> ModuleType:
    """Write ``source`` to ``<cache>/<key>.py`` (unless it is there already) and import it as ``key``.

    The module is compiled from ``source`` itself, the text this process generated and checked:
    neither the file (which could change after the comparison) nor a bytecode file beside it
    (``__pycache__/*.pyc``, which Python's importer would trust) is ever executed. The file exists
    so that numba can key its on-disk machine-code cache to it.
    """
    with _lock:
        if key in sys.modules:
            return sys.modules[key]
        path = cache_dir() / f"{key}.py"
        remove_untrusted(path.parent, key)
        if not path.is_file() or path.is_symlink() or _read(path) != source:
            # atomic replace, so that concurrent processes never see a half-written file
            with atomic_write(path) as fh:
                fh.write(source)
        module = ModuleType(key)
        module.__file__ = str(path)
        code = compile(source, str(path), "exec", dont_inherit=True)
        sys.modules[key] = module
        try:
            exec(code, module.__dict__)
        except BaseException:
            sys.modules.pop(key, None)
            raise
    return module


def trusted_file(st: os.stat_result) -> bool:
    """Whether a file (its ``os.lstat``) may be loaded from the code cache: a regular file (not a link) of this user
    that no one else can write to."""
    foreign = hasattr(os, "getuid") and st.st_uid != os.getuid()
    return stat.S_ISREG(st.st_mode) and not foreign and not st.st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def remove_untrusted(folder: Path, key: str) -> list[Path]:
    """Remove the files of module ``key`` in the cache ``folder`` that this process may not trust: its
    source and numba's index and machine code (``__pycache__/<key>.*.nbi``/``.nbc``; numba unpickles the
    index, so a planted one would run code) when they are symbolic links, belong to another user or can
    be written by others. Numba then rebuilds them. Returns the paths removed; raises OSError (naming the
    file) if one cannot be removed."""
    removed = []
    for p in [folder / f"{key}.py", *sorted((folder / "__pycache__").glob(f"{key}.*"))]:
        try:
            st = os.lstat(p)
        except FileNotFoundError:
            continue
        if not trusted_file(st):
            try:
                p.unlink()
            except OSError as exc:
                raise OSError(
                    f"the code cache holds {p}, which is not safe to load (another user's, writable by "
                    f"others, or a link) and cannot be removed ({exc.strerror or exc}); delete it or set "
                    "DUFFSYM_CACHE to a private folder"
                ) from None
            removed.append(p)
    return removed


def _read(path: Path) -> str | None:
    try:
        return path.read_text()
    except (OSError, UnicodeDecodeError):
        return None
