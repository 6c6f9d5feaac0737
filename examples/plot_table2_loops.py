"""
The paper's Table 2 dampers at 2 Hz
===================================

Simulate the MR damper model (Eq. 12, n = 5) with the identified parameters of Table 2 for three
of its voltages, and draw the d–y and d'–y loops of the last cycle. The integrator picks its
substeps from the local stiffness and reports what it did in ``summary()``.
"""
import numpy as np

import duffsym
from duffsym.model.presets import table2_params
from duffsym.plot import plot_loops

model = duffsym.mr_damper(n=5)
t = np.arange(0, 3, 0.005)  # the paper's sampling, three periods
excitation = duffsym.Sine(amplitude=1.0, frequency=2.0)
trajectories = [duffsym.simulate(model, table2_params(v), t, excitation) for v in (0.0, 0.4, 0.8)]
print(trajectories[1].summary())

fig = plot_loops(trajectories, period=0.5, labels=["0 V", "0.4 V", "0.8 V"],
                 title="Table 2 rows at 2 Hz, last period")
