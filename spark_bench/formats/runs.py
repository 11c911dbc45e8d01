"""``spark-bench import FORMAT --runs DIR --bench BENCH --out PRED``: one run of another method per case,
``DIR/<case id>/`` holding that case's output exactly as the method writes it for one object, read by the
format's reader and written as ``PRED/<case id>/`` (an object folder in the benchmark frame with its
``import.json``, :mod:`spark_bench.formats.foreign`).

What was skipped and why is listed: a case without a run folder, a run the reader refuses (its one-line
:class:`~spark_bench.errors.InputError` naming the file and the problem: the import goes on with the other
runs), and entries of ``DIR`` that name no case. A previous import of a case that is now skipped is removed,
so ``eval`` never scores a stale run. The report goes to ``PRED/<format>_import.json``.

Exit codes of the command: 0 when at least one run was imported, 1 when none could be, 2 on bad arguments
(no runs folder, not a benchmark, an unknown format or case).

The formats (:data:`spark_bench.formats.FORMATS`): each name maps to ``module:function``, a reader ``(run_dir: Path) ->
ForeignObject`` raising :class:`~spark_bench.errors.InputError`; SPARK's run folders, named by timestamp,
have their own importer (``import spark``, :mod:`spark_bench.formats.spark.importer`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.formats import FORMATS, RUN_FILE_SUFFIXES
from spark_bench.formats.foreign import (
    ForeignObject,
    ImportOutcome,
    remove_stale_import,
    selected_case_ids,
    to_benchmark,
    write_import,
)

Reader = Callable[[Path], ForeignObject]


def reader_of(name: str) -> Reader:
    """The reader of format ``name``.

    :raises InputError: for an unknown format
    """
    if name not in FORMATS:
        raise InputError(None, f"unknown format {name!r}; known: {', '.join(sorted(FORMATS)) or 'none'}")
    module, _, function = FORMATS[name].partition(":")
    return getattr(importlib.import_module(module), function)


def run_file_suffixes(name: str) -> tuple[str, ...]:
    """The file suffixes a case's run of format ``name`` may also be, ``DIR/<case id><suffix>``
    (:data:`spark_bench.formats.RUN_FILE_SUFFIXES`; none for a format whose run is always a folder)."""
    return RUN_FILE_SUFFIXES.get(name, ())


def run_of(runs_dir: Path, case_id: str, suffixes: tuple[str, ...]) -> Path:
    """A case's run: ``DIR/<case id>/``, else the one file ``DIR/<case id><suffix>`` (the folder's path when
    neither is there)."""
    folder = runs_dir / case_id
    if folder.is_dir():
        return folder
    files = [runs_dir / f"{case_id}{suffix}" for suffix in suffixes if (runs_dir / f"{case_id}{suffix}").is_file()]
    return files[0] if len(files) == 1 else folder


@dataclass
class CaseImport:
    """What happened to one case.

    :param case_id: the case
    :param run: its run folder (None: there was none)
    :param imported: whether ``PRED/<case id>/`` was written
    :param reason: why it was skipped (empty when imported)
    :param removed_stale: a previous import of the case was removed
    :param articulated: the imported object has joints (False: a shape-only format)
    """

    case_id: str
    run: Path | None
    imported: bool
    reason: str = ""
    removed_stale: bool = False
    articulated: bool = True

    def to_dict(self) -> dict:
        return {"case": self.case_id, "run": None if self.run is None else str(self.run), "imported": self.imported,
                "reason": self.reason, "removed_stale": self.removed_stale, "articulated": self.articulated}


@dataclass
class ImportReport(ImportOutcome):
    """The outcome of :func:`import_runs`."""

    format: str
    runs_dir: Path
    out_dir: Path
    bench: Path
    cases: list[CaseImport] = field(default_factory=list)
    unknown: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"format": self.format, "runs": str(self.runs_dir), "out": str(self.out_dir), "bench": str(self.bench),
                "imported": len(self.imported), "skipped": len(self.skipped),
                "cases": [c.to_dict() for c in self.cases], "unknown": self.unknown}

    def lines(self) -> list[str]:
        """A human-readable report, one item per line, ending with the command that scores the import."""
        out = [f"imported {len(self.imported)} of {len(self.cases)} cases ({self.format}) from {self.runs_dir} "
               f"into {self.out_dir}"]
        out += [f"  imported {c.case_id}" + ("" if c.articulated else " (shape only: no joints)")
                for c in self.imported]
        out += [f"  skipped  {c.case_id}: {c.reason}" for c in self.skipped]
        out += [f"  no such case: {name}" for name in self.unknown]
        if self.imported:
            out.append(f"score them: spark-bench eval --method predictions --method-args "
                       f"predictions={self.out_dir},label={self.format} --bench {self.bench} --align icp")
        return out


def import_runs(fmt: str, runs_dir: str | Path, bench: str | Path, out_dir: str | Path,
                cases: list[str] | None = None, reader: Reader | None = None) -> ImportReport:
    """Import every case's run of format ``fmt`` (see the module docstring).

    :param fmt: the format's name (:data:`spark_bench.formats.FORMATS`)
    :param runs_dir: the folder of runs, ``DIR/<case id>/``
    :param bench: the benchmark folder
    :param out_dir: the predictions folder to write (``PRED``)
    :param cases: only these case ids (default: every case of the benchmark)
    :param reader: the reader to use (default: the format's, :func:`reader_of`)
    :raises InputError: for a missing runs folder, a folder that is not a benchmark, an unknown format or case
    """
    from spark_bench.data.case import Benchmark
    from spark_bench.jsonio import to_json_text

    read = reader or reader_of(fmt)
    benchmark = Benchmark(Path(bench))
    case_ids = selected_case_ids(benchmark, cases)
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        raise InputError(runs_dir, "runs folder not found (one folder per case id, each one run's output)")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(out_dir, "predictions folder is a file")
    out_dir.mkdir(parents=True, exist_ok=True)
    known = set(benchmark.case_ids())
    suffixes = run_file_suffixes(fmt)

    def case_of(p: Path) -> str:
        return p.stem if p.is_file() and p.suffix.lower() in suffixes else p.name

    report = ImportReport(fmt, runs_dir, out_dir, Path(bench),
                          unknown=sorted(p.name for p in runs_dir.iterdir()
                                         if not p.name.startswith(".") and case_of(p) not in known))
    for case_id in case_ids:
        benchmark.case_dir(case_id)  # refuses an id that would leave the folder
        target = out_dir / case_id
        run = run_of(runs_dir, case_id, suffixes)
        if not run.exists():
            report.cases.append(CaseImport(case_id, None, False, f"no {fmt} run for this case ({run} is not a "
                                           "folder)", removed_stale=remove_stale_import(target)))
            continue
        try:
            found = read(run.resolve())
            found.record.setdefault("format", fmt)
            found.record["run"] = str(run.resolve())
            found.record["case_id"] = case_id
            asset, record = to_benchmark(found, case_id)
        except InputError as exc:
            report.cases.append(CaseImport(case_id, run, False, " ".join(str(exc).split()),
                                           removed_stale=remove_stale_import(target)))
            continue
        except Exception as exc:  # a reader's bug or a library's surprise: this run fails, the import goes on
            reason = f"{run}: unexpected {type(exc).__name__} while reading: {' '.join(str(exc).split())[:300]}"
            report.cases.append(CaseImport(case_id, run, False, reason, removed_stale=remove_stale_import(target)))
            continue
        write_import(asset, record, target)
        report.cases.append(CaseImport(case_id, run, True, articulated=found.articulated))
    (out_dir / f"{fmt}_import.json").write_text(to_json_text(report.to_dict(), indent=1) + "\n")
    return report
