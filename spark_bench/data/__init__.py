"""Datasets: readers for object folders, the procedural ``synth`` generator, rendering, and
benchmark-case preparation.

Every name is imported on first use: even the readers pull in trimesh and yourdfpy, which
``spark-bench --help`` (it imports this package's ``commands``) should not pay for.
"""

from __future__ import annotations

from spark_bench.lazy import lazy_exports

_LAZY = {
    "find_urdf": "spark_bench.data.readers",
    "load_object": "spark_bench.data.readers",
    "prepare_case": "spark_bench.data.prepare",
    "prepare_benchmark": "spark_bench.data.prepare",
    "PrepareOptions": "spark_bench.data.prepare",
    "read_segmentation": "spark_bench.data.prepare",
    "Benchmark": "spark_bench.data.case",
    "BenchmarkCase": "spark_bench.data.case",
    "ensure_benchmark": "spark_bench.data.benchmarks",
    "CameraView": "spark_bench.data.camera",
    "AssetRenderer": "spark_bench.data.render",
    "render_asset": "spark_bench.data.render",
    "generate_dataset": "spark_bench.data.synth",
    "generate_object": "spark_bench.data.synth",
}

_lazy_names, __getattr__ = lazy_exports(__name__, _LAZY)
__all__ = _lazy_names
