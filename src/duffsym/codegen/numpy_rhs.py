"""NumPy functions generated from a model with ``lambdify`` (vectorised, for analysis and checks)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import sympy as sp

from duffsym.codegen._printing import check_numeric_structure, param_jacobian, state_jacobian
from duffsym.model.core import SymbolicModel


@dataclass(frozen=True)
class NumpyModel:
    """Vectorised right-hand side, output and Jacobians.

    Every function takes ``(x, u, p)`` with the last axis ordered as ``model.states``,
    ``model.inputs`` and ``model.params``; leading axes broadcast.
    """

    model: SymbolicModel
    _rhs: Callable
    _out: Callable
    _jx: Callable
    _jp: Callable

    @staticmethod
    def _split(x, u, p):
        x, u, p = (np.asarray(a, dtype=float) for a in (x, u, p))
        return [*np.moveaxis(x, -1, 0), *np.moveaxis(u, -1, 0), *np.moveaxis(p, -1, 0)]

    def _stack(self, values, shape):
        return np.stack([np.broadcast_to(np.asarray(v, dtype=float), shape) for v in values], axis=-1)

    def _shape(self, x, u, p):
        return np.broadcast_shapes(np.shape(x)[:-1], np.shape(u)[:-1], np.shape(p)[:-1])

    def rhs(self, x, u, p) -> np.ndarray:
        """State derivative, shape ``(..., n_states)``."""
        return self._stack(self._rhs(*self._split(x, u, p)), self._shape(x, u, p))

    def output(self, x, u, p) -> np.ndarray:
        """Output, shape ``(...)``."""
        return np.broadcast_to(np.asarray(self._out(*self._split(x, u, p)), dtype=float), self._shape(x, u, p))

    def jac_states(self, x, u, p) -> np.ndarray:
        """:math:`\\partial f/\\partial x`, shape ``(..., n_states, n_states)``."""
        shape = self._shape(x, u, p)
        rows = self._jx(*self._split(x, u, p))
        return np.stack([self._stack(r, shape) for r in rows], axis=-2)

    def jac_params(self, x, u, p) -> np.ndarray:
        """:math:`\\partial f/\\partial \\theta`, shape ``(..., n_states, n_params)``."""
        shape = self._shape(x, u, p)
        rows = self._jp(*self._split(x, u, p))
        return np.stack([self._stack(r, shape) for r in rows], axis=-2)


@lru_cache(maxsize=64)
def numpy_model(model: SymbolicModel) -> NumpyModel:
    """Generate the NumPy functions of ``model`` (cached per model)."""
    check_numeric_structure(model)
    args = [*model.states, *model.input_symbols, *model.param_symbols]
    jx = state_jacobian(model)
    jp = param_jacobian(model)
    return NumpyModel(
        model=model,
        _rhs=sp.lambdify(args, list(model.rhs), modules="numpy", cse=True),
        _out=sp.lambdify(args, model.output, modules="numpy"),
        _jx=sp.lambdify(args, jx.tolist(), modules="numpy", cse=True),
        _jp=sp.lambdify(args, jp.tolist(), modules="numpy", cse=True),
    )


@dataclass(frozen=True)
class ScalarModel:
    """Right-hand side and state Jacobian for one point, with little call overhead.

    ``rhs(x, u, p)`` returns ``(n_states,)`` and ``jac_states(x, u, p)`` ``(n_states, n_states)``
    for 1-D ``x, u, p``; used by the Radau reference, which calls them thousands of times.
    """

    model: SymbolicModel
    _rhs: Callable
    _jx: Callable

    def rhs(self, x, u, p) -> np.ndarray:
        return np.array(self._rhs(*x, *u, *p), dtype=float)

    def jac_states(self, x, u, p) -> np.ndarray:
        return np.array(self._jx(*x, *u, *p), dtype=float)


@lru_cache(maxsize=64)
def scalar_model(model: SymbolicModel) -> ScalarModel:
    """Generate the one-point functions of ``model`` (math module first, NumPy for the rest)."""
    check_numeric_structure(model)
    args = [*model.states, *model.input_symbols, *model.param_symbols]
    modules = ["math", "numpy"]
    return ScalarModel(
        model=model,
        _rhs=sp.lambdify(args, list(model.rhs), modules=modules, cse=True),
        _jx=sp.lambdify(args, state_jacobian(model).tolist(), modules=modules, cse=True),
    )
