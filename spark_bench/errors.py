"""Exceptions shared by every module: one-line, file-naming errors for bad input."""

from __future__ import annotations

from pathlib import Path


class SparkBenchError(Exception):
    """Base class of every error spark-bench raises on purpose."""


class InputError(SparkBenchError):
    """Bad input: the message names the file and the problem on one line.

    :param path: the file (or folder) that is wrong
    :param problem: what is wrong with it, in a few words
    """

    def __init__(self, path: str | Path | None, problem: str):
        self.path = None if path is None else str(path)
        self.problem = " ".join(str(problem).split())  # always one line
        super().__init__(f"{self.path}: {self.problem}" if self.path else self.problem)
