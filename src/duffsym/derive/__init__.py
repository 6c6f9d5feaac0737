"""Derivations of the paper, computed from the symbolic model (nothing typed in).

- :func:`derive_normalization`, :func:`to_duffing_like`: Eq. 11 -> Eq. 12 by coefficient matching.
- :func:`lyapunov_analysis`: the Lyapunov functions of Eq. 6 and 8 and their derivatives (Eq. 7, 9).
- :func:`stability_conditions`, :func:`stability_certificate`: the conditions behind Eq. 6–10, for
  any parameter signs and parity of n, and their check for numeric parameters.
- :func:`energy_balance`, :func:`loop_area`, :func:`cycle_energy`, :func:`linear_loop_area`: energy
  dissipated per cycle and the d–y loop area.
- :func:`find_scaling_symmetry`, :func:`normalize_af`: the state-scaling symmetry and the fixing of A_f.
- :func:`derivation_report`: all of it in the paper's order, as text, LaTeX or JSON.
"""

from duffsym.derive._mechanics import split_terms
from duffsym.derive.energy import (
    CycleEnergy,
    EnergyBalance,
    LinearLoopArea,
    cycle_energy,
    energy_balance,
    linear_loop_area,
    linear_loop_area_value,
    loop_area,
)
from duffsym.derive.lyapunov import (
    DissipationTerm,
    LyapunovAnalysis,
    energy_lyapunov,
    lyapunov_analysis,
    state_based_lyapunov,
    time_derivative,
)
from duffsym.derive.normalize import Normalization, derive_normalization, duffing_like_parameter_map, to_duffing_like
from duffsym.derive.report import DerivationReport, ReportItem, derivation_report
from duffsym.derive.stability import (
    Condition,
    StabilityCertificate,
    StabilityConditions,
    stability_certificate,
    stability_conditions,
)
from duffsym.derive.symmetry import ScalingSymmetry, find_scaling_symmetry, normalize_af

__all__ = [
    "derive_normalization",
    "to_duffing_like",
    "duffing_like_parameter_map",
    "Normalization",
    "lyapunov_analysis",
    "state_based_lyapunov",
    "energy_lyapunov",
    "time_derivative",
    "LyapunovAnalysis",
    "DissipationTerm",
    "stability_conditions",
    "stability_certificate",
    "StabilityConditions",
    "StabilityCertificate",
    "Condition",
    "energy_balance",
    "loop_area",
    "cycle_energy",
    "linear_loop_area",
    "linear_loop_area_value",
    "EnergyBalance",
    "CycleEnergy",
    "LinearLoopArea",
    "find_scaling_symmetry",
    "normalize_af",
    "ScalingSymmetry",
    "derivation_report",
    "DerivationReport",
    "ReportItem",
    "split_terms",
]
