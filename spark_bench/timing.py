"""The one stage timer: wall and CPU seconds per named stage, summed over its ``with timer(name)`` blocks.

On a shared machine the CPU seconds (this process's) say what the work costs, the wall seconds what it
took; both are kept.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager


class StageTimer:
    """Accumulates wall and CPU seconds per stage: ``with timer("render"): ...``.

    :attr wall: wall seconds per stage
    :attr cpu: this process's CPU seconds per stage
    """

    def __init__(self):
        self.wall: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    @contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            self.wall[stage] = self.wall.get(stage, 0.0) + time.perf_counter() - wall
            self.cpu[stage] = self.cpu.get(stage, 0.0) + time.process_time() - cpu

    def as_dict(self, cpu: bool = True) -> dict[str, float]:
        """``{stage: wall seconds}``, with ``cpu`` also ``{stage + "_cpu": CPU seconds}``."""
        return {**self.wall, **({f"{k}_cpu": v for k, v in self.cpu.items()} if cpu else {})}
