"""SINDy cross-check of the recovered nonlinear terms (pysindy).

:func:`crosscheck` regresses the velocity equation sparsely on a candidate library generated
from the model itself, the effects catalogue and generic terms, and says which terms the data
support, how they compare with a fit, and when the data cannot decide. The diagnosis reads
:func:`sindy_evidence`.
"""

from duffsym.derive import split_terms
from duffsym.sindy.check import CrossCheckOptions, SindyCrossCheck, Thresholds, crosscheck, sindy_evidence
from duffsym.sindy.library import CandidateLibrary, Term, candidate_library
from duffsym.sindy.states import ReconstructedStates, output_gain, output_split, reconstruct_states

__all__ = [
    "crosscheck",
    "sindy_evidence",
    "CrossCheckOptions",
    "SindyCrossCheck",
    "Thresholds",
    "candidate_library",
    "CandidateLibrary",
    "Term",
    "split_terms",
    "reconstruct_states",
    "ReconstructedStates",
    "output_gain",
    "output_split",
]
