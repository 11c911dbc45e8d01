"""``spark-bench data export-images``: each case's input image as ``DIR/<case id>.png``, ready to be
SPARK's ``image/`` folder (``run.py`` takes every ``*.png|*.jpeg|*.jpg`` there and names each run
``<file stem>_<timestamp>``, so the run folders carry the case ids back to ``import spark``)."""

from __future__ import annotations

import shutil
from pathlib import Path

from spark_bench.errors import InputError


def export_images(bench: str | Path, out_dir: str | Path, cases: list[str] | None = None) -> tuple[list[Path], list[str]]:
    """Copy every case's input image to ``out_dir/<case id>.png``.

    :param bench: the benchmark folder
    :param out_dir: the folder to write (created)
    :param cases: only these case ids (default: every case)
    :returns: ``(images written, "case: why" for cases without an input image)``
    :raises InputError: when ``bench`` is not a benchmark or a case id is unknown or unsafe
    """
    from spark_bench.data.case import Benchmark

    benchmark = Benchmark(Path(bench))
    ids = benchmark.case_ids()
    unknown = [c for c in cases or () if c not in ids]
    if unknown:
        raise InputError(benchmark.manifest_path, f"no case {unknown[0]!r} in this benchmark")
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(out_dir, "output folder is a file")
    out_dir.mkdir(parents=True, exist_ok=True)
    written, missing = [], []
    for case_id in ids:
        if cases and case_id not in cases:
            continue
        source = benchmark.case(case_id).input_image  # case() refuses unsafe ids
        if not source.is_file():
            missing.append(f"{case_id}: no input image ({source})")
            continue
        target = out_dir / f"{case_id}.png"
        shutil.copyfile(source, target)
        written.append(target)
    return written, missing
