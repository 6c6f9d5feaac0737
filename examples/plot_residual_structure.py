"""
Where a fit fails: the residual of a record with a hidden effect
================================================================

``synthetic_hidden.csv`` hides a seal friction and a load-cell offset in the damper. The plain
model is fitted, and the structure of its free-run residual is analysed without refitting: its
mean (the offset) and its jumps at the velocity reversals (the friction) show what is missing.
``duffsym diagnose`` and ``duffsym ladder`` go on from here (see the guide "Find the missing effect").
"""
import matplotlib.pyplot as plt

import duffsym
from duffsym.diagnose import analyse_residuals
from duffsym.identify import Problem, fit, validate
from _data import DATA

record = duffsym.read_csv(DATA / "synthetic_hidden.csv")
result = fit(Problem(duffsym.mr_damper(n=5), record))
free_run = validate(result, record).y_sim
analysis = analyse_residuals(record, free_run)
print(f"free-run NRMSE {analysis.nrmse:.4f}; residual RMS {analysis.excess:.1f} x the noise level; "
      f"mean residual {analysis.mean:.3f} ({analysis.mean_z:.0f} standard errors)")

fig, ax = plt.subplots(1, 2, figsize=(9, 3.6))
ax[0].plot(record.d_dot, record.y - free_run, ".", ms=2, color="C3")
ax[0].axhline(0, color="0.5", lw=0.8)
ax[0].set_xlabel("velocity d'")
ax[0].set_ylabel("residual y - ŷ")
ax[0].set_title("residual against velocity")
ax[1].plot(record.t, record.y, color="0.6", lw=1.5, label="measured")
ax[1].plot(record.t, free_run, color="C0", lw=1, label="plain model")
ax[1].set_xlabel("time (s)")
ax[1].legend(loc="upper right")
ax[1].set_title("measured and free run")
fig.tight_layout()
