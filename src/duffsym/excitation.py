"""Input signals with exact time derivatives: sine, multisine and band-limited random."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from duffsym.errors import DataError


class Excitation:
    """A signal :math:`d(t)` whose derivatives up to order 2 are known exactly."""

    signal: str = "d"

    def derivative(self, t: np.ndarray, order: int) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError

    def __call__(self, t) -> np.ndarray:
        return self.derivative(np.asarray(t, dtype=float), 0)

    def channels(self, t, model) -> np.ndarray:
        """The model's input matrix ``(n_times, n_inputs)`` sampled at ``t``."""
        t = np.asarray(t, dtype=float)
        orders = []
        for ch in model.inputs:
            if ch.signal != self.signal:
                raise DataError(
                    f"model {model.name} needs input signal {ch.signal!r}, the excitation provides "
                    f"{self.signal!r}; build the excitation with signal={ch.signal!r}"
                )
            orders.append(ch.order)
        return self._derivatives(t, orders)

    def _derivatives(self, t: np.ndarray, orders: list[int]) -> np.ndarray:
        """Columns ``(n_times, len(orders))`` of the derivatives of the given orders."""
        U = np.empty((t.size, len(orders)))
        for j, k in enumerate(orders):
            U[:, j] = self.derivative(t, k)
        return U


def _check_positive(name, value):
    if not (math.isfinite(value) and value > 0):
        raise DataError(f"{name} must be a positive finite number; got {value}")


@dataclass(frozen=True)
class Sine(Excitation):
    """:math:`d(t) = a \\sin(2\\pi f t + \\varphi)`."""

    amplitude: float = 1.0
    frequency: float = 1.0
    phase: float = 0.0
    signal: str = "d"

    def __post_init__(self):
        _check_positive("frequency (Hz)", self.frequency)
        if not math.isfinite(self.amplitude):
            raise DataError(f"amplitude must be finite; got {self.amplitude}")

    @property
    def period(self) -> float:
        return 1.0 / self.frequency

    def derivative(self, t, order):
        w = 2 * math.pi * self.frequency
        arg = w * np.asarray(t, dtype=float) + self.phase
        # d^k/dt^k sin = w^k sin(arg + k pi/2)
        return self.amplitude * w**order * np.sin(arg + order * math.pi / 2)

    def _derivatives(self, t, orders):
        # one sine and one cosine serve every order: d^k sin = w^k (sin, cos, -sin, -cos)[k % 4]
        w = 2 * math.pi * self.frequency
        arg = w * t + self.phase
        base = (np.sin(arg), np.cos(arg))
        U = np.empty((t.size, len(orders)))
        for j, k in enumerate(orders):
            sign = -1.0 if k % 4 >= 2 else 1.0
            np.multiply(base[k % 2], sign * self.amplitude * w**k, out=U[:, j])
        return U


@dataclass(frozen=True)
class Multisine(Excitation):
    """Sum of sines with given amplitudes, frequencies (Hz) and phases."""

    amplitudes: tuple[float, ...]
    frequencies: tuple[float, ...]
    phases: tuple[float, ...] = ()
    signal: str = "d"

    def __post_init__(self):
        if len(self.amplitudes) != len(self.frequencies) or len(self.amplitudes) == 0:
            raise DataError("Multisine needs as many amplitudes as frequencies (at least one)")
        for f in self.frequencies:
            _check_positive("frequency (Hz)", f)
        if self.phases and len(self.phases) != len(self.amplitudes):
            raise DataError("Multisine phases must match the frequencies in number (or be empty)")

    @classmethod
    def random_phase(cls, rms: float, f_min: float, f_max: float, n_lines: int, *, rng=None, signal="d"):
        """Equal-amplitude lines between ``f_min`` and ``f_max`` with random phases, scaled to ``rms``."""
        rng = np.random.default_rng(rng)
        freqs = np.linspace(f_min, f_max, n_lines)
        amp = rms * math.sqrt(2.0 / n_lines)
        return cls(tuple([amp] * n_lines), tuple(freqs), tuple(rng.uniform(0, 2 * math.pi, n_lines)), signal)

    def derivative(self, t, order):
        t = np.asarray(t, dtype=float)
        phases = self.phases or (0.0,) * len(self.amplitudes)
        out = np.zeros_like(t)
        for a, f, ph in zip(self.amplitudes, self.frequencies, phases):
            w = 2 * math.pi * f
            out += a * w**order * np.sin(w * t + ph + order * math.pi / 2)
        return out


#: Most lines of a :class:`BandLimitedRandom` (one per 1/duration up to f_max); the fuzz test found
#: ``--duration 99999 --f-max 99999`` (1e10 lines) filling 24 GB before any error.
MAX_RANDOM_LINES = 1_000_000


@dataclass(frozen=True)
class BandLimitedRandom(Excitation):
    """Gaussian-like random signal: many random-phase lines with random amplitudes up to ``f_max``.

    Deterministic from ``seed``; smooth, so its derivatives are exact.
    """

    rms: float = 1.0
    f_max: float = 5.0
    duration: float = 10.0
    seed: int = 0
    signal: str = "d"
    _lines: Multisine = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        _check_positive("rms", self.rms)
        _check_positive("f_max (Hz)", self.f_max)
        _check_positive("duration (s)", self.duration)
        rng = np.random.default_rng(self.seed)
        f0 = 1.0 / self.duration
        n_lines = self.f_max * self.duration
        if n_lines > MAX_RANDOM_LINES:  # checked before np.arange, which would fill the memory page by page
            raise DataError(
                f"random excitation: f_max x duration = {self.f_max:g} Hz x {self.duration:g} s is {n_lines:.3g} "
                f"lines, more than {MAX_RANDOM_LINES}; lower f_max or the duration"
            )
        freqs = np.arange(f0, self.f_max + 0.5 * f0, f0)
        if freqs.size == 0:
            raise DataError(
                f"random excitation: f_max = {self.f_max:g} Hz is below the lowest line 1/duration = "
                f"{f0:g} Hz; raise f_max or the duration"
            )
        amps = rng.rayleigh(1.0, freqs.size)
        amps *= self.rms / math.sqrt(0.5 * np.sum(amps**2))
        lines = Multisine(tuple(amps), tuple(freqs), tuple(rng.uniform(0, 2 * math.pi, freqs.size)), self.signal)
        object.__setattr__(self, "_lines", lines)

    def derivative(self, t, order):
        return self._lines.derivative(t, order)
