"""Parity benchmarks of the papers' metric protocols (:mod:`spark_bench.metrics.protocols`)."""
