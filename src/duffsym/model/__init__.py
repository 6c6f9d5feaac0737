"""Symbolic models: the single source of truth (``SymbolicModel``) and the paper's models."""

from duffsym.model.core import InputChannel, SymbolicModel
from duffsym.model.library import MODELS, duffing, duffing_like, from_second_order, get_model, mr_damper
from duffsym.model.statespace import StateSpace, state_space
from duffsym.model.symbols import ParamSpec

__all__ = [
    "InputChannel",
    "ParamSpec",
    "SymbolicModel",
    "StateSpace",
    "state_space",
    "from_second_order",
    "duffing",
    "duffing_like",
    "mr_damper",
    "get_model",
    "MODELS",
]
