"""The measurements behind the harness's numbers: one ``measure_<what>`` script per measurement, run from the
repository root as ``python -m benchmarks.<name>``, and the modules they share. Not part of the installed
package. ``benchmarks/README.md`` names every script, the report(s) it writes under ``benchmarks/results/``
and the latest headline numbers."""
