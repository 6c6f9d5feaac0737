"""duffsym: the continuous hysteresis model of Tu, Lin & Cheng, from one symbolic model.

One SymPy model is the single source of truth: derivations (state-space form, Lyapunov
functions, invariant set, scaling symmetry), generated code (NumPy, CasADi, compiled numba) and
simulation all come from it; identification (CasADi collocation + IPOPT) fits it to measurements.
Subpackages hold the rest: ``duffsym.model``, ``duffsym.derive``, ``duffsym.codegen``,
``duffsym.simulate``, ``duffsym.excitation``, ``duffsym.effects``, ``duffsym.data``,
``duffsym.identify``, ``duffsym.loops``, ``duffsym.plot``.
"""
from duffsym.errors import DataError, DuffsymError, ModelError, SimulationError
from duffsym.excitation import Sine
from duffsym.model import SymbolicModel, duffing, duffing_like, get_model, mr_damper, state_space
from duffsym.simulate import Trajectory, simulate


def __getattr__(name):
    # identification pulls in casadi: import it only when asked for, so `import duffsym` stays fast
    if name in ("Problem", "fit"):
        from duffsym import identify

        return getattr(identify, name)
    if name == "batch":  # many records on local processes or a Dask cluster (duffsym.campaign)
        from duffsym.campaign.command import batch

        return batch
    if name == "compare":  # several models on the same records, held-out scores (duffsym.diagnose.compare)
        from duffsym.diagnose.compare import compare

        return compare
    if name == "read_csv":
        from duffsym.data import read_csv

        return read_csv
    raise AttributeError(f"module 'duffsym' has no attribute {name!r}")


__version__ = "0.1.0"

__all__ = [
    "SymbolicModel", "mr_damper", "duffing_like", "duffing", "get_model", "state_space",
    "simulate", "Trajectory", "Sine", "read_csv", "Problem", "fit", "batch", "compare",
    "DuffsymError", "ModelError", "DataError", "SimulationError",
]
