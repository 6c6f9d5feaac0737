"""Plotting (matplotlib is imported inside each function, so ``import duffsym`` stays fast).

- :func:`plot_loops` — d–y and d'–y hysteresis loops of the last full excitation cycle.
- :func:`save_figure` — write a figure with the Agg backend, creating folders, and close it.
"""
from duffsym.plot.loops import plot_loops, save_figure

__all__ = ["plot_loops", "save_figure"]
