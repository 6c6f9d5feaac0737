"""Public benchmarks scored by their own protocol (``duffsym benchmark silverbox|bouc-wen``).

- :func:`run_bouc_wen`: the Bouc–Wen hysteretic benchmark with the structure model
  (a mass whose restoring force includes the Duffing-like element).
- :func:`run_silverbox`: the Silverbox's three official scores with Eq. 1 and catalogued effects.
"""

from duffsym.benchmark.bouc_wen import BoucWenOptions, run_bouc_wen
from duffsym.benchmark.result import BenchmarkResult, Published
from duffsym.benchmark.silverbox import SilverboxOptions, run_silverbox

__all__ = ["run_bouc_wen", "run_silverbox", "BoucWenOptions", "SilverboxOptions", "BenchmarkResult", "Published"]
