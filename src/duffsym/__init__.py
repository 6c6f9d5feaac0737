"""duffsym: the continuous hysteresis model of Tu, Lin & Cheng, from one symbolic model.

One SymPy model is the single source of truth: derivations (state-space form, Lyapunov
functions, invariant set, scaling symmetry), generated code (NumPy, CasADi, compiled numba) and
simulation all come from it. Subpackages hold the rest: ``duffsym.model``, ``duffsym.derive``,
``duffsym.codegen``, ``duffsym.simulate``, ``duffsym.excitation``.
"""
from duffsym.errors import DataError, DuffsymError, ModelError, SimulationError
from duffsym.excitation import Sine
from duffsym.model import SymbolicModel, duffing, duffing_like, get_model, mr_damper, state_space
from duffsym.simulate import Trajectory, simulate

__version__ = "0.1.0"

__all__ = [
    "SymbolicModel", "mr_damper", "duffing_like", "duffing", "get_model", "state_space",
    "simulate", "Trajectory", "Sine",
    "DuffsymError", "ModelError", "DataError", "SimulationError",
]
