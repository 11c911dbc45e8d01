"""The version of the metric definitions (``docs/conventions.md``), written into every results row.

What each version changed is told in ``docs/conventions-history.md``.
"""

#: The current metric convention; a row stored under another one is not compared with today's.
CONVENTION_VERSION = "spark-bench-conv-11"
