"""The benchmark case and the benchmark: the one owner of their file names, of ``manifest.json``, of
``case.json`` and of the benchmark frame in both directions (docs/formats.md, docs/conventions.md).

A benchmark folder::

    BENCH/
      manifest.json          name, cases (ids, in order), failed (id -> reason), options, convention
      contact_sheet.png      one thumbnail per case
      cases/<id>/
        case.json            written last: a case folder with it is complete
        input.png            the input image (rest state)      input_seg.png   its link labels
        open.png             the open state (joints at open)   open_seg.png    its link labels
        camera.json          intrinsics and pose of both images (OpenCV convention, benchmark frame)
        gt/                  the ground-truth object folder, in the benchmark frame

Every other module asks :class:`BenchmarkCase` and :class:`Benchmark` for these paths and records; the
file names are spelt out here only.

**The benchmark frame**: an asset posed at rest, its world-frame axis-aligned box centred at the origin
and scaled by ``2 / max extent`` (it fits [-1, 1]^3). :func:`benchmark_frame` is that similarity for any
asset; :meth:`BenchmarkCase.to_metres` takes a case's ``gt/`` back to its source object's frame in metres
(``case.json``'s ``normalization``).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from spark_bench.errors import InputError

# ----- the file names (here and nowhere else) ----------------------------------------------------
CASES_DIR = "cases"
MANIFEST = "manifest.json"
CONTACT_SHEET = "contact_sheet.png"
CASE_FILE = "case.json"
GT_DIR = "gt"
INPUT_IMAGE = "input.png"
INPUT_SEG = "input_seg.png"
OPEN_IMAGE = "open.png"
OPEN_SEG = "open_seg.png"
CAMERA_FILE = "camera.json"
#: The rendered states of a case: ``(image, segmentation)`` file names by state.
STATE_FILES = {"input": (INPUT_IMAGE, INPUT_SEG), "open": (OPEN_IMAGE, OPEN_SEG)}


# ----- the benchmark frame ------------------------------------------------------------------------
def benchmark_frame(asset, q=None) -> np.ndarray:
    """The 4x4 similarity from ``asset``'s world frame into its benchmark frame.

    :param asset: an :class:`~spark_bench.asset.model.ArticulatedAsset`
    :param q: the configuration the box is taken at (default: rest)
    """
    from spark_bench.asset.ops import normalization

    center, scale = normalization(asset, q)
    matrix = np.eye(4)
    matrix[:3, :3] *= scale
    matrix[:3, 3] = -scale * np.asarray(center, dtype=np.float64)
    return matrix


def to_benchmark_frame(asset):
    """``(asset in its benchmark frame, center, scale)``: a copy centred and scaled into [-1, 1]^3.

    ``center`` and ``scale`` are what ``case.json``'s ``normalization`` stores.
    """
    from spark_bench.asset.ops import normalize_asset

    return normalize_asset(asset)


def prediction_to_gt_world(pred, gt_bench, alignment=None) -> np.ndarray:
    """The 4x4 similarity from the prediction's world frame into the ground truth's as stored: prediction
    world -> its benchmark frame (-> the metrics' ICP alignment) -> ground-truth world.

    :param pred: predicted asset
    :param gt_bench: the ground truth as stored (a case's ``gt/``: the benchmark frame)
    :param alignment: optional 4x4 similarity the metrics applied to the prediction's benchmark frame
    """
    align = np.asarray(alignment if alignment is not None else np.eye(4), dtype=np.float64)
    return np.linalg.inv(benchmark_frame(gt_bench)) @ align @ benchmark_frame(pred)


def prediction_to_gt_metres(pred, gt_bench, alignment=None, bench_to_metres=None) -> np.ndarray:
    """The 4x4 similarity from the prediction's world frame into the ground truth's in metres, where robots
    act on it: :func:`prediction_to_gt_world`, then ``bench_to_metres``.

    :param pred: the predicted asset as stored
    :param gt_bench: the ground truth as stored (a case's ``gt/``: the benchmark frame)
    :param alignment: 4x4 similarity the metrics applied to the prediction's benchmark frame, or None
    :param bench_to_metres: 4x4 from ``gt_bench`` to metres (:func:`ground_truth_in_metres`'s third
        value), or None for a ground truth stored in metres
    """
    frame = prediction_to_gt_world(pred, gt_bench, alignment)
    return (np.asarray(bench_to_metres, dtype=np.float64) if bench_to_metres is not None else np.eye(4)) @ frame


def ground_truth_in_metres(gt_folder: str | Path, gt_bench=None):
    """``(gt_bench, gt_metres, bench_to_metres)``: the ground truth as stored, the same object in metres,
    and the 4x4 from the first to the second.

    A benchmark case's ground truth is stored in the benchmark frame ([-1, 1]^3) and comes back to its
    source's size and place (:meth:`BenchmarkCase.gt_at_source_size`): robots act on objects at their real
    size. Any other object folder is taken to be in metres already: ``gt_metres`` is ``gt_bench`` itself and
    the matrix the identity.

    :param gt_folder: the ground-truth object folder (a case's ``gt/``, or any object folder)
    :param gt_bench: that folder's object if the caller already loaded it (not modified; a real case's R=200
        remesh takes ~0.6 s CPU to load)
    """
    from spark_bench.data.readers import load_object

    gt_bench = load_object(gt_folder) if gt_bench is None else gt_bench
    case = BenchmarkCase.of_gt_folder(gt_folder)
    if case is None:
        return gt_bench, gt_bench, np.eye(4)
    gt_metres, bench_to_metres = case.gt_at_source_size(gt_bench)
    return gt_bench, gt_metres, bench_to_metres


def metres_from_normalization(normalization, where: Path | None = None) -> np.ndarray:
    """The 4x4 similarity from a benchmark frame back to the source frame, from a ``normalization``
    record ``{"center": [x, y, z], "scale": s}``.

    :raises InputError: naming ``where`` when the record is malformed
    """
    from spark_bench.asset.ops import denormalization

    try:
        center = np.asarray(normalization["center"], dtype=np.float64)
        scale = float(normalization["scale"])
    except (TypeError, KeyError, ValueError):
        raise InputError(where, 'expected "normalization": {"center": [x, y, z], "scale": s}') from None
    if center.shape != (3,) or not np.all(np.isfinite(center)) or not np.isfinite(scale) or scale <= 0:
        raise InputError(where, f"bad normalization: center {center.tolist()}, scale {scale}")
    return denormalization(center, scale)


# ----- one case ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class BenchmarkCase:
    """One benchmark case folder.

    :param folder: the case folder (``BENCH/cases/<id>``)
    """

    folder: Path

    def __post_init__(self):
        object.__setattr__(self, "folder", Path(self.folder))

    # --- paths
    @property
    def record_path(self) -> Path:
        """``case.json``."""
        return self.folder / CASE_FILE

    @property
    def input_image(self) -> Path:
        return self.folder / INPUT_IMAGE

    @property
    def input_seg(self) -> Path:
        return self.folder / INPUT_SEG

    @property
    def open_image(self) -> Path:
        return self.folder / OPEN_IMAGE

    @property
    def open_seg(self) -> Path:
        return self.folder / OPEN_SEG

    @property
    def camera_path(self) -> Path:
        return self.folder / CAMERA_FILE

    @property
    def gt_dir(self) -> Path:
        """The ground-truth object folder (benchmark frame)."""
        return self.folder / GT_DIR

    def state_files(self, state: str) -> tuple[Path, Path]:
        """``(image, segmentation)`` of a rendered state (``input`` or ``open``)."""
        image, seg = STATE_FILES[state]
        return self.folder / image, self.folder / seg

    @property
    def is_complete(self) -> bool:
        """A case is complete when its ``case.json`` (written last) exists."""
        return self.record_path.is_file()

    # --- case.json
    @cached_property
    def record(self) -> dict:
        """``case.json`` (read once).

        :raises InputError: naming the file when it is absent, malformed or has no ``id``
        """
        from spark_bench.data.readers import read_json

        case = read_json(self.record_path, missing="case file not found (incomplete case?)")
        if not isinstance(case, dict) or "id" not in case:
            raise InputError(self.record_path, 'expected an object with an "id"')
        return case

    @property
    def id(self) -> str:
        return str(self.record["id"])

    def fingerprint(self) -> str:
        """A hash of what a method sees of the case and what it is scored against: ``case.json`` without
        its ``source`` path (which moves with the data; the record holds the normalization, the image
        size, the view, the render mode and the remesh's report), the rendered states and the camera.
        A benchmark prepared again with other settings gives its cases other fingerprints, so an
        ``eval`` resumed on it scores them again instead of mixing the two builds; the same build moved
        to another folder keeps them.

        :raises InputError: naming ``case.json`` when the case is incomplete
        """
        digest = hashlib.sha256()
        record = {key: value for key, value in self.record.items() if key != "source"}
        digest.update(json.dumps(record, sort_keys=True).encode())
        for name in (*(n for pair in STATE_FILES.values() for n in pair), CAMERA_FILE):
            path = self.folder / name
            digest.update(f"\0{name}\0".encode())
            if path.is_file():
                digest.update(path.read_bytes())
        return digest.hexdigest()[:16]

    @property
    def category(self) -> str:
        return str(self.record.get("category", "") or "")

    @property
    def links(self) -> list[str]:
        """The link names that the segmentation labels index (label k + 1 is link k).

        :raises InputError: naming ``case.json`` when ``links`` is not a list of names
        """
        links = self.record.get("links")
        if not isinstance(links, list) or not all(isinstance(n, str) for n in links):
            raise InputError(self.record_path, '"links" must be the list of link names that the '
                                               'segmentation images index')
        return links

    def write_record(self, record: dict) -> None:
        """Write ``case.json`` (last, when every other file of the case is in place)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        self.record_path.write_text(json.dumps(record, indent=1) + "\n")
        self.__dict__.pop("record", None)

    # --- the ground truth and its frames
    def load_gt(self, load_meshes: bool = True):
        """The ground-truth object, in the benchmark frame."""
        from spark_bench.data.readers import load_object

        if not self.gt_dir.is_dir():
            raise InputError(self.folder, f"benchmark case has no {GT_DIR}/ object folder")
        return load_object(self.gt_dir, load_meshes=load_meshes)

    def to_metres(self) -> np.ndarray:
        """The 4x4 similarity from this case's benchmark frame (its ``gt/``) back to the source object's
        world frame in metres (``case.json``'s ``normalization``). Physics needs the real size: a cabinet
        normalized to [-1, 1]^3 is two metres tall."""
        return metres_from_normalization(self.record.get("normalization"), self.record_path)

    def gt_at_source_size(self, gt_bench=None):
        """``(gt_metres, bench_to_metres)``: the ground truth in metres and the 4x4 from the benchmark frame
        to metres.

        :param gt_bench: the case's ground truth as stored (benchmark frame) if already loaded (it is not
            modified)
        """
        from spark_bench.asset.ops import similarity_asset

        gt_bench = self.load_gt() if gt_bench is None else gt_bench
        bench_to_metres = self.to_metres()
        return similarity_asset(gt_bench, bench_to_metres), bench_to_metres

    @property
    def source_folder(self) -> Path | None:
        """The object folder (or URDF file) the case was prepared from (``case.json``'s ``source``), or None
        when the record names none. It may not exist on this machine (a benchmark prepared elsewhere)."""
        source = self.record.get("source")
        return Path(source) if isinstance(source, str) and source else None

    def load_source(self):
        """The object the case was prepared from, as the dataset gives it: its own meshes (not the
        remesh), in its own frame and units, which are those of :meth:`gt_at_source_size` (``data prepare``
        remeshes the source in its frame and only then normalizes it).

        :raises InputError: naming the folder when the record names none or it is not on this machine
        """
        from spark_bench.data.readers import load_object

        folder = self.source_folder
        if folder is None or not folder.exists():
            raise InputError(folder or self.record_path, "source object not found")
        return load_object(folder)

    @classmethod
    def of_gt_folder(cls, folder: str | Path) -> BenchmarkCase | None:
        """The case whose ground truth is ``folder``, or None when ``folder`` is not a case's ``gt/``."""
        folder = Path(folder)
        case = cls(folder.parent)
        if folder.name == GT_DIR and case.is_complete:
            return case
        return None

    @classmethod
    def of_folder(cls, folder: str | Path) -> BenchmarkCase | None:
        """The case in ``folder``, or None when ``folder`` holds no complete case."""
        case = cls(Path(folder))
        return case if Path(folder).is_dir() and case.is_complete else None

    # --- images
    def read_camera(self) -> dict:
        """``camera.json`` as a dict (InputError naming the file when absent or not an object)."""
        from spark_bench.data.readers import read_json

        camera = read_json(self.camera_path, missing="camera file not found")
        if not isinstance(camera, dict):
            raise InputError(self.camera_path, "expected a JSON object")
        return camera

    def read_segmentation(self, state: str = "open") -> np.ndarray:
        """The ``(H, W)`` uint16 link labels of a rendered state (0 background, k + 1 = link k)."""
        from PIL import Image

        path = self.state_files(state)[1]
        if not path.is_file():
            raise InputError(path, "segmentation image not found")
        try:
            with Image.open(path) as image:
                seg = np.asarray(image)
        except OSError as exc:
            raise InputError(path, f"unreadable image: {exc}") from None
        if seg.ndim == 3:
            seg = seg[..., 0]
        return seg.astype(np.uint16)

    def part_masks(self, state: str = "open") -> dict[str, np.ndarray]:
        """The visible mask of each link in a rendered state, by link name (links not in view absent)."""
        seg = self.read_segmentation(state)
        links = self.links
        out = {}
        for k, name in enumerate(links):
            mask = seg == k + 1
            if mask.any():
                out[name] = mask.astype(np.float64)
        return out


# ----- the benchmark ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Benchmark:
    """A benchmark folder: its manifest and its cases.

    :param folder: the benchmark folder (``BENCH``)
    """

    folder: Path

    def __post_init__(self):
        object.__setattr__(self, "folder", Path(self.folder))

    @property
    def manifest_path(self) -> Path:
        return self.folder / MANIFEST

    @property
    def cases_dir(self) -> Path:
        return self.folder / CASES_DIR

    @property
    def contact_sheet_path(self) -> Path:
        return self.folder / CONTACT_SHEET

    @property
    def exists(self) -> bool:
        """Whether the folder holds a manifest."""
        return self.manifest_path.is_file()

    def manifest(self) -> dict:
        """``manifest.json`` (InputError naming it when absent or malformed)."""
        from spark_bench.data.readers import read_json

        data = read_json(self.manifest_path,
                         missing="not a benchmark folder: no manifest (run `spark-bench data prepare`)")
        if not isinstance(data, dict) or not isinstance(data.get("cases"), list):
            raise InputError(self.manifest_path, 'expected an object with a "cases" list')
        return data

    def write_manifest(self, manifest: dict) -> dict:
        """Write ``manifest.json`` atomically (a reader never sees half a file); returns ``manifest``."""
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = self.folder / f".{MANIFEST}.tmp"
        tmp.write_text(json.dumps(manifest, indent=1) + "\n")
        tmp.replace(self.manifest_path)
        return manifest

    @property
    def name(self) -> str:
        """The manifest's name, else the folder's."""
        return str(self.manifest().get("name") or self.folder.resolve().name)

    def case_ids(self) -> list[str]:
        """The case ids in manifest order."""
        return [str(c) for c in self.manifest()["cases"]]

    def complete_case_ids(self) -> list[str]:
        """Ids of the complete case folders, sorted (whatever the manifest says)."""
        if not self.cases_dir.is_dir():
            return []
        return sorted(p.name for p in self.cases_dir.iterdir()
                      if not p.name.startswith(".") and BenchmarkCase(p).is_complete)

    def case_dir(self, case_id: str) -> Path:
        """The folder of case ``case_id`` (it may not exist yet).

        :raises InputError: for an id that would leave the cases folder
        """
        case_id = str(case_id)
        if not case_id or case_id in (".", "..") or "/" in case_id or "\\" in case_id:
            raise InputError(self.cases_dir, f"unsafe case id {case_id!r}")
        return self.cases_dir / case_id

    def case(self, case_id: str) -> BenchmarkCase:
        """Case ``case_id``."""
        return BenchmarkCase(self.case_dir(case_id))

    def cases(self) -> list[BenchmarkCase]:
        """Every case of the manifest, in order."""
        return [self.case(c) for c in self.case_ids()]


__all__ = ["CAMERA_FILE", "CASES_DIR", "CASE_FILE", "CONTACT_SHEET", "GT_DIR", "INPUT_IMAGE", "INPUT_SEG",
           "MANIFEST", "OPEN_IMAGE", "OPEN_SEG", "STATE_FILES", "Benchmark", "BenchmarkCase", "benchmark_frame",
           "metres_from_normalization", "to_benchmark_frame"]
