"""duffsym: the continuous hysteresis model of Tu, Lin & Cheng, from one symbolic model.

One SymPy model is the single source of truth: derivations (state-space form, Lyapunov
functions, invariant set, scaling symmetry), generated code (NumPy, CasADi, compiled numba) and
simulation all come from it; identification (CasADi collocation + IPOPT) fits it to measurements.
Subpackages hold the rest: ``duffsym.model``, ``duffsym.derive``, ``duffsym.codegen``,
``duffsym.simulate``, ``duffsym.excitation``, ``duffsym.effects``, ``duffsym.data``,
``duffsym.identify``, ``duffsym.plot`` (hysteresis loops: :mod:`duffsym.plot.loops`).
"""

import sys
import types

from duffsym.errors import DataError, DuffsymError, ModelError, SimulationError, show_notes

#: The facade's names and where they live: imported on first use, so that ``import duffsym`` (and with
#: it every ``duffsym`` command, ``duffsym --help`` included) does not pay for SymPy, NumPy or CasADi
#: until they are needed (``python -X importtime`` shows what an import costs; tests/test_startup.py checks that
#: ``--help`` and ``--version`` import none of them).
_LAZY = {
    "Sine": "duffsym.excitation",
    "SymbolicModel": "duffsym.model",
    "duffing": "duffsym.model",
    "duffing_like": "duffsym.model",
    "get_model": "duffsym.model",
    "mr_damper": "duffsym.model",
    "state_space": "duffsym.model",
    "Trajectory": "duffsym.simulate",
    "Problem": "duffsym.identify",
    "fit": "duffsym.identify",
    "batch": "duffsym.cli.batch",
    "read_csv": "duffsym.data",
    "compare": "duffsym.diagnose.compare",
}


def __getattr__(name):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'duffsym' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


class _Package(types.ModuleType):
    """``duffsym.simulate`` is both a submodule and the facade's function: the attribute stays the function
    (importing the submodule would otherwise replace it, as Python sets a package's attribute to each
    submodule it loads)."""

    @property
    def simulate(self):
        from duffsym.simulate import simulate

        return simulate

    @simulate.setter
    def simulate(self, value):  # the import system setting the submodule: the function stays
        pass


sys.modules[__name__].__class__ = _Package

__version__ = "0.2.0"  # the one place the version lives (pyproject.toml reads it; CHANGELOG.md says what changed)

# duffsym's own warnings (expected numerical conditions) print as one line, "note: ...", from the API too;
# other packages' warnings keep Python's form (duffsym.errors.show_notes)
show_notes()

__all__ = [
    "SymbolicModel",
    "mr_damper",
    "duffing_like",
    "duffing",
    "get_model",
    "state_space",
    "simulate",
    "Trajectory",
    "Sine",
    "read_csv",
    "Problem",
    "fit",
    "batch",
    "compare",
    "DuffsymError",
    "ModelError",
    "DataError",
    "SimulationError",
]
