"""SPARK's real output, read and run as SPARK's public code writes it.

- :mod:`~spark_bench.spark_output.layout`: SPARK's folder layout, names, stages and frames (with the
  files of SPARK's code each fact comes from);
- :mod:`~spark_bench.spark_output.reader`: one SPARK run folder -> an object folder in the benchmark frame;
- :mod:`~spark_bench.spark_output.importer`: ``spark-bench import spark`` over a folder of runs;
- :mod:`~spark_bench.spark_output.export`: ``spark-bench data export-images`` (the images SPARK reads);
- :mod:`~spark_bench.spark_output.driver`: SPARK's stage scripts run per case;
- :mod:`~spark_bench.spark_output.commands`: the command-line entries.
"""
