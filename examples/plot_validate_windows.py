"""
Judge a prediction: measured against predicted, a zoom, and loops of windows
============================================================================

``duffsym validate FIT.json RECORD --plot FILE`` draws this figure: the fit of the shipped sine record
runs freely on the shipped band-limited random record. The top panel shows the whole record with the
zoom shaded, the middle one the stretch with the largest error, and the bottom row the loops of two
stretches. A random record has no repeating cycle, so the loops are *windows* (one typical crossing
interval long; they do not close) and the figure says so; on a sine test they are whole cycles
(:func:`duffsym.plot.windows.loop_windows` decides).
"""
import duffsym
from duffsym.identify import Problem, fit, validate
from duffsym.plot.prediction import plot_prediction
from duffsym.plot.windows import loop_windows
from _data import DATA

sine = duffsym.read_csv(DATA / "synthetic_sine.csv")
random = duffsym.read_csv(DATA / "synthetic_random.csv")
check = validate(fit(Problem(duffsym.mr_damper(n=5), sine)), random)
print(check.summary())
print("sine record:", loop_windows(sine.d).reason, "| random record:", loop_windows(random.d).reason)

fig = plot_prediction(random.t, random.d, random.velocity(), random.y, check.y_sim, units=random.units,
                      title="the sine fit predicting synthetic_random.csv")
