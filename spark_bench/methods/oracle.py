"""The ``oracle`` method: the ground-truth object itself, the sanity check of the whole pipeline.

Every articulation error of the oracle is zero and so is its Chamfer distance (the copied files load to
the same surfaces, sampled with the same seed); its sim-readiness is that of the ground truth. A benchmark where the oracle scores anything else has
a bug in a metric, a check or the case preparation.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from spark_bench.methods.base import CaseInput, Generation
from spark_bench.methods.registry import register_method


@register_method("oracle")
class Oracle:
    """Copies the case's ground-truth object folder as the prediction."""

    name = "oracle"
    version = "1"
    inputs = ("gt",)
    regime = "ground truth"
    #: It takes no options.
    accepts: dict = {}

    @classmethod
    def from_options(cls, options: dict) -> Oracle:
        """The registry's factory (no options)."""
        return cls()

    def label(self) -> str:
        return "oracle"

    def prepare(self) -> None:
        """Nothing to prepare."""

    def config(self) -> dict:
        return {}

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        """Copy ``gt/`` into ``out_dir``.

        :param case: the case (the ``gt`` input must be allowed)
        :param out_dir: the output folder (empty)
        """
        shutil.copytree(case.gt_dir, out_dir, dirs_exist_ok=True)
        return Generation(Path(out_dir), {"source": str(case.gt_dir)})
