"""The one runner of external programs: argument lists without a shell, the whole group killed on timeout."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

from spark_bench.methods.process import ProgramError, run_program


def _alive(pid: int) -> bool:
    """Whether process ``pid`` still runs (a zombie waiting for its reaper does not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


def test_no_shell_and_the_output_comes_back():
    done = run_program([sys.executable, "-c", "import sys; print(sys.argv[1]); print('err', file=sys.stderr); "
                        "sys.exit(4)", "a; echo injected $HOME `id`"], timeout_s=30)
    assert done.returncode == 4
    assert done.stdout == "a; echo injected $HOME `id`\n"  # one argument, passed literally
    assert done.stderr == "err\n" and done.last_lines() == ["err"]


def test_environment_working_directory_and_closed_stdin(tmp_path):
    done = run_program([sys.executable, "-c", "import os, sys; print(os.getcwd(), os.environ['SPARK_X'], "
                        "repr(sys.stdin.read()))"], timeout_s=30, cwd=tmp_path, extra_env={"SPARK_X": "1"})
    assert done.returncode == 0 and done.stdout.split() == [str(tmp_path.resolve()), "1", "''"]


def test_a_program_that_cannot_start():
    with pytest.raises(ProgramError, match="cannot start '/nonexistent/prog'") as info:
        run_program(["/nonexistent/prog", "x"], timeout_s=5)
    assert info.value.program == "/nonexistent/prog"


@pytest.mark.skipif(not Path("/proc/self/stat").is_file(), reason="needs /proc to see the child process")
def test_timeout_kills_the_whole_process_group(tmp_path):
    """The program starts a child that holds the output pipe and would outlive it; both are killed, and
    the runner returns at once instead of waiting for the pipe to close."""
    pid_file = tmp_path / "child.pid"
    script = ("import subprocess, sys, time; child = subprocess.Popen(['sleep', '60']); "
              f"open({str(pid_file)!r}, 'w').write(str(child.pid)); time.sleep(60)")
    start = time.monotonic()
    with pytest.raises(ProgramError, match="timed out after 3 s"):
        run_program([sys.executable, "-c", script], timeout_s=3)
    assert time.monotonic() - start < 20
    child = int(pid_file.read_text())
    deadline = time.monotonic() + 5
    while _alive(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(child), "the program's child survived the timeout"
