"""The ``ours`` method: the SPARK pipeline (:func:`spark_bench.methods.ours.run_ours`), handed a :class:`CaseInput`.

Its inputs are what its configuration reads of a case (:meth:`SparkConfig.case_inputs`), and its
regime names every ground-truth-derived one, the simulated stages by what they take from the ground
truth (:meth:`SparkConfig.simulated_stages`, as each stage's backend names it). With the default
configuration (SPARK's own optimizer on the whole open-state silhouette)::

    image + gt camera + gt open image + gt structure (simulated prior) + gt geometry

and with ``[optimize] method = "native"``, ``part_masks = true`` (label ``opt=native,sup=part-masks``)::

    image + gt camera + gt open image + gt open part masks + gt structure (simulated prior) + gt geometry

and with no ground truth at all, the ``retrieval`` prior and geometry (label
``prior=retrieval,geometry=retrieval,open=dataset,opt=native`` with ``[optimize] method = "native"``)::

    image + gt camera + gt open image

SPARK itself (torch and the stage modules) is imported only when a case is generated.
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.data.case import BenchmarkCase
from spark_bench.methods.base import CaseInput, Generation, NotPreparedError, regime_of
from spark_bench.methods.options import MethodOption
from spark_bench.methods.registry import register_method


@register_method("ours")
class OursMethod:
    """SPARK with a ``SparkConfig``: its label is the configuration's (``ours (prior=annotation,...)``).

    When the geometry is the ground truth's, the shape metrics are marked invalid (n/a). The prior
    before joint optimization is a variant of its own (``w/o joint opt.``, paper Table 4).

    :param config: a ``SparkConfig``
    """

    name = "ours"
    accepts = {"config": MethodOption("SPARK's configuration file, TOML or JSON (default: the offline default "
                                      "configuration; docs/ours.md)", "path")}

    def __init__(self, config):
        from spark_bench import __version__

        self.spark_config = config
        self.version = __version__
        self.inputs = config.case_inputs()
        self.regime = " + ".join([regime_of(set(self.inputs) - {"gt"}), *config.simulated_stages()])
        self._gallery: dict | None = None

    @classmethod
    def from_options(cls, options: dict) -> OursMethod:
        """The registry's factory: ``options["config"]`` is a SPARK configuration file (default: offline; its
        ``[method]`` table, the eval command's, is not read here)."""
        from spark_bench.methods.ours.config import (
            SparkConfig,  # the registry works before SPARK is installed
        )

        path = options.get("config")
        return cls(SparkConfig.from_file(path) if path else SparkConfig())

    def label(self) -> str:
        return f"ours ({self.spark_config.label()})"

    def prepare(self) -> None:
        """With a ``retrieval`` backend: open the gallery and build its index (the default gallery is
        generated on first use), once, in this process, as ``--method retrieval`` does
        (:meth:`spark_bench.methods.retrieval.method.RetrievalMethod.prepare`); nothing otherwise."""
        if self._gallery is not None or not self.spark_config.uses_retrieval():
            return
        from spark_bench.methods.ours.retrieved import open_case_gallery
        from spark_bench.methods.retrieval.index import gallery_index
        from spark_bench.methods.retrieval.method import BUILD_WORKERS
        from spark_bench.methods.retrieval.search import SearchOptions

        gallery = open_case_gallery(self.spark_config.retrieval.gallery)
        gallery_index(gallery, SearchOptions().index, workers=BUILD_WORKERS, isolate=True)
        self._gallery = {"name": gallery.name, "hash": gallery.content_hash}

    def config(self) -> dict:
        """The configuration; with a ``retrieval`` backend also the gallery's name and content hash (so
        results are keyed by what the gallery holds).

        :raises NotPreparedError: with a ``retrieval`` backend, before :meth:`prepare`
        """
        out = self.spark_config.to_dict()
        if self.spark_config.uses_retrieval():
            if self._gallery is None:
                raise NotPreparedError("ours: call prepare() before config() (the retrieval gallery's content "
                                       "hash is known once the gallery is built)")
            out["retrieval_gallery"] = dict(self._gallery)
        return out

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        """Run the pipeline; the refined object is ``out_dir``, the prior's ``out_dir/prior`` a variant."""
        from spark_bench.methods.ours.pipeline import run_ours

        report = run_ours(case, out_dir, self.spark_config)
        variants = {}
        if self.spark_config.optimize.enabled and (Path(out_dir) / "prior" / "mobility.urdf").is_file():
            variants["w/o joint opt."] = Path(out_dir) / "prior"
        info = {k: report[k] for k in ("label", "backends", "timings", "movable_joints", "retrieval")
                if k in report}
        return Generation(Path(out_dir), info, variants,
                          shape_metrics_valid=not report.get("geometry_is_ground_truth", False))


def ours_case(case_dir: str | Path, config) -> CaseInput:
    """The case in ``case_dir`` as ``ours`` with ``config`` sees it (what the runner would hand it), for
    scripts and tests that call :func:`spark_bench.methods.ours.run_ours` themselves."""
    return CaseInput(BenchmarkCase(Path(case_dir)), frozenset(OursMethod(config).inputs))
