"""Resuming a run: which cases already have a result scored on the benchmark's present build.

A row is final for its run (method label, configuration hash, metric convention) and for the build of
the case it was scored on: the case's :meth:`~spark_bench.data.case.BenchmarkCase.fingerprint` is stored
with every row and generation. A benchmark prepared again with other settings (the render mode, the image
size, the remesh resolution) gives its cases other fingerprints, and ``eval`` scores them again instead of
averaging rows of two builds.
"""

from __future__ import annotations

from collections.abc import Iterable

from spark_bench.data.case import Benchmark
from spark_bench.errors import InputError
from spark_bench.evaluation.store import ResultsStore


def case_fingerprints(bench: Benchmark, case_ids: Iterable[str]) -> dict[str, str]:
    """:meth:`~spark_bench.data.case.BenchmarkCase.fingerprint` of each case; an incomplete case has none
    (its task fails with the case's own reason).

    :param bench: the benchmark
    :param case_ids: the cases to fingerprint
    """
    out = {}
    for cid in case_ids:
        try:
            out[cid] = bench.case(cid).fingerprint()
        except (InputError, OSError):
            continue
    return out


def scored_on_this_build(store: ResultsStore, run, fingerprints: dict[str, str]) -> set[str]:
    """The cases of ``run`` with a final result scored on the benchmark's present build: a row made
    from other images or another ground truth of the case (a benchmark prepared again, with another
    render mode or resolution), or made before rows carried the case's fingerprint, is scored again.

    :param store: the results store
    :param run: the run's :class:`~spark_bench.evaluation.runner.RunIdentity` (its bench, label, config hash)
    :param fingerprints: the cases' fingerprints now (:func:`case_fingerprints`)
    """
    done = store.done_cases(run.bench, run.label, run.config_hash)
    stored = {r["case_id"]: (r.get("info") or {}).get("case_fingerprint")
              for r in store.rows(bench=run.bench, label=run.label, where=[("config_hash", run.config_hash)])
              if r["variant"] == "" and r["case_id"] in done}
    return {cid for cid in done if fingerprints.get(cid) is not None and stored.get(cid) == fingerprints[cid]}
