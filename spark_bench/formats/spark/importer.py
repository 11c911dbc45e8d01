"""``spark-bench import spark``: a folder of SPARK runs -> a predictions folder, one object folder per case.

SPARK's ``run.py`` names each run ``<image name>_<YYYYmmdd_HHMMSS>`` (one timestamp per ``run.py``
invocation); with images exported by ``spark-bench data export-images`` the image name is the case id.
Case ids may contain underscores, so a folder name is split at its trailing timestamp and the rest must
equal one of the benchmark's case ids (``Benchmark.case_ids()``). Per case the newest timestamp wins;
older runs are listed as superseded. A folder that is not a run, a run that names no case and a case
with no run are reported. For each chosen run the stage that failed is told from the files present
(:func:`spark_bench.formats.spark.layout.diagnose`: ``run.py`` exits 0 whatever fails), and the run is read
by :func:`spark_bench.formats.spark.reader.read_spark_run` into ``PRED/<case id>/`` (an object folder in
the benchmark frame with its ``import.json``). A run that cannot be read is skipped with the reason; a
previous import of that case is removed, so ``eval`` never scores a stale run as if it were the newest.
The whole report goes to ``PRED/spark_import.json``.

Exit codes of the command: 0 when at least one run was imported (skipped ones are listed), 1 when none
could be, 2 on bad arguments (no runs folder, not a benchmark).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from spark_bench.errors import InputError
from spark_bench.formats.foreign import ImportOutcome, remove_stale_import, selected_case_ids, write_import
from spark_bench.formats.spark import layout
from spark_bench.formats.spark.reader import read_spark_run

SUMMARY = "spark_import.json"


@dataclass(frozen=True)
class RunFolder:
    """A SPARK run folder: ``<name>_<stamp>``."""

    path: Path
    name: str
    stamp: str


@dataclass
class CaseImport:
    """What happened to one case.

    :param case_id: the case
    :param run: the run folder read (None: the case had no run)
    :param imported: whether ``PRED/<case id>/`` was written
    :param reason: why it was skipped (empty when imported)
    :param failed_stage: the first SPARK stage whose output is missing (None: every stage's is there)
    :param urdf: the URDF read (relative to the run), when imported
    :param removed_stale: a previous import of the case was removed
    :param label: the results label the driver recorded for the run (None: not made by the driver)
    """

    case_id: str
    run: Path | None
    imported: bool
    reason: str = ""
    failed_stage: str | None = None
    urdf: str | None = None
    removed_stale: bool = False
    label: str | None = None

    def to_dict(self) -> dict:
        return {"case": self.case_id, "run": None if self.run is None else str(self.run), "imported": self.imported,
                "reason": self.reason, "failed_stage": self.failed_stage, "urdf": self.urdf,
                "removed_stale": self.removed_stale, "label": self.label}


@dataclass
class ImportReport(ImportOutcome):
    """The outcome of :func:`import_runs`."""

    runs_dir: Path
    out_dir: Path
    alignment: str
    bench: Path | None = None
    cases: list[CaseImport] = field(default_factory=list)
    not_runs: list[str] = field(default_factory=list)
    unknown: list[str] = field(default_factory=list)
    superseded: list[str] = field(default_factory=list)

    @property
    def label(self) -> str:
        """The results label to give ``eval``: the driver's when every run shares one, else ``spark``."""
        kinds = {c.urdf for c in self.imported}
        labels = {c.label for c in self.imported}
        base = labels.pop() if len(labels) == 1 and None not in labels else "spark"
        if kinds and all(k and k.endswith(layout.OPTIMIZED_SUFFIX) for k in kinds) and "optimize" not in base:
            base += "+optimized"
        return base

    def to_dict(self) -> dict:
        return {"runs": str(self.runs_dir), "out": str(self.out_dir), "alignment": self.alignment,
                "bench": None if self.bench is None else str(self.bench),
                "imported": len(self.imported), "skipped": len(self.skipped), "label": self.label,
                "cases": [c.to_dict() for c in self.cases], "not_runs": self.not_runs, "unknown": self.unknown,
                "superseded": self.superseded}

    def lines(self) -> list[str]:
        """A human-readable report, one item per line."""
        out = [f"imported {len(self.imported)} of {len(self.cases)} cases from {self.runs_dir} into {self.out_dir}"]
        for c in self.cases:
            if c.imported:
                note = f" (stage {c.failed_stage} incomplete)" if c.failed_stage else ""
                out.append(f"  imported {c.case_id}: {c.run.name} {c.urdf}{note}")
        for c in self.skipped:
            stage = f" [failed stage: {c.failed_stage}]" if c.failed_stage else ""
            out.append(f"  skipped  {c.case_id}: {c.reason}{stage}")
        out += [f"  superseded: {name}" for name in self.superseded]
        out += [f"  no such case: {name}" for name in self.unknown]
        out += [f"  not a SPARK run folder: {name}" for name in self.not_runs]
        if self.imported:
            bench = f" --bench {self.bench}" if self.bench is not None else ""
            out.append(f"score them: spark-bench eval --method predictions --method-args predictions={self.out_dir},"
                       f"label={self.label}{bench}" + (" --align icp" if self.alignment == "icp" else ""))
        return out


def find_runs(runs_dir: str | Path) -> tuple[list[RunFolder], list[str]]:
    """``(run folders, other entries)`` of a SPARK output folder (hidden entries ignored), sorted by name.

    :raises InputError: when ``runs_dir`` is not a folder
    """
    runs_dir = Path(runs_dir)
    if not runs_dir.is_dir():
        raise InputError(runs_dir, "SPARK runs folder not found (SPARK writes them into its output/)")
    runs, other = [], []
    for entry in sorted(runs_dir.iterdir()):
        if entry.name.startswith("."):
            continue
        parsed = layout.parse_run_name(entry.name) if entry.is_dir() else None
        if parsed is None:
            other.append(entry.name)
        else:
            runs.append(RunFolder(entry, *parsed))
    return runs, other


def match_runs(runs: list[RunFolder], case_ids: list[str]) -> tuple[dict[str, RunFolder], list[RunFolder],
                                                                     list[RunFolder]]:
    """``(newest run by case id, superseded runs, runs naming no case)``."""
    known = set(case_ids)
    chosen: dict[str, RunFolder] = {}
    superseded, unknown = [], []
    for run in runs:
        if run.name not in known:
            unknown.append(run)
            continue
        previous = chosen.get(run.name)
        if previous is None or (run.stamp, run.path.name) > (previous.stamp, previous.path.name):
            if previous is not None:
                superseded.append(previous)
            chosen[run.name] = run
        else:
            superseded.append(run)
    return chosen, superseded, unknown


def import_runs(runs_dir: str | Path, bench: str | Path, out_dir: str | Path, tag: str | None = None,
                alignment: str = "icp", cases: list[str] | None = None) -> ImportReport:
    """Import every case's newest SPARK run (see the module docstring).

    :param runs_dir: SPARK's output folder (``SPARK/output``)
    :param bench: the benchmark folder
    :param out_dir: the predictions folder to write (``PRED``)
    :param tag: the inference tag (default: SPARK's ``FT5_G1_0``, else the only one in each run)
    :param alignment: ``icp`` or ``camera`` (:func:`~spark_bench.formats.spark.reader.read_spark_run`)
    :param cases: only these case ids (default: every case of the benchmark)
    :raises InputError: for a missing runs folder, a folder that is not a benchmark, an unknown case
    """
    from spark_bench.data.case import Benchmark
    from spark_bench.jsonio import to_json_text

    benchmark = Benchmark(Path(bench))
    case_ids = selected_case_ids(benchmark, cases)
    runs, not_runs = find_runs(runs_dir)
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(out_dir, "predictions folder is a file")
    out_dir.mkdir(parents=True, exist_ok=True)
    chosen, superseded, unknown = match_runs(runs, case_ids)
    report = ImportReport(Path(runs_dir), out_dir, alignment, Path(bench), not_runs=not_runs,
                          unknown=[r.path.name for r in unknown], superseded=[r.path.name for r in superseded])
    for case_id in case_ids:
        benchmark.case_dir(case_id)  # refuses an id that would leave the folder
        target = out_dir / case_id
        run = chosen.get(case_id)
        if run is None:
            report.cases.append(CaseImport(case_id, None, False, "no SPARK run for this case",
                                           removed_stale=remove_stale_import(target)))
            continue
        diagnosis = layout.diagnose(run.path, tag or _tag_of(run.path))
        try:
            case = benchmark.case(case_id)
            camera = case.read_camera() if alignment == "camera" else None
            result = read_spark_run(run.path, tag, alignment, camera, case.camera_path if camera else None,
                                    name=case_id)
        except InputError as exc:
            report.cases.append(CaseImport(case_id, run.path, False, str(exc), diagnosis.failed_stage,
                                           removed_stale=remove_stale_import(target)))
            continue
        result.record["case_id"] = case_id
        write_import(result.asset, result.record, target)
        driver = result.record.get("driver")
        label = str(driver["label"]) if isinstance(driver, dict) and driver.get("label") else None
        report.cases.append(CaseImport(case_id, run.path, True, "", diagnosis.failed_stage, result.record["urdf"],
                                       label=label))
    (out_dir / SUMMARY).write_text(to_json_text(report.to_dict(), indent=1) + "\n")
    return report


def _tag_of(run_dir: Path) -> str:
    from spark_bench.formats.spark.reader import inference_dirs

    dirs = inference_dirs(run_dir, None)
    return dirs[0].name if dirs else layout.DEFAULT_TAG
