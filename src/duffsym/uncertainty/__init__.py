"""Parameter uncertainty: emcee posterior sampling of a fit, diagnostics and identifiability.

- :func:`sample` (a fit + its records -> :class:`Chains`), :func:`load_chains`;
- :func:`posterior_predictive` (bands of the output at posterior draws);
- :func:`identifiability_report` (scaling symmetry + Fisher information + posterior correlations);
- :mod:`duffsym.uncertainty.plots`: corner plot, predictive bands.
"""

from duffsym.uncertainty.options import SampleOptions
from duffsym.uncertainty.posterior import LogPosterior, Prior, make_prior
from duffsym.uncertainty.sampler import Chains, ChainTooShort, autocorr_time, load_chains, load_partial_chain, sample

__all__ = [
    "sample",
    "SampleOptions",
    "Chains",
    "load_chains",
    "load_partial_chain",
    "ChainTooShort",
    "LogPosterior",
    "Prior",
    "make_prior",
    "autocorr_time",
    "posterior_predictive",
    "identifiability_report",
    "fisher_information",
]


def __getattr__(name):  # the heavier parts are imported on use
    if name == "posterior_predictive":
        from duffsym.uncertainty.predictive import posterior_predictive

        return posterior_predictive
    if name in ("identifiability_report", "fisher_information"):
        from duffsym.uncertainty import identifiability

        return getattr(identifiability, name)
    raise AttributeError(name)
