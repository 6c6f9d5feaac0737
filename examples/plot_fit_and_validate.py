"""
Fit a record, then predict another one
======================================

Fit the MR damper model to the shipped 2 Hz sine record (2 % noise) by direct collocation and
IPOPT, then run the fitted model freely on a band-limited random record it never saw (the paper's
Fig. 9). The in-sample and the held-out NRMSE are printed side by side.
"""
import matplotlib.pyplot as plt

import duffsym
from duffsym.identify import Problem, fit, validate
from _data import DATA

sine = duffsym.read_csv(DATA / "synthetic_sine.csv")
random = duffsym.read_csv(DATA / "synthetic_random.csv")
result = fit(Problem(duffsym.mr_damper(n=5), sine))
print(result.summary())

check = validate(result, random)
print(check.summary())

fig, ax = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
ax[0].plot(random.t, random.y, color="0.6", lw=1.5, label="measured")
ax[0].plot(random.t, check.y_sim, color="C0", lw=1, label="predicted (free run)")
ax[0].set_ylabel("force y")
ax[0].legend(loc="upper right")
ax[0].set_title(f"the sine fit on the random record: NRMSE {check.nrmse:.3f}")
ax[1].plot(random.t, random.y - check.y_sim, color="C3", lw=0.8)
ax[1].set_ylabel("residual")
ax[1].set_xlabel("time (s)")
fig.tight_layout()
