"""Where a model fails against measurements, which catalogued effect is missing, and the ladder
that adds effects while the evidence supports them.

- :func:`analyse_residuals` — the structure of a free-run residual (no refit);
- :func:`diagnose` — refit with each candidate effect, judge on held-out data, give a verdict;
- :func:`ladder` — add the supported effects one by one and report the error at each step;
- :func:`discover_campaign` — what one parameter set misses across several records, found outside the catalogue.
"""

from duffsym.diagnose.campaign import CampaignDiscovery, discover_campaign
from duffsym.diagnose.ladder import Ladder, Step, ladder
from duffsym.diagnose.options import DiagnoseOptions, LadderOptions
from duffsym.diagnose.parts import BaseCheck, CandidateRun, SindyCheck, Split
from duffsym.diagnose.residuals import ResidualAnalysis, analyse_residuals, noise_level
from duffsym.diagnose.search import Candidate, Diagnosis, diagnose, split_record

__all__ = [
    "analyse_residuals",
    "noise_level",
    "ResidualAnalysis",
    "diagnose",
    "Diagnosis",
    "Candidate",
    "split_record",
    "ladder",
    "Ladder",
    "Step",
    "DiagnoseOptions",
    "LadderOptions",
    "discover_campaign",
    "CampaignDiscovery",
    "BaseCheck",
    "Split",
    "SindyCheck",
    "CandidateRun",
]
