"""Predictions written beforehand (``--method predictions``), and the one reader of a predictions folder.

A predictions folder holds one object folder per case, ``DIR/<case id>/`` (PartNet-Mobility
conventions). :func:`prediction_folder` is how every user finds a case's folder in it: the
``predictions`` method and the ``predictions`` geometry backend of the SPARK pipeline. A case folder
written by ``spark-bench import spark`` holds ``import.json``; its results row then says which SPARK run,
which URDF of it (``mobility_optimized.urdf``...) and which alignment it came from
(:func:`spark_bench.formats.foreign.row_fields`).
"""

from __future__ import annotations

from pathlib import Path

from spark_bench.errors import InputError, SparkBenchError
from spark_bench.methods.base import CaseInput, Generation
from spark_bench.methods.options import MethodOption
from spark_bench.methods.registry import register_method


def prediction_folder(predictions_dir: str | Path, case_id: str) -> Path:
    """``<predictions_dir>/<case_id>/``: the object folder predicted for a case.

    :param predictions_dir: the predictions folder
    :param case_id: the case id
    :raises InputError: for a case id that would leave the predictions folder (empty, ``.``, ``..``, or
        with a path separator), or when the case has no folder there
    """
    case_id = str(case_id)
    if not case_id or case_id in (".", "..") or "/" in case_id or "\\" in case_id:
        raise InputError(predictions_dir, f"unsafe case id {case_id!r}")
    folder = Path(predictions_dir) / case_id
    if not folder.is_dir():
        raise InputError(folder, "no prediction folder for this case")
    return folder


@register_method("predictions")
class PredictionsFolder:
    """Predictions written beforehand by any method: ``DIR/<case id>/`` is the case's object folder.

    :param folder: the predictions folder
    :param label: display label (default ``predictions:<folder name>``)
    :param regime: the input regime the external method had (default ``image``)
    """

    name = "predictions"
    version = "1"
    inputs: tuple[str, ...] = ()
    accepts = {"predictions": MethodOption("the folder of one object folder per case id (required)", "path"),
               "label": MethodOption("display label of the rows (default: predictions:<folder name>)"),
               "regime": MethodOption("the input regime the external method had (default: image)")}

    def __init__(self, folder: str | Path, label: str | None = None, regime: str = "image"):
        self.folder = Path(folder).expanduser().resolve()
        if not self.folder.is_dir():
            raise InputError(self.folder, "predictions folder not found")
        self._label = label or f"predictions:{self.folder.name}"
        self.regime = regime

    @classmethod
    def from_options(cls, options: dict) -> PredictionsFolder:
        """The registry's factory: ``predictions`` (the folder), ``label``, ``regime``."""
        if not options.get("predictions"):
            raise SparkBenchError("--method predictions needs --method-args predictions=DIR")
        return cls(options["predictions"], options.get("label"), options.get("regime") or "image")

    def label(self) -> str:
        return self._label

    def prepare(self) -> None:
        """Nothing to prepare."""

    def config(self) -> dict:
        return {"predictions": str(self.folder)}

    def generate(self, case: CaseInput, out_dir: Path) -> Generation:
        """The case's folder of predictions (nothing is copied into ``out_dir``); its info names the folder
        and, for an imported SPARK run, what the import read (``spark_run``, ``spark_urdf``,
        ``spark_urdf_kind``, ``spark_alignment``)."""
        from spark_bench.formats.foreign import read_import_record, row_fields

        folder = prediction_folder(self.folder, case.case_id)
        record = read_import_record(folder)
        # a shape-only format's import (part meshes, no joints): its articulation metrics are n/a, not errors
        articulated = bool((record or {}).get("articulated", True))
        return Generation(folder, {"source": str(folder), **row_fields(record)},
                          articulation_metrics_valid=articulated)
