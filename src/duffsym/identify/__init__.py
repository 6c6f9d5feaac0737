"""Identification: a :class:`Problem` (model, records, free/fixed parameters, bounds, mask) is fitted by
:func:`fit` (direct collocation + IPOPT; its settings are a :class:`FitOptions`) into an
:class:`IdentificationResult`.

The modules: ``collocation`` (the fit's pipeline), ``nlp`` (the transcribed problem, its structured
derivatives and the IPOPT runs), ``states`` (the data-based start of the state trajectories:
:func:`initial_states`), ``covariance`` (the Laplace standard errors), ``initial`` (parameter starts),
``problem``, ``quality``, ``result``, ``validation``, ``extended``, ``structure``.

:func:`initial_guess` implements the paper's tuning procedure (Fig. 4) as a small grid search;
:func:`auto_mask` finds the deadzone of a joint backlash (Fig. 8) in the data; :func:`validate`
simulates a fit on another record (Fig. 9); :func:`extended_start` and :func:`fit_with_effects`
fit a model extended by effects after a base fit.
"""

from duffsym.identify.collocation import FitOptions, fit
from duffsym.identify.extended import extended_start, fit_with_effects
from duffsym.identify.initial import TUNING_STEPS, auto_mask, initial_guess
from duffsym.identify.nlp import collocation_coefficients
from duffsym.identify.problem import Problem
from duffsym.identify.result import IdentificationResult, load_result, nrmse
from duffsym.identify.states import driven_states, initial_states
from duffsym.identify.validation import ValidationResult, model_from_result, validate

__all__ = [
    "Problem",
    "fit",
    "FitOptions",
    "IdentificationResult",
    "load_result",
    "initial_guess",
    "auto_mask",
    "initial_states",
    "driven_states",
    "collocation_coefficients",
    "TUNING_STEPS",
    "nrmse",
    "validate",
    "ValidationResult",
    "model_from_result",
    "extended_start",
    "fit_with_effects",
]
