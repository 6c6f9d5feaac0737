"""Where the shipped records are, for the gallery scripts (run from ``examples/`` or the checkout root)."""
from pathlib import Path

DATA = next(p for p in (Path("../data"), Path("data"), Path(__file__).resolve().parent.parent / "data")
            if (p / "synthetic_sine.csv").is_file())
