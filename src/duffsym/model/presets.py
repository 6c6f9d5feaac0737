"""Parameter sets printed in the paper (Tables 1 and 2, Fig. 3)."""

from __future__ import annotations

from duffsym.errors import ModelError

#: Table 2: identified 3-kN MR damper at 2 Hz, by voltage (V). n = 5 and k3 = 0 throughout.
TABLE2: dict[float, dict[str, float]] = {
    0.0: dict(c1=10, c2=100, c3=350, k1=50, k2=800, k3=0, A_f=0.25),
    0.2: dict(c1=10, c2=10, c3=330, k1=40, k2=650, k3=0, A_f=1.0),
    0.3: dict(c1=10, c2=10, c3=320, k1=36, k2=520, k3=0, A_f=1.4),
    0.4: dict(c1=10, c2=10, c3=320, k1=34, k2=480, k3=0, A_f=1.6),
    0.5: dict(c1=10, c2=10, c3=280, k1=33, k2=470, k3=0, A_f=1.7),
    0.6: dict(c1=10, c2=10, c3=280, k1=32, k2=450, k3=0, A_f=1.8),
    0.8: dict(c1=10, c2=10, c3=250, k1=30, k2=400, k3=0, A_f=2.0),
}
TABLE2_N = 5
TABLE2_FREQUENCY_HZ = 2.0
TABLE2_DT = 0.005

#: Table 1: base values of the Fig. 6 sweeps (A_f = 2, n = 3) and the values swept per panel.
TABLE1_BASE: dict[str, float] = dict(c1=20, c2=10, c3=100, k1=3, k2=5, k3=5, A_f=2.0)
TABLE1_N = 3
TABLE1_SWEEPS: dict[str, tuple[str, tuple[float, ...]]] = {
    "a": ("c1", (-20, -10, 20, 30)),
    "b": ("c2", (-30, -10, 10, 30)),
    "c": ("c3", (100, 1000)),
    "d": ("k1", (-5, -3, 3, 5)),
    "e": ("k2", (-5, -1, 5, 15)),
    "f": ("k3", (-40, -5, 5, 60)),
    "g": ("n", (1, 3, 5)),
}
TABLE1_FREQUENCY_HZ = 0.25

#: Fig. 3: the Duffing-like benchmark (Eq. 3, n = 3) and the one-at-a-time changes.
FIG3_BASE: dict[str, float] = dict(gamma=10, alpha=10, beta=200, delta=200, k1=10, c1=10, A_f=2.0)
FIG3_N = 3
FIG3_CHANGES: dict[str, float] = dict(k1=25, c1=25, gamma=50, alpha=50, beta=400, delta=400, n=5, A_f=4)


def table2_params(voltage: float) -> dict[str, float]:
    """The Table 2 row for a coil voltage in volts (one of 0, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8)."""
    for v, row in TABLE2.items():
        if abs(v - float(voltage)) < 1e-9:
            return {k: float(x) for k, x in row.items()}
    rows = ", ".join(f"{v:g}" for v in TABLE2)
    raise ModelError(f"voltage {voltage:g} V is not a row of Table 2; choose one of {rows}")
