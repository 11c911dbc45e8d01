"""What the sim-readiness checks report: one :class:`CheckResult` per check, a :class:`CheckReport`
per object (``spark-bench check --json``, with what reading the asset left out: ``warnings``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class CheckResult:
    """One check: whether it passed, its number, and details (JSON-able). A check never passes on a value that is
    not a number: such a result is made a failure, with that reason."""

    passed: bool
    value: float
    details: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.passed and not math.isfinite(float(self.value)):
            self.passed = False
            self.details.setdefault("reason", f"its value is not a number ({self.value})")

    def to_dict(self) -> dict:
        value = float(self.value) if math.isfinite(self.value) else None
        return {"passed": bool(self.passed), "value": value, **self.details}


@dataclass
class CheckReport:
    """All checks of one object. ``to_dict()`` is the ``spark-bench check --json`` output; ``seconds``
    says where the time went (wall seconds per stage, and the CPU seconds of the CoACD workers)."""

    name: str
    checks: dict[str, CheckResult] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks.values())

    def to_dict(self) -> dict:
        out = {"passed": self.passed, "checks": {k: v.to_dict() for k, v in self.checks.items()},
               "seconds": {k: round(v, 3) for k, v in self.seconds.items()}}
        if self.warnings:  # what reading the asset left out (look-only files, unreadable layers), one line each
            out["warnings"] = list(self.warnings)
        return out

    def failures(self) -> list[str]:
        """One line per failed check, with its reason where known."""
        return [f"{k}: {v.details.get('reason', 'failed')} (value {v.value:.4g})"
                for k, v in self.checks.items() if not v.passed]
