"""Benchmark-case preparation: object folders -> cases (``spark-bench data prepare``).

For each object (docs/formats.md, "Benchmark"): read it; merge each link's visuals into one mesh with
the area-weighted mean colour; make it watertight (SPARK appendix remesh); keep only convex collision
shapes; normalize into the benchmark frame; write the ground truth (with the source's GAPartNet part
classes, when it has them); render the input (rest) and open states with per-link masks from a seeded
front view (or the fixed view of :class:`PrepareOptions`), of the source meshes as SPARK renders (or of the
remesh, ``render_mesh="watertight"``); write the camera and, last, the case record
(:class:`~spark_bench.data.case.BenchmarkCase` names the files). A case is built in a hidden temporary
folder and renamed into place, so a case folder with a record is always complete and a killed run
resumes where it stopped.
"""

from __future__ import annotations

import multiprocessing
import shutil
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from spark_bench.asset.model import ArticulatedAsset, Link, Visual
from spark_bench.convention import CONVENTION_VERSION
from spark_bench.data.case import Benchmark, BenchmarkCase
from spark_bench.data.contact_sheet import write_contact_sheet
from spark_bench.data.readers import URDF_NAMES, load_object
from spark_bench.data.real_size import source_scale
from spark_bench.errors import InputError, SparkBenchError
from spark_bench.ray_executor import connect_ray, ray_map, require_paths
from spark_bench.timing import StageTimer

#: Stages timed by :func:`prepare_case` (``benchmarks/measure_prepare.py`` reports them); the timer also
#: holds ``render.scene``, the part of ``render`` spent building the MuJoCo scene.
STAGES = ("load", "merge", "watertight", "normalize_write", "render")
#: What :class:`PrepareOptions` may render the images from; the first is the default. ``source`` is what
#: SPARK renders (``datasets/preprocess/render.py`` loads the object's ``textured_objs/*.obj``; its points
#: come from the watertight ``voxel.glb``). Options stored without the key are of builds made before
#: ``source`` became the default, which rendered the watertight remesh.
RENDER_MESHES = ("source", "watertight")


@dataclass
class PrepareOptions:
    """How cases are made; stored in the manifest so a resumed run cannot mix settings.

    :param image_size: width and height of the renders in pixels (the paper used 2048)
    :param resolution: watertight remesh voxels along a part's largest axis (R; the paper's 200)
    :param n_min: minimum voxels across a part's thinnest axis (N_min)
    :param fov_deg: vertical field of view of the camera
    :param distance: radius of the camera sphere (benchmark frame)
    :param seed: base seed of the per-case views
    :param azimuth_deg: a fixed camera azimuth for every case (degrees from +X towards +Y; 180: the
        object's front); None: a seeded view of the front hemisphere per case
    :param elevation_deg: the fixed camera elevation (degrees above the XY plane), given with ``azimuth_deg``
    :param render_mesh: what the images are rendered from: ``"source"`` (the default, as SPARK renders:
        each link's merged source mesh with the ground truth's colour, in the benchmark frame) or
        ``"watertight"`` (the ground-truth remesh, 10^5-10^6 faces per link at R=200, the default before
        issue 12: a scene about 10x slower to build; the masks differ from the source meshes' by about
        1-2 % IoU where the remesh thickens thin parts; ``benchmarks/results/prepare_speed.md``). The
        ground truth is the remesh either way.
    """

    image_size: int = 512
    resolution: int = 200
    n_min: int = 3
    fov_deg: float = 40.0
    distance: float = 4.0
    seed: int = 0
    azimuth_deg: float | None = None
    elevation_deg: float | None = None
    render_mesh: str = RENDER_MESHES[0]

    def __post_init__(self):
        if self.render_mesh not in RENDER_MESHES:
            raise SparkBenchError(f"invalid prepare options {self}: render_mesh is one of {RENDER_MESHES}")
        if self.image_size < 16 or self.resolution < 4 or self.n_min < 1:
            raise SparkBenchError(f"invalid prepare options {self}: image_size >= 16, resolution >= 4, n_min >= 1")
        if (self.azimuth_deg is None) != (self.elevation_deg is None):
            raise SparkBenchError(f"invalid prepare options {self}: give both azimuth_deg and elevation_deg, or neither")

    def to_json(self) -> dict:
        """The options as the manifest stores them; a fixed view's angles only when set, so the options of
        a seeded-view benchmark read as they did before fixed views existed."""
        out = asdict(self)
        if self.azimuth_deg is None:
            del out["azimuth_deg"], out["elevation_deg"]
        if self.render_mesh == "watertight":
            del out["render_mesh"]  # how builds made before the key existed read (they rendered the remesh)
        return out

    def view(self, case_id: str):
        """The case's camera: the fixed view when set, else the seeded front view of ``case_id``.

        :returns: ``(CameraView, view seed)``
        """
        from spark_bench.data.camera import CameraView, view_seed

        seed = view_seed(case_id, self.seed)
        if self.azimuth_deg is not None:
            return CameraView.on_sphere(self.azimuth_deg, self.elevation_deg, self.distance, self.image_size,
                                        self.fov_deg), seed
        return CameraView.front(seed, self.distance, self.image_size, self.fov_deg), seed


@dataclass
class CaseResult:
    """Outcome of one object: ``reason`` is None on success; ``seconds`` by stage (:data:`STAGES`)."""

    case_id: str
    reason: str | None = None
    seconds: dict[str, float] = field(default_factory=dict)
    skipped: bool = False


# ----- ground truth --------------------------------------------------------------------------
def link_color(link: Link) -> tuple[float, float, float, float]:
    """Area-weighted mean RGBA of a link's visuals (grey when it has none)."""
    if not link.visuals:
        return (0.7, 0.7, 0.7, 1.0)
    weights = np.array([float(v.mesh.area) for v in link.visuals]) + 1e-12
    colors = np.array([v.rgba for v in link.visuals], dtype=float)
    return tuple(float(c) for c in np.average(colors, axis=0, weights=weights))


def ground_truth_asset(asset: ArticulatedAsset, resolution: int = 200, n_min: int = 3,
                       timer: StageTimer | None = None) -> tuple[ArticulatedAsset, dict[str, dict]]:
    """The asset with one watertight mesh per link, its mean colour and only convex collisions.

    Non-convex mesh collisions are dropped: the simulator's converter decomposes the visual mesh.

    :param resolution: R of :func:`~spark_bench.asset.mesh.make_watertight`
    :param n_min: N_min of :func:`~spark_bench.asset.mesh.make_watertight`
    :returns: ``(asset, report per link)`` (same frame as the input)
    """
    from spark_bench.asset.mesh import make_watertight

    timer = timer or StageTimer()
    out = asset.copy(visuals=False)
    reports: dict[str, dict] = {}
    for name, link in out.links.items():
        original = asset.links[name]
        with timer("merge"):
            color = link_color(original)
            merged = original.merged_mesh() if original.has_geometry else None
            collisions = [c for c in link.collisions if c.is_convex]
        if merged is not None:
            with timer("watertight"):
                try:
                    mesh, report = make_watertight(merged, resolution=resolution, n_min=n_min)
                except ValueError as exc:
                    raise ValueError(f"link {name!r}: cannot make the mesh watertight: {exc}") from None
            reports[name] = {**asdict(report), "input_faces": int(len(merged.faces))}
            link.visuals = [Visual(mesh=mesh, rgba=color)]
        else:
            link.visuals = []
        link.collisions = collisions
    return out, reports


def source_render_asset(source: ArticulatedAsset, center: np.ndarray, scale: float) -> ArticulatedAsset:
    """The source asset as :func:`ground_truth_asset` colours it, one merged mesh per link, not remeshed,
    moved into the benchmark frame by the ground truth's normalization (``p = (p_world - center) * scale``).
    """
    from spark_bench.asset.ops import apply_normalization

    out = source.copy(visuals=False)
    for name, link in out.links.items():
        original = source.links[name]
        merged = original.merged_mesh() if original.has_geometry else None
        link.visuals = [Visual(mesh=merged, rgba=link_color(original))] if merged is not None else []
        link.collisions = []
    return apply_normalization(out, center, scale, copy=False)  # out is this function's own


def _joint_label(asset: ArticulatedAsset, joint_name: str) -> str:
    """The semantic label of what a joint moves: its child's, else the first labelled link below."""
    for link in asset.moving_links(joint_name):
        if asset.links[link].label:
            return asset.links[link].label
    return ""


#: GAPartNet's per-link annotation file of an object folder (read by :func:`~spark_bench.data.readers.load_object`).
GAPARTNET_ANNOTATIONS = "link_annotation_gapartnet.json"


def write_gapartnet_annotations(asset: ArticulatedAsset, folder: Path) -> Path | None:
    """Carry the source's GAPartNet part classes into an object folder (``link_annotation_gapartnet.json``:
    ``link_name``, ``is_gapart``, ``category`` per annotated link), so that the metrics can give each
    ground-truth joint its part class. The boxes (``bbox``, in the source's frame and units) are not
    carried. Nothing is written for an asset without annotations.

    :returns: the file written, or None
    """
    import json

    items = [{"link_name": name, "is_gapart": bool(link.annotations.get("is_gapart", True)),
              "category": str(link.annotations.get("category") or "")}
             for name, link in asset.links.items() if link.annotations.get("category")]
    if not items:
        return None
    path = Path(folder) / GAPARTNET_ANNOTATIONS
    path.write_text(json.dumps(items, indent=1) + "\n")
    return path


def joint_records(asset: ArticulatedAsset) -> list[dict]:
    """The case record's ``joints``: every movable joint in file order, world frame at rest (a point on the axis
    and the unit axis), its limits and ``open``, the value it has in ``open.png``."""
    frames = asset.joint_frames()
    out = []
    for joint in asset.movable_joints():
        origin, axis = frames[joint.name]
        out.append({"name": joint.name, "type": joint.type, "parent": joint.parent, "child": joint.child,
                    "axis": [float(x) for x in axis], "origin": [float(x) for x in origin],
                    "lower": float(joint.lower), "upper": float(joint.upper), "open": float(joint.open_value),
                    "label": _joint_label(asset, joint.name)})
    return out


# ----- images ----------------------------------------------------------------------------------
def write_rgb(path: Path, rgb: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(rgb, dtype=np.uint8)).save(path)


def write_segmentation(path: Path, labels: np.ndarray) -> None:
    """16-bit grey PNG of link labels (0 background, k + 1 = index k into the case's ``links``)."""
    from PIL import Image

    Image.fromarray(np.ascontiguousarray(labels, dtype=np.uint16)).save(path)


def read_segmentation(path: str | Path) -> np.ndarray:
    """A segmentation image (:func:`write_segmentation`) as an ``(H, W)`` uint16 array."""
    from PIL import Image

    with Image.open(path) as image:
        return np.asarray(image).astype(np.uint16)


# ----- one case -------------------------------------------------------------------------------
def prepare_case(src: str | Path, case_dir: str | Path, options: PrepareOptions | None = None,
                 case_id: str | None = None, timer: StageTimer | None = None) -> dict:
    """Build one benchmark case from an object folder; returns the ``case.json`` record.

    Built in ``.<id>.partial`` beside ``case_dir`` and renamed into place at the end (an existing
    ``case_dir`` is replaced); the record (:attr:`BenchmarkCase.record`) is written last.

    :param src: object folder (PartNet-Mobility layout) or URDF file
    :param case_dir: the case folder to create (:meth:`~spark_bench.data.case.Benchmark.case_dir`)
    :param options: see :class:`PrepareOptions`
    :param case_id: the case id (default: the name of ``case_dir``)
    :param timer: collects seconds per stage (:data:`STAGES`)
    """
    from threadpoolctl import threadpool_limits

    # one BLAS thread: the products here are (N, 3) x (3, 3), whose extra threads only spin, and a run
    # with several workers already has a process per core
    with threadpool_limits(limits=1, user_api="blas"):
        return _prepare_case(Path(src), Path(case_dir), options or PrepareOptions(), case_id or Path(case_dir).name,
                             timer or StageTimer())


def _prepare_case(src: Path, case_dir: Path, options: PrepareOptions, case_id: str, timer: StageTimer) -> dict:
    """:func:`prepare_case`'s body, with its defaults filled in."""
    from spark_bench.asset.ops import normalize_asset
    from spark_bench.asset.urdf import write_object_folder
    from spark_bench.data.render import AssetRenderer

    work = case_dir.parent / f".{case_dir.name}.partial"
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    case = BenchmarkCase(work)
    try:
        with timer("load"):
            source = load_object(src)
            if not any(link.has_geometry for link in source.links.values()):
                raise InputError(src, "object has no visual geometry")
        gt, reports = ground_truth_asset(source, options.resolution, options.n_min, timer)
        with timer("normalize_write"):
            gt, center, scale = normalize_asset(gt, copy=False)  # gt is this function's own
            gt.name = case_id
            write_object_folder(gt, case.gt_dir)
            write_gapartnet_annotations(gt, case.gt_dir)
        view, seed = options.view(case_id)
        links = list(gt.links)
        with timer("render"):
            with timer("render.scene"):  # a sub-stage: building the MuJoCo model (mesh processing)
                shown = source_render_asset(source, center, scale) if options.render_mesh == "source" else gt
                renderer = AssetRenderer(shown, options.image_size, links=links)
            with renderer:
                for state, q in (("input", gt.rest_configuration()), ("open", gt.open_configuration())):
                    image = renderer.render(view, q)
                    rgb_path, seg_path = case.state_files(state)
                    write_rgb(rgb_path, image.rgb)
                    write_segmentation(seg_path, image.segmentation)
            view.save(case.camera_path)
        record = {
            "id": case_id, "category": gt.category, "source": str(src.resolve()),
            "links": links, "joints": joint_records(gt),
            "normalization": {"center": [float(c) for c in center], "scale": float(scale)},
            "source_scale": source_scale(src if src.is_dir() else src.parent, source.category).record(),
            "image_size": options.image_size, "view_seed": seed,
            "watertight": {"resolution": options.resolution, "n_min": options.n_min, "links": reports},
        }
        if options.render_mesh != "watertight":  # absent: a remesh render, as before the key existed
            record["render_mesh"] = options.render_mesh
        case.write_record(record)
        if case_dir.exists():
            shutil.rmtree(case_dir)
        work.rename(case_dir)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    return record


# ----- many cases -----------------------------------------------------------------------------
def find_objects(src: str | Path, ids: Sequence[str] | None = None) -> dict[str, Path]:
    """Object folders under ``src`` by id (folder name); ``src`` itself when it is one object.

    Every non-hidden sub-folder counts as an object, so one without a URDF is reported as failed
    rather than silently skipped.

    :param ids: keep only these ids (each must exist)
    """
    src = Path(src)
    if not src.is_dir():
        raise InputError(src, "source folder not found")
    if (src / URDF_NAMES["mobility"]).is_file() or (any(src.glob("*.urdf")) and not any(
            p.is_dir() and any(p.glob("*.urdf")) for p in src.iterdir())):
        found = {src.resolve().name: src}
    else:
        found = {p.name: p for p in sorted(src.iterdir()) if p.is_dir() and not p.name.startswith(".")}
    if not found:
        raise InputError(src, "no object folders found")
    if ids:
        missing = [i for i in ids if i not in found]
        if missing:
            raise InputError(src, f"no object folder for id(s) {', '.join(missing)}")
        found = {i: found[i] for i in ids}
    return found


def one_line(exc: BaseException) -> str:
    """An exception as a one-line reason for the manifest."""
    text = str(exc) if isinstance(exc, SparkBenchError) else f"{type(exc).__name__}: {exc}"
    return " ".join(text.split())


def _prepare_one(task: tuple[Path, Path, PrepareOptions]) -> CaseResult:
    """Worker body of ``(src, case_dir, options)``: never raises (but on interrupt); a failure is its reason."""
    src, case_dir, options = task
    timer = StageTimer()
    try:
        prepare_case(src, case_dir, options, case_dir.name, timer)
    except Exception as exc:  # any failure of one object is recorded and the run goes on
        return CaseResult(case_dir.name, one_line(exc), timer.wall)
    return CaseResult(case_dir.name, None, timer.wall)


def write_manifest(bench: Benchmark, name: str, options: PrepareOptions, failed: dict[str, str],
                   source: str | None, created: str | None = None) -> dict:
    """(Re)write the benchmark's manifest from its complete case folders and the failures of this run."""
    cases = bench.complete_case_ids()
    now = datetime.now(UTC).isoformat(timespec="seconds")
    manifest = {"name": name, "convention": CONVENTION_VERSION, "cases": cases,
                "failed": {k: v for k, v in sorted(failed.items()) if k not in cases},
                "created": created or now, "updated": now, "source": source, "options": options.to_json()}
    return bench.write_manifest(manifest)


@contextmanager
def bench_lock(bench: Path, wait: bool = False) -> Iterator[None]:
    """An exclusive lock on a benchmark folder, so two runs never write the same cases."""
    import fcntl

    bench.mkdir(parents=True, exist_ok=True)
    with open(bench / ".lock", "w") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            raise SparkBenchError(f"{bench}: another spark-bench process is preparing this benchmark") from None
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _previous(bench: Benchmark, options: PrepareOptions) -> dict:
    """The existing manifest of a resumed run; its options must match this run's."""
    if not bench.exists:
        return {}
    old = bench.manifest()
    if old.get("options") and old["options"] != options.to_json() and bench.complete_case_ids():
        raise SparkBenchError(f"{bench.folder}: prepared with other options {old['options']}; "
                              "use another output folder or --overwrite")
    return old


def prepare_benchmark(src: str | Path, out: str | Path, ids: Sequence[str] | None = None,
                      options: PrepareOptions | None = None, workers: int = 1, progress: bool = True,
                      name: str | None = None, overwrite: bool = False, contact_sheet: bool = True,
                      on_result=None, isolate: bool = False, executor: str = "local",
                      ray_address: str | None = None) -> dict:
    """Prepare every object under ``src`` into the benchmark folder ``out``; returns the manifest.

    Complete cases already in ``out`` are kept (resume); a failing object is recorded in the
    manifest's ``failed`` with its reason and the run goes on.

    :param src: a folder of object folders, or one object folder
    :param out: the benchmark folder
    :param ids: only these object ids
    :param workers: processes (1: in this process)
    :param progress: show a progress bar
    :param name: benchmark name (default: the folder name of ``out``)
    :param overwrite: rebuild complete cases too
    :param contact_sheet: write ``contact_sheet.png`` at the end
    :param on_result: called with each :class:`CaseResult` (timings), skipped ones included
    :param isolate: render in spawned processes even with one worker, so that this process opens no OpenGL
        context: a process that forks workers afterwards must not have rendered (``eval`` builds its
        benchmark and then forks; workers that render after such a fork hang in EGL's set-up)
    :param executor: ``local`` (``workers`` processes) or ``ray``: a Ray task per object on the cluster at
        ``ray_address``, else as ``eval`` finds one; every node must see ``src`` and ``out`` (docs/cluster.md)
    """
    if executor not in ("local", "ray"):
        raise SparkBenchError(f"unknown executor {executor!r}; choose from local, ray")
    if executor == "ray":  # before anything is written: an address nothing answers at is one line
        connect_ray(ray_address, workers)
    options = options or PrepareOptions()
    out = Path(out)
    bench = Benchmark(out)
    objects = find_objects(src, ids)
    with bench_lock(out):
        old = {} if overwrite else _previous(bench, options)
        bench.cases_dir.mkdir(parents=True, exist_ok=True)
        name = name or old.get("name") or out.resolve().name
        failed = {k: v for k, v in old.get("failed", {}).items() if k not in objects}
        todo = {}
        for case_id, path in objects.items():
            if not overwrite and bench.case(case_id).is_complete:
                if on_result:
                    on_result(CaseResult(case_id, skipped=True))
            else:
                todo[case_id] = path
        created = old.get("created")
        write_manifest(bench, name, options, failed, str(Path(src).resolve()), created)
        if executor == "ray" and todo:
            require_paths([str(Path(src).resolve()), str(out.resolve())])
        for result in _run(todo, bench, options, workers, progress, isolate, executor == "ray"):
            if result.reason is not None:
                failed[result.case_id] = result.reason
            if on_result:
                on_result(result)
            manifest = write_manifest(bench, name, options, failed, str(Path(src).resolve()), created)
            created = manifest["created"]
        manifest = write_manifest(bench, name, options, failed, str(Path(src).resolve()), created)
    if contact_sheet and manifest["cases"]:
        write_contact_sheet(out)
    return manifest


def _run(todo: dict[str, Path], bench: Benchmark, options: PrepareOptions, workers: int,
         progress: bool, isolate: bool = False, on_ray: bool = False) -> Iterator[CaseResult]:
    from tqdm import tqdm

    bar = tqdm(total=len(todo), desc="prepare", unit="case", disable=not progress or not todo)
    try:
        if not on_ray and not isolate and (workers <= 1 or len(todo) <= 1):
            for case_id, path in todo.items():
                bar.set_postfix_str(case_id)
                yield _prepare_one((path, bench.case_dir(case_id), options))
                bar.update()
            return
        # absolute: a Ray task runs in a worker whose working folder is not this process's
        tasks = [(path.resolve(), bench.case_dir(case_id).resolve(), options) for case_id, path in todo.items()]
        results = ray_map(_prepare_one, tasks, lambda task, reason: CaseResult(task[1].name, reason)) if on_ray \
            else _in_processes(tasks, workers)  # a task Ray could not finish: failed with the reason
        for result in results:
            bar.set_postfix_str(result.case_id)
            bar.update()
            yield result
    finally:
        bar.close()


def _in_processes(tasks: list[tuple[Path, Path, PrepareOptions]], workers: int) -> Iterator[CaseResult]:
    """Each :func:`_prepare_one` in a spawned worker process, each result as it ends."""
    # spawn: each worker opens its own OpenGL context, none inherited from a fork
    with ProcessPoolExecutor(max(1, workers), mp_context=multiprocessing.get_context("spawn")) as pool:
        for future in as_completed([pool.submit(_prepare_one, task) for task in tasks]):
            yield future.result()
