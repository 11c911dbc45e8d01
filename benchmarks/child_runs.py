"""One object per child process, results stored as they finish: the runner of the benchmarks that check many
objects (``measure_check_validity``, ``measure_engine_agreement``), with the objects they share (:func:`object_sets`)
and the command-line options that pick them and run them (:func:`add_run_arguments`).

Each object runs as ``python -m MODULE --one FOLDER --out STORE/<set>__<id>.json [ARGS]`` (``jobs`` at once), so
that one object's crash or hang (killed after ``timeout`` seconds) costs only its own row, and an interrupted run
resumes from the rows already stored.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
PARTNET_DEV = SHARED / "partnet_dev"
REAL_OBJECTS = SHARED / "real_objects"


def add_run_arguments(parser: argparse.ArgumentParser, name: str, results: Path) -> None:
    """The options every many-object benchmark takes: which objects (:func:`object_sets`), how many children at
    once, their home, where the rows and the report go.

    :param name: the benchmark's short name, for its default home and store under the temporary folder
    :param results: the report's default path without suffix
    """
    parser.add_argument("--half", choices=("tune", "holdout", "all", "none"), default="all",
                        help="which half of partnet_dev (none: skip it)")
    parser.add_argument("--no-real", dest="real", action="store_false", help="skip ../shared/real_objects")
    parser.add_argument("--cases", nargs="*", type=Path, default=[], help="prepared benchmarks: their cases/*/gt")
    parser.add_argument("--ids", nargs="*", default=None, help="only these object or case ids")
    parser.add_argument("--jobs", type=int, default=2, help="objects measured at once")
    parser.add_argument("--home", type=Path, default=Path(tempfile.gettempdir()) / f"spark_{name}_home",
                        help="$SPARK_BENCH_HOME of the checks (their CoACD cache)")
    parser.add_argument("--store", type=Path, default=Path(tempfile.gettempdir()) / f"spark_{name}",
                        help="per-object results")
    parser.add_argument("--fresh", action="store_true", help="measure objects that have a stored result again")
    parser.add_argument("--timeout", type=float, default=3600.0, help="seconds one object may take")
    parser.add_argument("--out", type=Path, default=results, help="report path without suffix ('-': none)")
    parser.add_argument("--one", type=Path, default=None, help=argparse.SUPPRESS)


def object_sets(args) -> list[tuple[str, str, Path]]:
    """``(set, id, folder)`` of every object :func:`add_run_arguments`' options pick: partnet_dev's halves (as
    ``partnet_dev_split.json`` fixes them), real_objects, and each prepared benchmark's ground truths."""
    from benchmarks.partnet_dev_split import read_halves

    out = []
    ids = set(args.ids) if args.ids else None
    if PARTNET_DEV.is_dir() and args.half != "none":
        halves = read_halves()
        for half in ("tune", "holdout") if args.half == "all" else (args.half,):
            out += [(f"partnet_dev {half}", i, PARTNET_DEV / i) for i in halves[half]]
    if REAL_OBJECTS.is_dir() and args.real:
        out += [("real_objects", p.name, p) for p in sorted(REAL_OBJECTS.iterdir()) if (p / "mobility.urdf").is_file()]
    for bench in args.cases:
        name = Path(bench).name
        out += [(name, c.name, c / "gt") for c in sorted((Path(bench) / "cases").iterdir())
                if (c / "gt" / "mobility.urdf").is_file()]
    return [row for row in out if ids is None or row[1] in ids]


def stored_path(store: Path, set_name: str, object_id: str) -> Path:
    """Where the row of ``object_id`` of ``set_name`` is stored."""
    return store / f"{set_name.replace(' ', '_')}__{object_id}.json"


def stored_rows(store: Path, objects: list[tuple[str, str, Path]]) -> dict[str, dict]:
    """The rows already stored for ``objects`` (by ``<set>__<id>``, each with its ``set`` and ``object``)."""
    rows = {}
    for set_name, object_id, _ in objects:
        path = stored_path(store, set_name, object_id)
        if path.is_file():
            rows[path.stem] = {**json.loads(path.read_text()), "set": set_name, "object": object_id}
    return rows


def rate(part: int, whole: int, digits: int = 0) -> str:
    """``part/whole (percent %)``, ``n/a`` for none: a rate always beside what it was computed on."""
    return f"{part}/{whole} ({100.0 * part / whole:.{digits}f} %)" if whole else "n/a"


def run_in_children(objects: list[tuple[str, str, Path]], store: Path, module: str, child_args: list[str], *,
                    home: Path, jobs: int, timeout: float, fresh: bool,
                    describe: Callable[[dict], str]) -> dict[str, dict]:
    """Measure every ``(set, id, folder)`` of ``objects`` in child processes, reusing stored rows.

    :param store: the folder of the rows (one JSON file per object)
    :param module: the benchmark module run as the child (it takes ``--one FOLDER --out PATH``)
    :param child_args: further arguments of every child
    :param home: ``$SPARK_BENCH_HOME`` of the children (their CoACD cache)
    :param jobs: children at once
    :param timeout: seconds one child may take before it is killed
    :param fresh: measure objects that have a stored row again
    :param describe: one line on a finished row, printed under the progress bar
    :return: the rows by ``<set>__<id>``, each with its ``set`` and ``object``
    """
    from concurrent.futures import ThreadPoolExecutor, as_completed

    from tqdm import tqdm

    store.mkdir(parents=True, exist_ok=True)
    rows = {} if fresh else stored_rows(store, objects)
    todo = [(s, i, folder, stored_path(store, s, i)) for s, i, folder in objects
            if stored_path(store, s, i).stem not in rows]

    def one(item) -> tuple[str, dict]:
        set_name, object_id, folder, path = item
        started = time.monotonic()
        row = _child_row([sys.executable, "-m", module, "--one", str(folder), "--out", str(path), *child_args],
                         path, timeout, home)
        row.update(set=set_name, object=object_id, wall_s=round(time.monotonic() - started, 1))
        path.write_text(json.dumps(row, indent=1))  # stored as it finishes: an interrupted run resumes here
        return path.stem, row

    with ThreadPoolExecutor(max(1, jobs)) as pool, tqdm(total=len(todo), desc="objects", unit="object") as bar:
        for future in as_completed([pool.submit(one, item) for item in todo]):
            key, row = future.result()
            rows[key] = row
            bar.update(1)
            bar.write(f"{row['set']:20s} {row['object']:>16s} {describe(row)}")
    return rows


def _child_row(command: list[str], path: Path, timeout: float, home: Path) -> dict:
    """The row one child wrote to ``path``; where it wrote none, its error (a time-out, its last output line)."""
    from spark_bench.methods.process import ProgramError, run_program

    try:  # its own process group, killed whole on a time-out (CoACD workers included), its output drained
        result = run_program(command, timeout, cwd=ROOT, extra_env={"SPARK_BENCH_HOME": str(home)})
    except ProgramError as exc:
        return {"error": exc.problem}
    if path.is_file():
        return json.loads(path.read_text())
    return {"error": (result.last_lines() or [f"exited with status {result.returncode} and wrote no row"])[0]}
