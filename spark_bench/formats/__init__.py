"""Other programs' output, read as they write it: one module (or folder) per format, each turning one
run of a method into an object folder in the benchmark frame, with the files of the method's code each
fact comes from.

- :mod:`.spark`: SPARK's run folders (its layout, the reader, ``spark-bench import spark``);
- :mod:`.commands`: ``spark-bench import FORMAT``.

This package uses ``asset`` and ``data`` only; the methods (``methods/predictions``, ``ours``' ``spark``
geometry backend) use it.
"""
