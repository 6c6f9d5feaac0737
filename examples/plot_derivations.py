"""
The derivations, from the symbolic model
========================================

Every derivation of the paper is computed from the one SymPy model: here the Lyapunov derivative of
the MR damper model and the stability certificate of one Table 2 parameter set. ``duffsym derive
--latex`` prints the same report as LaTeX (the Theory pages are made from it).
"""
import duffsym
from duffsym.derive import derivation_report, stability_certificate
from duffsym.model.presets import table2_params

model = duffsym.mr_damper(n=5)
report = derivation_report(model)
print([item.key for item in report.items])
print(report.item("lyapunov_derivative").text)
print(stability_certificate(model, table2_params(0.4)).summary())
