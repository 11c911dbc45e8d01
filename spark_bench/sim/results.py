"""What the sim-readiness checks report: one :class:`CheckResult` per check, a :class:`CheckReport`
per object (``spark-bench check --json``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class CheckResult:
    """One check: whether it passed, its number, and details (JSON-able)."""

    passed: bool
    value: float
    details: dict = field(default_factory=dict)

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

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.passed for c in self.checks.values())

    def to_dict(self) -> dict:
        return {"passed": self.passed, "checks": {k: v.to_dict() for k, v in self.checks.items()},
                "seconds": {k: round(v, 3) for k, v in self.seconds.items()}}

    def failures(self) -> list[str]:
        """One line per failed check, with its reason where known."""
        return [f"{k}: {v.details.get('reason', 'failed')} (value {v.value:.4g})"
                for k, v in self.checks.items() if not v.passed]
