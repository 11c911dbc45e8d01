"""SPARK's real output, read as SPARK's public code writes it.

- :mod:`.layout`: SPARK's folder layout, names, stages and frames (with the files of SPARK's code each
  fact comes from);
- :mod:`.reader`: one SPARK run folder -> an object folder in the benchmark frame;
- :mod:`.importer`: ``spark-bench import spark`` over a folder of runs.

Running SPARK's own scripts is :mod:`spark_bench.methods.ours.run_spark`; handing it the benchmark's images,
``spark-bench data export-images`` (:mod:`spark_bench.data.export`).
"""
