"""Models and expressions as JSON-safe data, read back without ``eval``.

An expression is written as SymPy's ``srepr`` (exact: ``Float('0.01', precision=53)``, symbols with their
assumptions) and read back by :func:`expr_from_text`, a small reader over Python's :mod:`ast` that
builds only SymPy objects: calls of SymPy classes (``Add``, ``Mul``, ``Symbol``, ``tanh``, ...) on
numbers, strings and other such calls, and SymPy's named constants (``pi``, ``E``, ``oo``). Anything
else (attribute access, an unknown name, a lambda, a huge power) is refused with a :class:`ModelError`:
a FIT.json is data, and reading it never runs code.

:func:`model_to_data` / :func:`model_from_data` write and read a :class:`SymbolicModel`'s equations
whole (states, inputs, parameter specifications, right-hand sides, output, structural values,
composition); values a model holds that are themselves models (the parts of a composed model) go
through the ``encode_model``/``decode_model`` hooks the caller gives (the effects layer writes them as a
base model plus effect objects: :mod:`duffsym.effects.spec`).
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable
from dataclasses import fields
from typing import Any

import sympy as sp

from duffsym.errors import ModelError
from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.symbols import ParamSpec

#: SymPy's named singletons as ``srepr`` prints them.
_CONSTANTS = {
    "pi": sp.pi,
    "E": sp.E,
    "I": sp.I,
    "oo": sp.oo,
    "zoo": sp.zoo,
    "nan": sp.nan,
    "true": sp.true,
    "false": sp.false,
}
#: Longest expression text read (characters) and deepest nesting.
MAX_TEXT = 2_000_000
MAX_DEPTH = 200
#: Largest integer literal and largest exponent of a power of two numbers (refused beyond: a hang, not data).
MAX_INT = 10**30
MAX_EXPONENT = 1000


#: The SymPy classes a stored expression may call: numbers, symbols, arithmetic, the elementary functions and
#: relations (a whitelist: a class that evaluates on construction, e.g. ``factorial`` of a huge integer, is not here).
_ALLOWED = (
    "Symbol",
    "Integer",
    "Rational",
    "Float",
    "Add",
    "Mul",
    "Pow",
    "Tuple",
    "Eq",
    "Equality",
    "Unequality",
    "StrictGreaterThan",
    "StrictLessThan",
    "GreaterThan",
    "LessThan",
    "And",
    "Or",
    "Not",
    "Piecewise",
    "ExprCondPair",
    "tanh",
    "sinh",
    "cosh",
    "exp",
    "log",
    "sin",
    "cos",
    "tan",
    "atan",
    "atan2",
    "asinh",
    "Abs",
    "sign",
    "Heaviside",
    "Max",
    "Min",
    "erf",
)
_CLASSES = {name: getattr(sp, name) for name in _ALLOWED if hasattr(sp, name)}
_CLASSES["ExprCondPair"] = sp.functions.elementary.piecewise.ExprCondPair


def expr_to_text(expr) -> str:
    """``expr`` (a SymPy object) as exact text: its ``srepr``."""
    return sp.srepr(expr)


def expr_from_text(text: str, *, source: str = "expression") -> sp.Basic:
    """The SymPy object written by :func:`expr_to_text`, read without ``eval`` (see the module docstring).

    Raises
    ------
    ModelError
        For text that is not such an expression (one line naming ``source``).
    """
    if not isinstance(text, str) or len(text) > MAX_TEXT:
        raise ModelError(f"{source}: expected the text of a SymPy expression (at most {MAX_TEXT} characters)")
    try:
        tree = ast.parse(text, mode="eval")
        return _build(tree.body, 0, source)
    except ModelError:
        raise
    except (SyntaxError, TypeError, ValueError, AttributeError, RecursionError, sp.SympifyError) as exc:
        raise ModelError(
            f"{source}: cannot read the expression {text[:60]!r} ({type(exc).__name__}: "
            f"{str(exc)[:80]}); the file is damaged or edited"
        ) from None


def _refuse(source: str, what: str) -> ModelError:
    return ModelError(f"{source}: {what} is not allowed in a stored expression; the file is damaged or edited")


def _build(node: ast.AST, depth: int, source: str):
    if depth > MAX_DEPTH:
        raise _refuse(source, f"nesting deeper than {MAX_DEPTH}")
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or v is None or isinstance(v, (str, float)):
            return v
        if isinstance(v, int):
            if abs(v) > MAX_INT:
                raise _refuse(source, "an integer this large")
            return v
        raise _refuse(source, f"the constant {v!r}")
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Constant):
        return -_build(node.operand, depth + 1, source)
    if isinstance(node, ast.Name):
        if node.id in _CONSTANTS:
            return _CONSTANTS[node.id]
        raise _refuse(source, f"the name {node.id!r}")
    if isinstance(node, (ast.Tuple, ast.List)):
        return tuple(_build(e, depth + 1, source) for e in node.elts)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _CLASSES:
        args = [_build(a, depth + 1, source) for a in node.args]
        built = [(k.arg, _build(k.value, depth + 1, source)) for k in node.keywords]
        if any(k is None for k, _ in built) or not all(isinstance(v, (bool, int, str)) for _, v in built):
            raise _refuse(source, "a keyword argument other than a flag or a precision")
        kwargs = {str(k): v for k, v in built}
        if (
            node.func.id == "Pow"
            and len(args) == 2
            and all(isinstance(a, sp.Number) for a in args)
            and abs(args[1]) > MAX_EXPONENT
        ):
            raise _refuse(source, "a power of two numbers with an exponent this large")
        return _CLASSES[node.func.id](*args, **kwargs)
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
        raise _refuse(source, f"the function {node.func.id!r}")
    raise _refuse(source, f"the construct {type(node).__name__}")


# ---------------------------------------------------------------------------------------------- values
def float_to_data(v: float):
    """A float as JSON: the number, or ``{"float": "inf"}`` (JSON has no inf/NaN)."""
    v = float(v)
    return v if math.isfinite(v) else {"float": repr(v)}


def float_from_data(v, source: str) -> float:
    if isinstance(v, dict) and set(v) == {"float"} and v["float"] in ("inf", "-inf", "nan"):
        return float(v["float"])
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ModelError(f"{source}: expected a number; got {str(v)[:40]}")
    return float(v)


def param_to_data(p: ParamSpec) -> dict:
    return {
        "name": p.name,
        "latex": p.latex,
        "default": float_to_data(p.default),
        "lower": float_to_data(p.lower),
        "upper": float_to_data(p.upper),
        "unit": p.unit,
        "scale": None if p.scale is None else float(p.scale),
        "description": p.description,
        "held": p.held,
    }


def param_from_data(d, source: str) -> ParamSpec:
    if not isinstance(d, dict) or not isinstance(d.get("name"), str):
        raise ModelError(f"{source}: a parameter must be an object with its name; got {str(d)[:60]}")
    where = f"{source}: parameter {d['name']}"
    return ParamSpec(
        name=d["name"],
        latex=str(d.get("latex", d["name"])),
        default=float_from_data(d.get("default"), where),
        lower=float_from_data(d.get("lower", {"float": "-inf"}), where),
        upper=float_from_data(d.get("upper", {"float": "inf"}), where),
        unit=str(d.get("unit", "1")),
        scale=None if d.get("scale") is None else float_from_data(d["scale"], where),
        description=str(d.get("description", "")),
        held=str(d.get("held", "")),
    )


def value_to_data(v, encode_model: Callable[[SymbolicModel], Any]):
    """A setting or composition value as JSON: numbers, strings and None as they are, tuples as lists,
    SymPy objects as ``{"sympy": srepr}``, models through ``encode_model`` as ``{"model": ...}``."""
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        return float_to_data(v)
    if isinstance(v, SymbolicModel):
        return {"model": encode_model(v)}
    if isinstance(v, ParamSpec):
        return {"param": param_to_data(v)}
    if isinstance(v, InputChannel):
        return {"channel": [v.signal, v.order]}
    if isinstance(v, sp.Basic):
        return {"sympy": expr_to_text(v)}
    if isinstance(v, (tuple, list)):
        return [value_to_data(e, encode_model) for e in v]
    if hasattr(v, "__float__"):  # numpy scalars
        return float_to_data(float(v))
    raise ModelError(f"cannot store a value of type {type(v).__name__} ({str(v)[:40]}) in a saved model")


def value_from_data(v, decode_model: Callable[[Any], SymbolicModel], source: str):
    """Inverse of :func:`value_to_data` (lists come back as tuples)."""
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, list):
        return tuple(value_from_data(e, decode_model, source) for e in v)
    if isinstance(v, dict) and len(v) == 1:
        ((tag, body),) = v.items()
        if tag == "sympy":
            return expr_from_text(body, source=source)
        if tag == "model":
            return decode_model(body)
        if tag == "param":
            return param_from_data(body, source)
        if tag == "channel" and isinstance(body, list) and len(body) == 2:
            return InputChannel(str(body[0]), int(body[1]))
        if tag == "float":
            return float_from_data(v, source)
    raise ModelError(f"{source}: cannot read the stored value {str(v)[:60]}; the file is damaged or edited")


# ---------------------------------------------------------------------------------------------- models
def model_to_data(model: SymbolicModel, encode_model: Callable[[SymbolicModel], Any]) -> dict:
    """Every field of ``model`` as JSON-safe data (its equations whole; see :func:`model_from_data`)."""
    text = expr_to_text

    def opt(e):
        return None if e is None else text(e)

    return {
        "name": model.name,
        "states": [text(s) for s in model.states],
        "inputs": [[c.signal, c.order] for c in model.inputs],
        "params": [param_to_data(p) for p in model.params],
        "rhs": [text(e) for e in model.rhs],
        "output": text(model.output),
        "output_name": model.output_name,
        "structural": [[k, value_to_data(v, encode_model)] for k, v in model.structural],
        "position": opt(model.position),
        "velocity": opt(model.velocity),
        "equation": opt(model.equation),
        "effects": list(model.effects),
        "description": model.description,
        "composition": [[k, value_to_data(v, encode_model)] for k, v in model.composition],
    }


def model_from_data(data, decode_model: Callable[[Any], SymbolicModel], *, source: str = "model") -> SymbolicModel:
    """The model written by :func:`model_to_data` (a :class:`ModelError` naming ``source`` if damaged)."""
    need = [f.name for f in fields(SymbolicModel) if f.init and f.name != "lineage"]
    if not isinstance(data, dict) or any(k not in data for k in need):
        missing = [k for k in need if not isinstance(data, dict) or k not in data]
        raise ModelError(f"{source}: a stored model needs the fields {missing}; the file is damaged or edited")
    src = f"{source} ({data['name']})"

    def expr(t):
        return expr_from_text(t, source=src)

    def opt(t):
        return None if t is None else expr(t)

    try:
        return SymbolicModel(
            name=str(data["name"]),
            states=tuple(expr(s) for s in data["states"]),
            inputs=tuple(InputChannel(str(s), int(o)) for s, o in data["inputs"]),
            params=tuple(param_from_data(p, src) for p in data["params"]),
            rhs=tuple(expr(e) for e in data["rhs"]),
            output=expr(data["output"]),
            output_name=str(data["output_name"]),
            structural=tuple((str(k), value_from_data(v, decode_model, src)) for k, v in data["structural"]),
            position=opt(data["position"]),
            velocity=opt(data["velocity"]),
            equation=opt(data["equation"]),
            effects=tuple(str(e) for e in data["effects"]),
            description=str(data["description"]),
            composition=tuple((str(k), value_from_data(v, decode_model, src)) for k, v in data["composition"]),
        )
    except (TypeError, ValueError) as exc:
        raise ModelError(
            f"{src}: a stored field has the wrong shape ({str(exc)[:80]}); the file is damaged or edited"
        ) from None
