"""Plotting (matplotlib is imported inside each function, so ``import duffsym`` stays fast).

- :func:`plot_loops` — d–y and d'–y hysteresis loops of the last full excitation cycle.
- :func:`save_figure` — write a figure with the Agg backend, creating folders, and close it.
- :func:`loop_metrics`, :func:`trajectory_loop_metrics` — numbers of one cycle (no plotting; :mod:`duffsym.plot.loops`).
"""

from duffsym.plot.loops import LoopMetrics, loop_metrics, plot_loops, save_figure, trajectory_loop_metrics

__all__ = ["plot_loops", "save_figure", "loop_metrics", "trajectory_loop_metrics", "LoopMetrics"]
