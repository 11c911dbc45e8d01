"""Datasets: readers for object folders, the procedural ``synth`` generator, rendering, and
benchmark-case preparation."""

from spark_bench.data.readers import find_urdf, load_object

__all__ = ["find_urdf", "load_object"]
