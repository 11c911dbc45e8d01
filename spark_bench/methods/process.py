"""The one runner of external programs (a ``command`` method, SPARK's geometry command).

A program runs from an argument list, never through a shell (a ``;`` in an argument is just a
character), with stdin closed, in a session and process group of its own. On timeout the whole group
is killed: SPARK-like pipelines start child processes that would otherwise keep running and hold the
output pipes open.
"""

from __future__ import annotations

import os
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

from spark_bench.errors import SparkBenchError

#: Seconds to collect what a killed group left in the pipes before giving up on them.
DRAIN_S = 5.0


class ProgramError(SparkBenchError):
    """An external program could not start, or ran out of time (and was killed with its group).

    :param program: the program (``argv[0]``)
    :param problem: what happened, e.g. ``cannot start 'prog': No such file or directory`` or
        ``timed out after 60 s``
    """

    def __init__(self, program: str, problem: str):
        self.program, self.problem = program, problem
        super().__init__(problem)


@dataclass
class ProgramResult:
    """A finished program: its exit status and its output as text (undecodable bytes replaced)."""

    argv: list[str]
    returncode: int
    stdout: str
    stderr: str

    def last_lines(self, n: int = 1) -> list[str]:
        """The last ``n`` non-empty lines of stderr, else of stdout (stripped)."""
        lines = [line.strip() for line in (self.stderr.strip() or self.stdout.strip()).splitlines()]
        return [line for line in lines if line][-n:]


def run_program(argv: list[str], timeout_s: float, cwd: str | Path | None = None,
                extra_env: dict[str, str] | None = None) -> ProgramResult:
    """Run ``argv`` to completion (see the module docstring); a non-zero exit status is returned, not raised.

    :param argv: the program and its arguments
    :param timeout_s: seconds before the program's whole process group is killed
    :param cwd: working directory (default: the current one)
    :param extra_env: variables added to this process's environment
    :raises ProgramError: when the program cannot start or times out
    """
    argv = [str(a) for a in argv]
    if not argv:
        raise ProgramError("", "cannot start an empty command")
    env = {**os.environ, **extra_env} if extra_env else None
    try:
        process = subprocess.Popen(argv, cwd=cwd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                   stderr=subprocess.PIPE, start_new_session=True)
    except OSError as exc:
        raise ProgramError(argv[0], f"cannot start {argv[0]!r}: {exc.strerror or exc}") from None
    try:
        stdout, stderr = process.communicate(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        _kill_group(process)
        raise ProgramError(argv[0], f"timed out after {timeout_s:g} s") from None
    except BaseException:  # an interrupt must not leave the program running
        _kill_group(process)
        raise
    return ProgramResult(argv, process.returncode, stdout.decode(errors="replace"), stderr.decode(errors="replace"))


def _kill_group(process: subprocess.Popen) -> None:
    """Kill ``process``'s process group (it leads its own session) and reap it."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        process.kill()
    try:
        process.communicate(timeout=DRAIN_S)
    except subprocess.TimeoutExpired:  # a grandchild that left the group still holds a pipe
        for pipe in (process.stdout, process.stderr):
            if pipe is not None:
                pipe.close()
        process.wait()
