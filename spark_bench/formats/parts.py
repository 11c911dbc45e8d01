"""Shape-only part methods: one object as part meshes (one GLB per part, or one GLB scene of parts), read
as PartCrafter and OmniPart write them. No joints: every part is a link hanging from a root by a fixed
joint, and the articulation metrics of these rows are n/a (``articulated=False``).

The facts, each with where it comes from:

**PartCrafter** (``wgsxm/PartCrafter``, read at its newest snapshot; SPARK's fork ``YumengHe/PartCrafter``).

- Layout: ``scripts/inference_partcrafter.py`` (``__main__``) writes ``<output_dir>/<tag>/`` (the run
  folder): ``part_{i:02}.glb`` for each of the ``--num_parts`` parts (``mesh.export``), then
  ``object.glb``, the same parts as one scene, one geometry each with a random vertex colour
  (``src/utils/data_utils.py`` ``get_colored_mesh_composition``), and with ``--render`` the renders
  (``rendering*.gif``/``.png``, not read). ``scripts/inference_partcrafter_scene.py`` writes the same.
  The fork's ``scripts/inference_partcrafter_part.py`` adds ``object_scene_ordered.glb`` (the parts, one
  node ``{i:02d}_link_{i}`` each), ``part_order_mapping.json`` and ``input_*.png``. The reader takes
  the ``part_NN.glb`` files; only when there are none, one scene (``object_scene_ordered.glb``, else
  ``object.glb``), one part per scene node with geometry. ``object.glb`` is counted to find a part file
  that is missing: it holds one geometry per part.
- Failure: a part the pipeline cannot decode (``src/pipelines/pipeline_partcrafter.py`` ``__call__``:
  ``hierarchical_extract_geometry`` raising gives ``None``) is replaced by
  ``trimesh.Trimesh(vertices=[[0, 0, 0]], faces=[[0, 0, 0]])`` (``run_triposg``: "use a dummy mesh")
  and written like the others: a part with no surface. Such parts are passed over and listed
  (``failed_parts``); a run whose every part is one is an :class:`InputError`.
- Frame: every part is decoded in the one object box ``bounds = (-1.005, ..., 1.005)``
  (``pipeline_partcrafter.py`` ``__call__``; ``src/utils/inference_utils.py``
  ``hierarchical_extract_geometry``): the training objects are glTF scenes loaded by trimesh (Y up) and
  normalized to a box centred at 0 with largest side 2 (``data_utils.py`` ``normalize_mesh``, used by
  ``datasets/preprocess/mesh_to_point.py``). The conditioning image is rendered from azimuth 0,
  elevation 0 (``datasets/preprocess/render.py`` -> ``src/utils/render_utils.py``
  ``create_camera_pose_on_sphere``: camera at ``(0, 0, radius)``, up ``[0, 1, 0]``): the front seen in
  the image faces +Z. The reader turns Y up / front +Z into ours (Z up, front -X) with
  PartNet-Mobility's root rotation (:data:`Y_UP_TO_OURS`). The scale (a unit box) and the turn about the
  up axis (the input view) stay open.

**OmniPart** (``HKU-MMLab/OmniPart``: not in the index; read from the authors' own commits kept in the
history of the fork ``ericchen321/OmniPart``, their last one ``ceb1a4f``, 2025-11-06. The fork's later
commits change ``merge_parts``; the authors' version is the one followed).

- Layout: ``scripts/inference_omnipart.py`` writes ``<output_root>/<image stem>/`` (the run folder):
  ``img_mask_vis.png``, ``voxel_coords.npy``, ``voxel_coords_vis.ply``, ``bboxes.npy``,
  ``bboxes_vis.glb`` (the part boxes, not read), then ``modules/part_synthesis/process_utils.py``
  ``save_parts_outputs`` writes ``part{i}.glb`` for each part ``i >= 1`` (``i == 0``, the whole object,
  is skipped; a part whose ``to_glb`` returns None, no vertices or faces after post-processing, gets no
  file) and ``merged_gs.ply``/``exploded_gs.ply`` (Gaussians, not read); ``modules/inference_utils.py``
  ``merge_parts`` loads each ``part{i}.glb`` (``force='mesh'``), writes ``mesh_textured.glb`` (the parts,
  one geometry each) and ``mesh_segment.glb`` (the same with a random colour each) and deletes the
  ``part{i}.glb``. The demo (``app_utils.py``) also writes ``exploded_parts.glb`` (parts pushed apart:
  not read). The reader takes ``mesh_textured.glb``, else ``mesh_segment.glb``, one part per node; else
  the ``part{i}.glb`` left by a run that stopped before ``merge_parts`` (``part0.glb`` is never a part).
- Frame: the parts are TRELLIS meshes in its voxel cube ``[-0.5, 0.5]^3``, Z up
  (``representations/mesh/utils_cube.py`` ``get_defomed_verts``: ``v / res - 0.5``), turned Y up by
  ``utils/postprocessing_utils.py`` ``to_glb`` (``vertices @ [[1, 0, 0], [0, 0, -1], [0, 1, 0]]``, both
  branches). The reader turns them back (:data:`TRELLIS_GLB_TO_OURS`); the turn about Z and the scale
  stay open.

**Both.** Part files found by name must stay inside the run folder (a link leading out is an
:class:`InputError`), and so must every file read; a GLB that cannot be parsed (truncated...) or has
NaN vertices is an :class:`InputError` naming it.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from spark_bench.asset.model import ArticulatedAsset, Joint, Link, Visual
from spark_bench.errors import InputError
from spark_bench.formats.foreign import ForeignObject

FORMAT = "parts"
PARTCRAFTER = "wgsxm/PartCrafter"
PARTCRAFTER_FORK = "YumengHe/PartCrafter"
OMNIPART = "HKU-MMLab/OmniPart (authors' commit ceb1a4f in ericchen321/OmniPart)"

#: PartCrafter's part files (``f"part_{i:02}.glb"``) and scenes, in the order the reader prefers them.
PARTCRAFTER_PART = re.compile(r"^part_(\d{2,})\.glb$")
PARTCRAFTER_SCENES = ("object_scene_ordered.glb", "object.glb")
PARTCRAFTER_OBJECT = "object.glb"
#: OmniPart's scenes (``merge_parts``), preferred in this order, and its part files (``f"part{i}.glb"``).
OMNIPART_SCENES = ("mesh_textured.glb", "mesh_segment.glb")
OMNIPART_PART = re.compile(r"^part(\d+)\.glb$")
OMNIPART_NOT_READ = ("bboxes_vis.glb", "exploded_parts.glb", "merged_gs.ply", "exploded_gs.ply",
                     "voxel_coords_vis.ply")

#: Y up, front +Z (glTF; PartCrafter's input view) -> ours (Z up, front -X): PartNet-Mobility's root joint
#: rotation ``rpy="1.570796 0 -1.570796"`` (columns: where x, y, z go), as ``formats/spark/layout.py``.
Y_UP_TO_OURS = np.array([[0.0, 0.0, -1.0],
                         [-1.0, 0.0, 0.0],
                         [0.0, 1.0, 0.0]])
#: TRELLIS's ``to_glb`` multiplies row vertices by this (Z up -> Y up: a GLB point is ``(x, z, -y)``)...
TRELLIS_TO_GLB_ROWS = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
#: ...so ``v = TRELLIS_GLB_TO_OURS @ v_glb`` turns it back (TRELLIS's frame is Z up, as ours).
TRELLIS_GLB_TO_OURS = TRELLIS_TO_GLB_ROWS

PARTCRAFTER_FACTS = [
    {"fact": "run folder = <output_dir>/<tag>/: part_{i:02}.glb per part, object.glb = the same parts as "
             "one scene (one geometry each, random vertex colours)",
     "source": f"{PARTCRAFTER} scripts/inference_partcrafter.py __main__; src/utils/data_utils.py "
               "get_colored_mesh_composition"},
    {"fact": "the fork adds object_scene_ordered.glb (one node per part) and part_order_mapping.json",
     "source": f"{PARTCRAFTER_FORK} scripts/inference_partcrafter_part.py __main__ (build_ordered_scene)"},
    {"fact": "a part that fails to decode is written as a one-vertex degenerate mesh (no surface): "
             "passed over and listed in failed_parts",
     "source": f"{PARTCRAFTER} scripts/inference_partcrafter.py run_triposg; "
               "src/pipelines/pipeline_partcrafter.py __call__"},
    {"fact": "every part decoded in one object box [-1.005, 1.005]^3; training objects normalized to "
             "largest side 2 (unit box: scale left open)",
     "source": f"{PARTCRAFTER} src/pipelines/pipeline_partcrafter.py __call__ (bounds); "
               "src/utils/inference_utils.py hierarchical_extract_geometry; src/utils/data_utils.py "
               "normalize_mesh"},
    {"fact": "Y up (glTF scenes loaded by trimesh), front +Z (input view from (0, 0, radius), up +Y): "
             "turned to Z up, front -X by PartNet-Mobility's root rotation; the view's turn about the up "
             "axis left open",
     "source": f"{PARTCRAFTER} datasets/preprocess/render.py; src/utils/render_utils.py "
               "create_camera_pose_on_sphere; datasets/preprocess/mesh_to_point.py"},
]
OMNIPART_FACTS = [
    {"fact": "run folder = <output_root>/<image stem>/: part{i}.glb (i >= 1; part 0 is the whole object, "
             "never written) merged by merge_parts into mesh_textured.glb and mesh_segment.glb (one "
             "geometry per part), then deleted; a part whose to_glb returns None gets no file",
     "source": f"{OMNIPART} scripts/inference_omnipart.py; modules/part_synthesis/process_utils.py "
               "save_parts_outputs; modules/inference_utils.py merge_parts"},
    {"fact": "bboxes_vis.glb (boxes), exploded_parts.glb (demo: parts pushed apart) and the Gaussian PLYs "
             "are not parts: not read",
     "source": f"{OMNIPART} scripts/inference_omnipart.py; app_utils.py; process_utils.py"},
    {"fact": "TRELLIS voxel cube [-0.5, 0.5]^3, Z up, written Y up by to_glb "
             "(v @ [[1,0,0],[0,0,-1],[0,1,0]]): turned back; scale and the turn about Z left open",
     "source": f"{OMNIPART} modules/part_synthesis/utils/postprocessing_utils.py to_glb; "
               "modules/part_synthesis/representations/mesh/utils_cube.py get_defomed_verts"},
]


@dataclass
class Part:
    """One part read: its mesh in our frame, where it came from.

    :param mesh: the part's surface, in our frame (Z up)
    :param source: the file (and scene node) it was read from, relative to the run folder
    :param rgba: its mean colour, when the file has one
    """

    mesh: trimesh.Trimesh
    source: str
    rgba: tuple[float, float, float, float] | None = None


@dataclass
class Reading:
    """What one run folder gave: the method, its parts, and what was passed over.

    :param method: ``PartCrafter`` or ``OmniPart``
    :param parts: the parts with a surface, in file (or node) order
    :param failed: ``"source: why"`` for each part without a surface
    :param files: every file read, relative to the run folder
    :param facts: the facts applied (with their sources)
    :param frame: the method's frame, in words
    """

    method: str
    parts: list[Part] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    files: list[str] = field(default_factory=list)
    facts: list[dict] = field(default_factory=list)
    frame: str = ""


# ----- files ----------------------------------------------------------------------------------------------
def inside(run_dir: Path, path: Path) -> Path:
    """``path`` resolved, checked to stay inside ``run_dir`` (a link may lead out).

    :raises InputError: naming ``path`` when it leaves the run folder
    """
    resolved = path.resolve()
    if not resolved.is_relative_to(run_dir.resolve()):
        raise InputError(path, f"leads out of the run folder {run_dir} (to {resolved})")
    return resolved


def natural_key(name: str) -> list:
    """Sort key putting ``geometry_2`` before ``geometry_10``."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def numbered(run_dir: Path, pattern: re.Pattern) -> dict[int, Path]:
    """Index -> file of the files of ``run_dir`` whose names match ``pattern`` (one number group)."""
    return {int(m.group(1)): p for p in run_dir.iterdir() if (m := pattern.match(p.name)) and p.is_file()}


def load_glb(path: Path) -> trimesh.Scene | trimesh.Trimesh:
    """A GLB as trimesh reads it (unprocessed, file order).

    :raises InputError: for an empty file or one that cannot be parsed (truncated, not a GLB)
    """
    if path.stat().st_size == 0:
        raise InputError(path, "mesh file is empty (0 bytes)")
    try:
        with warnings.catch_warnings():  # texture UVs trimesh cannot use: not our concern
            warnings.simplefilter("ignore")
            return trimesh.load(str(path), file_type="glb", process=False, maintain_order=True)
    except Exception as exc:  # trimesh raises many kinds on a broken file
        raise InputError(path, f"cannot read GLB: {type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
                         ) from None


def surface_problem(mesh: trimesh.Trimesh) -> str | None:
    """None when ``mesh`` has a surface, else why not (PartCrafter's stand-in has one degenerate face)."""
    if len(mesh.faces) == 0:
        return f"{len(mesh.vertices)} vertices and no faces"
    if not float(mesh.area) > 0.0:
        return (f"{len(mesh.vertices)} vertices, {len(mesh.faces)} faces and no area "
                "(a failed part's stand-in)")
    return None


def _check_finite(mesh: trimesh.Trimesh, path: Path, what: str) -> None:
    if not np.all(np.isfinite(mesh.vertices)):
        raise InputError(path, f"{what} has NaN or infinite vertex coordinates")


def _mean_color(geom) -> tuple[float, float, float, float] | None:
    """The mean vertex or material colour of ``geom`` (for display only)."""
    visual = getattr(geom, "visual", None)
    colors = getattr(visual, "vertex_colors", None) if getattr(visual, "kind", None) == "vertex" else None
    if colors is not None and len(colors):
        mean = np.asarray(colors, dtype=float)[:, :3].mean(0) / 255.0
        return (*(float(c) for c in mean), 1.0)
    return None


def part_file(run_dir: Path, path: Path, rotation: np.ndarray) -> tuple[Part | None, str | None]:
    """One part GLB (every node of it, merged) in our frame: ``(part, None)``, or ``(None, why)`` when
    it has no surface.

    :raises InputError: when the file cannot be read, leaves the run folder or has NaN vertices
    """
    from spark_bench.asset.urdf import EmptyMeshError, load_mesh_file

    resolved = inside(run_dir, path)
    source = str(path.relative_to(run_dir))
    try:
        mesh, rgba = load_mesh_file(resolved)
    except EmptyMeshError as exc:
        return None, exc.problem
    problem = surface_problem(mesh)
    if problem:
        return None, problem
    return Part(trimesh.Trimesh(mesh.vertices @ rotation.T, mesh.faces, process=False), source, rgba), None


def scene_parts(run_dir: Path, path: Path, rotation: np.ndarray) -> tuple[list[Part], list[str]]:
    """One part per node with geometry of the scene GLB ``path`` (node transforms applied), in our
    frame, nodes in natural name order; and ``"source: why"`` for each node without a surface.

    :raises InputError: when the file cannot be read, leaves the run folder, holds no geometry or has
        NaN vertices
    """
    resolved = inside(run_dir, path)
    loaded = load_glb(resolved)
    rel = str(path.relative_to(run_dir))
    if isinstance(loaded, trimesh.Trimesh):
        loaded = trimesh.Scene(loaded)
    if not isinstance(loaded, trimesh.Scene) or not loaded.graph.nodes_geometry:
        raise InputError(path, "the scene holds no geometry (no part)")
    parts, failed = [], []
    for node in sorted(loaded.graph.nodes_geometry, key=natural_key):
        transform, geom_name = loaded.graph[node]
        geom = loaded.geometry[geom_name]
        source = f"{rel}#{node}"
        if not isinstance(geom, trimesh.Trimesh):
            failed.append(f"{source}: a {type(geom).__name__}, not a surface")
            continue
        _check_finite(geom, path, f"node {node!r}")  # before the area, which NaN would make look empty
        problem = surface_problem(geom)
        if problem:
            failed.append(f"{source}: {problem}")
            continue
        world = trimesh.transform_points(np.asarray(geom.vertices, dtype=float), transform)
        mesh = trimesh.Trimesh(world @ rotation.T, geom.faces, process=False)
        parts.append(Part(mesh, source, _mean_color(geom)))
    return parts, failed


def scene_count(run_dir: Path, path: Path) -> int:
    """How many geometry nodes the scene GLB ``path`` holds."""
    loaded = load_glb(inside(run_dir, path))
    return len(loaded.graph.nodes_geometry) if isinstance(loaded, trimesh.Scene) else 1


# ----- the two methods ------------------------------------------------------------------------------------
def read_part_files(run_dir: Path, files: dict[int, Path], first: int, reading: Reading,
                    rotation: np.ndarray) -> Reading:
    """The numbered part files ``files`` (numbers ``first``, ``first + 1``...) into ``reading``.

    :raises InputError: naming the first missing number's file (a gap: the method writes every number)
    """
    expected = range(first, first + len(files))
    if sorted(files) != list(expected):
        gap = next(i for i in range(first, max(files) + 1) if i not in files)
        raise InputError(run_dir / _numbered_name(files, gap),
                         f"part file missing: the run has parts {sorted(files)}, none numbered {gap}")
    for index in expected:
        part, problem = part_file(run_dir, files[index], rotation)
        reading.files.append(files[index].name)
        if part is None:
            reading.failed.append(f"{files[index].name}: {problem}")
        else:
            reading.parts.append(part)
    return reading


def _numbered_name(files: dict[int, Path], index: int) -> str:
    """The name the method gives part ``index``'s file: PartCrafter ``part_{i:02}``, OmniPart ``part{i}``."""
    sample = next(iter(files.values())).name
    return f"part_{index:02}.glb" if PARTCRAFTER_PART.match(sample) else f"part{index}.glb"


def read_partcrafter(run_dir: Path) -> Reading | None:
    """A PartCrafter run (``part_NN.glb``, else its scene), or None when the folder holds none of its files.

    :raises InputError: for a missing part file (``object.glb`` holds more parts than there are files)
    """
    reading = Reading("PartCrafter", facts=list(PARTCRAFTER_FACTS),
                      frame="PartCrafter: Y up, front +Z (input view), object box [-1, 1]^3")
    files = numbered(run_dir, PARTCRAFTER_PART)
    if files:
        read_part_files(run_dir, files, 0, reading, Y_UP_TO_OURS)
        whole = run_dir / PARTCRAFTER_OBJECT
        if whole.is_file():
            count = scene_count(run_dir, whole)
            reading.files.append(PARTCRAFTER_OBJECT)
            if count > len(files):
                raise InputError(run_dir / f"part_{len(files):02}.glb",
                                 f"part file missing: {PARTCRAFTER_OBJECT} holds {count} parts, the run has "
                                 f"part_00 .. part_{len(files) - 1:02} only")
        return reading
    for name in PARTCRAFTER_SCENES:
        if (run_dir / name).is_file():
            reading.parts, reading.failed = scene_parts(run_dir, run_dir / name, Y_UP_TO_OURS)
            reading.files.append(name)
            return reading
    return None


def read_omnipart(run_dir: Path) -> Reading | None:
    """An OmniPart run (``mesh_textured.glb``, else ``mesh_segment.glb``, else ``part{i}.glb``), or None
    when the folder holds none of its files."""
    reading = Reading("OmniPart", facts=list(OMNIPART_FACTS),
                      frame="OmniPart (TRELLIS): Z up, voxel cube [-0.5, 0.5]^3; GLB written Y up, "
                            "turned back")
    for name in OMNIPART_SCENES:
        if (run_dir / name).is_file():
            reading.parts, reading.failed = scene_parts(run_dir, run_dir / name, TRELLIS_GLB_TO_OURS)
            reading.files.append(name)
            return reading
    files = {i: p for i, p in numbered(run_dir, OMNIPART_PART).items() if i > 0}  # part0: the whole object
    if files:
        return read_part_files(run_dir, files, 1, reading, TRELLIS_GLB_TO_OURS)
    return None


def build_asset(parts: list[Part], name: str) -> ArticulatedAsset:
    """The object: a root ``base`` without geometry and one link ``part_<k>`` per part, hanging from it
    by a fixed joint at the identity (each part's mesh is in the object frame)."""
    links = {"base": Link("base", label="base")}
    joints = {}
    for k, part in enumerate(parts):
        visual = Visual(part.mesh, rgba=part.rgba or (0.7, 0.7, 0.7, 1.0), source=part.source)
        label = part.source.split("#")[-1].removesuffix(".glb")  # the file's or the node's name
        links[f"part_{k}"] = Link(f"part_{k}", [visual], label=label)
        joints[f"joint_{k}"] = Joint(f"joint_{k}", "fixed", "base", f"part_{k}")
    return ArticulatedAsset(name=name, links=links, joints=joints)


def read_run(run_dir: Path) -> ForeignObject:
    """One PartCrafter or OmniPart output folder, read into our frame (see the module docstring).

    :raises InputError: naming the file and the problem for every bad input
    """
    run_dir = Path(run_dir).resolve()
    if not run_dir.is_dir():
        raise InputError(run_dir, "run folder not found")
    reading = read_partcrafter(run_dir) or read_omnipart(run_dir)
    if reading is None:
        looked = ["part_NN.glb", *PARTCRAFTER_SCENES, *OMNIPART_SCENES, "part<i>.glb"]
        raise InputError(run_dir, "no part meshes of PartCrafter or OmniPart: looked for "
                                  f"{', '.join(looked)}")
    if not reading.parts:
        raise InputError(run_dir / reading.files[0], f"no part has a surface ({reading.method} wrote only "
                                                     f"failed parts: {'; '.join(reading.failed)})")
    asset = build_asset(reading.parts, run_dir.name)
    asset.source = str(run_dir)
    present = sorted(p.name for p in run_dir.iterdir() if p.name in OMNIPART_NOT_READ)
    record = {"format": FORMAT, "method": reading.method, "files": reading.files, "facts": reading.facts,
              "frame": reading.frame,
              "parts": [{"link": f"part_{k}", "source": p.source, "vertices": len(p.mesh.vertices),
                         "faces": len(p.mesh.faces)} for k, p in enumerate(reading.parts)],
              "failed_parts": reading.failed,
              "not_read": [f"{n} (not parts)" for n in present]}
    return ForeignObject(asset, record, articulated=False, open_questions=("yaw", "scale"))
