"""The result of a benchmark run: scores by the benchmark's protocol beside the published figures."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Published:
    """A published score: who, the value(s) per test set, and where it was read."""

    name: str
    scores: dict
    source: str


@dataclass(frozen=True)
class BenchmarkResult:
    """Scores of one benchmark run (``docs/contract.md``: ``duffsym benchmark``).

    Attributes
    ----------
    benchmark : ``"silverbox"`` or ``"bouc-wen"``.
    unit : the scores' unit (``"mV"`` or ``"m"``).
    scores : test set -> RMSE of the free-run simulation, by the benchmark's protocol.
    model, effects, n_params : the model scored, its effects, and its number of parameters (fixed ones included).
    seconds : wall time of estimation and scoring.
    protocol : every option and rule used (split, skipped samples, initialisation, estimation data).
    params : the parameter values scored.
    published : published scores on the same test sets, with sources.
    notes : what is doubtful, for the person reading the table.
    """

    benchmark: str
    unit: str
    scores: dict
    model: str
    effects: tuple
    n_params: int
    seconds: float
    protocol: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    published: tuple = ()
    notes: tuple = ()
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "benchmark": self.benchmark,
            "unit": self.unit,
            "scores": dict(self.scores),
            "model": self.model,
            "effects": list(self.effects),
            "n_params": int(self.n_params),
            "seconds": float(self.seconds),
            "protocol": dict(self.protocol),
            "params": dict(self.params),
            "published": [{"name": p.name, "scores": dict(p.scores), "source": p.source} for p in self.published],
            "notes": list(self.notes),
            "details": dict(self.details),
        }

    def table(self) -> str:
        """The scores beside the published ones, one row each."""
        sets = list(self.scores)
        fmt = (lambda v: f"{v:.4g}") if self.unit == "m" else (lambda v: f"{v:.3f}")
        head = f"{'model':<46}" + "".join(f"{s:>24}" for s in sets)
        rows = [head, "-" * len(head)]
        rows.append(
            f"{'duffsym: ' + self.model + (' + ' + ', '.join(self.effects) if self.effects else ''):<46}"[:46]
            + "".join(f"{fmt(self.scores[s]):>24}" for s in sets)
        )
        for p in self.published:
            rows.append(
                f"{p.name:<46}"[:46] + "".join(f"{(fmt(p.scores[s]) if s in p.scores else '-'):>24}" for s in sets)
            )
        rows.append(f"(RMSE in {self.unit}; sources below)")
        rows += [f"  {p.name}: {p.source}" for p in self.published]
        return "\n".join(rows)

    def summary(self) -> str:
        lines = [
            f"benchmark {self.benchmark}: model {self.model} ({self.n_params} parameters), {self.seconds:.0f} s",
            self.table(),
        ]
        lines += [f"  protocol: {k} = {v}" for k, v in self.protocol.items()]
        lines += [f"  note: {n}" for n in self.notes]
        return "\n".join(lines)
